"""A servo_jp flood: PSM1/servo_jp published as fast as rclpy can, paced to at most 10 kHz,
for 10 s, every command a different insertion, the last one a distinct value.

Checks: the newest command is the one applied (measured_js after the flood); the simulation
kept its frame rate during the flood (/diagnostics frames_per_second and /clock counted over the
flood, against before it). Prints `FLOOD_START` / `FLOOD_END` (the Rust side samples the node's
memory between them) and `RESULT sent=.. rate_hz=.. fps_before=.. fps_during=..`.
"""

import time

import rclpy

from rclpy.qos import QoSProfile, DurabilityPolicy, ReliabilityPolicy
from diagnostic_msgs.msg import DiagnosticArray
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from common import Recorder, check

SECONDS = 10.0
MAX_RATE = 10_000.0

rec = Recorder("flood_driver")
rec.subscribe(JointState, "/PSM1/measured_js")
rec.subscribe(Clock, "/clock")
latched = QoSProfile(
    depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE
)
rec.subscribe(DiagnosticArray, "/diagnostics", latched)
servo = rec.publisher(JointState, "/PSM1/servo_jp")
rec.wait_for(lambda: rec.latest("/PSM1/measured_js") is not None, 15.0, "measured_js")
rec.wait_subscribers(servo)


def frames_per_second():
    values = {kv.key: kv.value for kv in rec.latest("/diagnostics").status[0].values}
    return float(values["frames_per_second"])


# Before: 6 s of the node alone (the status measures over its last 5 s).
rec.spin_for(6.0)
fps_before = frames_per_second()
q = list(rec.latest("/PSM1/measured_js").position)
start = q[2]
clocks_before = rec.count("/clock")

print("FLOOD_START", flush=True)
t0 = time.monotonic()
sent = 0
while True:
    now = time.monotonic()
    if now - t0 >= SECONDS:
        break
    if sent >= (now - t0) * MAX_RATE:
        continue
    # Insertion sweeps 0..4 mm and back in 1 µm steps: a new value every command.
    step = sent % 8000
    q[2] = start + 1e-6 * (step if step < 4000 else 8000 - step)
    servo.publish(JointState(position=list(q)))
    sent += 1
    if sent % 200 == 0:
        rclpy.spin_once(rec.node, timeout_sec=0.0)
# The newest command: a value the sweep never takes.
q[2] = start + 0.00525
servo.publish(JointState(position=list(q)))
sent += 1
elapsed = time.monotonic() - t0
clocks_during = rec.count("/clock") - clocks_before
rec.spin_for(0.05)
fps_during = frames_per_second()
print("FLOOD_END", flush=True)

# The node drains the flood's backlog at its own frame rate, which a loaded machine slows:
# wait for the newest command (a value no older command carries) rather than a fixed time,
# then make sure no older command overrides it afterwards.
newest = start + 0.00525


def insertion():
    return rec.latest("/PSM1/measured_js").position[2]


deadline = time.monotonic() + 15.0
while abs(insertion() - newest) >= 1e-6 and time.monotonic() < deadline:
    rclpy.spin_once(rec.node, timeout_sec=0.01)
rec.spin_for(1.0)
final = insertion()
check(abs(final - newest) < 1e-6,
      f"the newest command is applied and stays: insertion {final:.6f} m, commanded {newest:.6f} m")
rate = sent / elapsed
check(rate > 1000.0, f"flood of {sent} commands at {rate:.0f} Hz")
check(fps_during >= 0.85 * fps_before,
      f"frame rate held: {fps_during:.2f} frames/s during the flood, {fps_before:.2f} before")
print(f"RESULT sent={sent} rate_hz={rate:.0f} fps_before={fps_before:.2f} "
      f"fps_during={fps_during:.2f} clock_msgs_during={clocks_during}", flush=True)
rec.close()
