"""A cloud subscriber that stops reading: one rclpy node subscribes tissue/points (rclpy's
default QoS: reliable, keep last 10) and is never spun again, so nothing is taken from its
reader; a second node watches /diagnostics. Check: the simulation's frame rate with the stalled
reader matched is what it was before it existed. Each window's figure is the best status
seen in it: a persistent slowdown (a writer blocked on the stalled reader, or busy repairing
to it) lowers every status, while another process's load on the machine comes and goes.

Prints `RESULT fps_before=.. fps_stalled=..`.
"""

import time

import rclpy
from rclpy.qos import QoSProfile, DurabilityPolicy, ReliabilityPolicy
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import PointCloud2

from common import check, fail

rclpy.init()
watcher = rclpy.create_node("status_watcher")
statuses = []
latched = QoSProfile(
    depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE
)
watcher.create_subscription(DiagnosticArray, "/diagnostics", statuses.append, latched)


def spin(seconds):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        rclpy.spin_once(watcher, timeout_sec=0.01)


def frames_per_second(status):
    values = {kv.key: kv.value for kv in status.status[0].values}
    return float(values["frames_per_second"])


def best_rate_over(seconds):
    """The highest frame rate the statuses published in the next `seconds` report."""
    first = len(statuses)
    spin(seconds)
    window = statuses[first:]
    if not window:
        fail("no /diagnostics")
    return max(frames_per_second(s) for s in window)


spin(5.0)
fps_before = best_rate_over(4.0)
stalled = rclpy.create_node("stalled_reader")
received = []
stalled.create_subscription(PointCloud2, "/tissue/points", received.append, 10)
# Let it match and fill its history, never taking anything from it.
deadline = time.monotonic() + 10.0
while stalled.count_publishers("/tissue/points") == 0 and time.monotonic() < deadline:
    spin(0.1)
check(stalled.count_publishers("/tissue/points") > 0, "the stalled reader matched the cloud")
# /diagnostics counts the frames of the last 5 s: from here on every status sees only frames
# made with the stalled reader matched.
spin(5.0)
fps_stalled = best_rate_over(4.0)
check(not received, "the stalled reader took nothing")
check(fps_stalled >= 0.9 * fps_before,
      f"frame rate with a stalled cloud reader {fps_stalled:.2f}/s, before {fps_before:.2f}/s")
print(f"RESULT fps_before={fps_before:.2f} fps_stalled={fps_stalled:.2f}", flush=True)
stalled.destroy_node()
watcher.destroy_node()
rclpy.shutdown()
