"""Counts /clock messages for SECONDS (argv[1]) after the first one arrives, waiting up to
WAIT seconds (argv[2], default 20) for it; prints `CLOCK n` (`CLOCK 0` when none came).

A node's /clock carries one message per simulated frame, so the count says whether, and how
fast, the node is publishing."""

import sys
import time

import rclpy
from rosgraph_msgs.msg import Clock

seconds = float(sys.argv[1])
wait = float(sys.argv[2]) if len(sys.argv) > 2 else 20.0
rclpy.init()
node = rclpy.create_node("clock_counter")
stamps = []
node.create_subscription(Clock, "/clock", lambda _msg: stamps.append(time.monotonic()), 10)
deadline = time.monotonic() + wait
while not stamps and time.monotonic() < deadline:
    rclpy.spin_once(node, timeout_sec=0.05)
if not stamps:
    print("CLOCK 0", flush=True)
    sys.exit(0)
end = stamps[0] + seconds
while time.monotonic() < end:
    rclpy.spin_once(node, timeout_sec=0.01)
print(f"CLOCK {sum(1 for t in stamps if t < end) - 1}", flush=True)
