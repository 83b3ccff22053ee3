"""/clock and the node's status, as a user with `use_sim_time` sees them.

An rclpy node with use_sim_time subscribes /clock (rosgraph_msgs/msg/Clock) and /diagnostics
(diagnostic_msgs/msg/DiagnosticArray, latched). Checks: /clock carries simulated time (from
zero, not the wall clock's epoch), rising frame by frame; rclpy's own clock follows it; the
real-time factor measured here from /clock against the wall clock agrees with the one the
status reports; a run slower than real time is a WARN status that says by how much.

Prints `RESULT rtf_measured=.. rtf_status=.. clock_msgs=..`.
"""

import time

import rclpy
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, DurabilityPolicy, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import PointCloud2

from common import check, fail

rclpy.init()
node = rclpy.create_node(
    "clock_probe", parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)]
)
clocks = []  # (wall, simulated)
statuses = []


def on_clock(msg):
    clocks.append((time.monotonic(), msg.clock.sec + msg.clock.nanosec * 1e-9))


node.create_subscription(Clock, "/clock", on_clock, 10)
latched = QoSProfile(
    depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE
)
node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: statuses.append(m), latched)
# A cloud subscriber with rclpy's default QoS (reliable, keep last 10), as a user writes it:
# it makes RustDDS repair fragments of clouds its keep-last history has replaced (the node's
# log must not report that as an error).
clouds = []
node.create_subscription(PointCloud2, "/tissue/points", lambda m: clouds.append(len(m.data)), 10)


def spin_until(predicate, timeout, what):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return
        rclpy.spin_once(node, timeout_sec=0.01)
    fail(f"timed out after {timeout} s waiting for {what}")


spin_until(lambda: len(clocks) >= 3, 60.0, "/clock")
check(clocks[0][1] < 1e6, f"/clock is simulated time ({clocks[0][1]:.3f} s), not the epoch")
# Measure over a window of wall time while the status keeps coming.
start = len(clocks)
window_start = time.monotonic()
spin_until(lambda: time.monotonic() - window_start > 8.0 and len(statuses) >= 6, 60.0,
           "8 s of /clock and 6 statuses")
window = clocks[start:]
check(len(window) >= 5, f"{len(window)} /clock messages in the window")
sims = [s for _, s in window]
check(all(b >= a for a, b in zip(sims, sims[1:])), "/clock never goes back")
check(sims[-1] > sims[0], "/clock advances")
rtf_measured = (window[-1][1] - window[0][1]) / (window[-1][0] - window[0][0])

# rclpy's clock (use_sim_time) is the last /clock received.
rclpy.spin_once(node, timeout_sec=0.05)
now = node.get_clock().now().nanoseconds * 1e-9
check(abs(now - clocks[-1][1]) < 0.2 + 2 * (1 / 60),
      f"rclpy's clock {now:.4f} s follows /clock {clocks[-1][1]:.4f} s")

status = statuses[-1].status[0]
values = {kv.key: kv.value for kv in status.values}
for key in ("real_time_factor", "substeps_per_frame", "backend", "adapter", "simulated_time"):
    check(key in values, f"status has {key}")
rtf_status = float(values["real_time_factor"])
check(float(values["substeps_per_frame"]) > 0.0, f"substeps per frame {values['substeps_per_frame']}")
check(values["backend"] == "cpu" and values["adapter"] == "cpu",
      f"backend {values['backend']}, adapter {values['adapter']}")
# The status measures over its last 5 s, this over 8 s; both count whole frames of 1/60 s.
frame_slack = 2 * (1 / 60) / (window[-1][0] - window[0][0])
check(abs(rtf_status - rtf_measured) <= 0.25 * rtf_measured + frame_slack,
      f"status real-time factor {rtf_status:.4f} against {rtf_measured:.4f} measured from /clock")
if rtf_measured < 0.8:
    # diagnostic_msgs' `byte` arrives in rclpy as a one-byte bytes object.
    level = status.level[0] if isinstance(status.level, (bytes, bytearray)) else status.level
    check(level == 1 and "slower than real time" in status.message
          and f"{rtf_status:.3f}" in status.message,
          f"a slow run is a warning that says by how much: {status.message!r}")
check(len(clouds) > 0, f"{len(clouds)} clouds received")
print(f"RESULT rtf_measured={rtf_measured:.4f} rtf_status={rtf_status:.4f} "
      f"clock_msgs={len(clocks)} clouds={len(clouds)} status_message={status.message!r}", flush=True)
node.destroy_node()
rclpy.shutdown()
