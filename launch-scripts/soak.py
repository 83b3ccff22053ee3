#!/usr/bin/env python3
"""Soak test of the node: N minutes of *simulated* time (default 30) with rclpy commanding the
arm and subscribed to every topic the node publishes; the node's resident memory is read at
the start (after a warm-up) and at the end, and its log is searched for ERROR lines.

Run inside a loopback-only network namespace (see README "ROS 2 node"), with the venv that
.ci/run makes:

    .venv/bin/python launch-scripts/soak.py --minutes 30

Prints a table; exits 1 if memory grew by more than 5 %, the log has an ERROR line, a topic
stayed silent, or the simulated time was not reached within twice its length in wall time.
"""

import argparse
import importlib
import math
import os
import signal
import subprocess
import sys
import time

import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy, DurabilityPolicy
from sensor_msgs.msg import JointState
from rosgraph_msgs.msg import Clock

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NODE = "dvrk_tissue_sim"


def rss_kb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return None


def message_type(name):
    package, _, type_name = name.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), type_name)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=30.0, help="simulated minutes")
    parser.add_argument("--scene", default="tests/scenes/small.toml")
    parser.add_argument("--binary", default=os.path.join(ROOT, "target/release/dvrk-tissue-sim"))
    parser.add_argument("--warmup", type=float, default=30.0, help="simulated s before the first memory reading")
    parser.add_argument("--log", default="/tmp/dvrk-soak.log")
    args = parser.parse_args()
    os.environ.setdefault("ROS_DOMAIN_ID", "57")
    env = dict(os.environ, NO_COLOR="1")
    env.pop("RUST_LOG", None)
    with open(args.log, "w") as log:
        node_proc = subprocess.Popen(
            [args.binary, "run", "--scene", args.scene, "--backend", "cpu"],
            cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=log)
    try:
        return soak(args, node_proc)
    finally:
        if node_proc.poll() is None:
            node_proc.kill()


def soak(args, node_proc):
    rclpy.init()
    node = rclpy.create_node("soak_client")
    counts = {}
    clock = {"t": 0.0}

    def on_clock(msg):
        clock["t"] = msg.clock.sec + msg.clock.nanosec * 1e-9

    node.create_subscription(Clock, "/clock", on_clock, 10)
    servo = node.create_publisher(JointState, "/PSM1/servo_jp", 10)
    jaw = node.create_publisher(JointState, "/PSM1/jaw/servo_jp", 10)

    # Discover what the node publishes, then subscribe to all of it.
    wall_start = time.monotonic()
    subscribed = set()
    unreadable = []
    while time.monotonic() - wall_start < 20.0:
        rclpy.spin_once(node, timeout_sec=0.1)
        for topic, types in node.get_topic_names_and_types():
            if topic in subscribed or topic in ("/rosout", "/parameter_events", "/clock"):
                continue
            publishers = node.get_publishers_info_by_topic(topic)
            if not any(p.node_name == NODE for p in publishers):
                continue
            qos = QoSProfile(depth=10)
            if any(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publishers):
                qos.durability = DurabilityPolicy.TRANSIENT_LOCAL
            if all(p.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for p in publishers):
                qos.reliability = ReliabilityPolicy.BEST_EFFORT
            subscribed.add(topic)
            try:
                msg_type = message_type(types[0])
            except ImportError:
                unreadable.append(f"{topic} ({types[0]})")
                continue
            counts[topic] = 0

            def callback(_msg, topic=topic):
                counts[topic] += 1

            node.create_subscription(msg_type, topic, callback, qos)
        if len(subscribed) >= 15 and time.monotonic() - wall_start > 5.0:
            break
    print(f"subscribed to {len(counts)} topics the node publishes; no Python type here for "
          f"{unreadable}", flush=True)

    target = args.minutes * 60.0
    start_rss = None
    start_wall = None
    next_command = 0.0
    next_report = 300.0
    commands = 0
    while clock["t"] < target and time.monotonic() - wall_start < 2.0 * target + 120.0:
        rclpy.spin_once(node, timeout_sec=0.005)
        t = clock["t"]
        if node_proc.poll() is not None:
            print(f"the node exited ({node_proc.returncode}) at t = {t:.1f} s", flush=True)
            break
        if start_rss is None and t >= args.warmup:
            start_rss, start_wall, start_t = rss_kb(node_proc.pid), time.monotonic(), t
            print(f"t = {t:.1f} s simulated: resident memory {start_rss} kB (start)", flush=True)
        if t >= next_command:
            # 20 Hz: a slow sweep of yaw, pitch, insertion and the jaw around home.
            q = [0.1 * math.sin(0.5 * t), 0.1 * math.sin(0.3 * t), 0.12 + 0.01 * math.sin(0.2 * t),
                 0.0, 0.0, 0.0]
            servo.publish(JointState(name=["yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw"], position=q))
            jaw.publish(JointState(name=["jaw"], position=[0.5 + 0.3 * math.sin(t)]))
            commands += 2
            next_command = t + 0.05
        if t >= next_report:
            print(f"t = {t:.0f} s simulated, {time.monotonic() - wall_start:.0f} s wall, "
                  f"resident memory {rss_kb(node_proc.pid)} kB", flush=True)
            next_report += 300.0
    end_t = clock["t"]
    end_rss = rss_kb(node_proc.pid) if node_proc.poll() is None else None
    end_wall = time.monotonic()
    node_proc.send_signal(signal.SIGINT)
    try:
        code = node_proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        node_proc.kill()
        code = "killed after 20 s"
    node.destroy_node()
    rclpy.shutdown()
    with open(args.log) as f:
        errors = [line.rstrip() for line in f if " ERROR " in line]

    growth = (end_rss - start_rss) / start_rss if start_rss and end_rss else float("nan")
    rtf = (end_t - start_t) / (end_wall - start_wall) if start_wall else float("nan")
    silent = [t for t, n in counts.items() if n == 0 and not t.endswith(("/error", "/warning", "/status", "/goal_reached"))]
    print()
    print("| measure | value |")
    print("|---|---|")
    print(f"| simulated time | {end_t:.1f} s of {target:.0f} s |")
    print(f"| wall time | {end_wall - wall_start:.0f} s (real-time factor {rtf:.3f} after warm-up) |")
    print(f"| commands sent (servo_jp + jaw/servo_jp) | {commands} |")
    print(f"| resident memory at t = {args.warmup:.0f} s | {start_rss} kB |")
    print(f"| resident memory at the end | {end_rss} kB ({growth * 100:+.2f} %) |")
    print(f"| ERROR lines in the node's log | {len(errors)} |")
    print(f"| node exit on Ctrl-C | {code} |")
    for topic in sorted(counts):
        print(f"| messages on {topic} | {counts[topic]} |")
    for line in errors[:10]:
        print(line)
    ok = (end_t >= target - 1.0 and abs(growth) <= 0.05 and not errors and not silent and code == 0)
    if silent:
        print(f"silent topics: {silent}")
    print("SOAK OK" if ok else "SOAK FAILED", flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
