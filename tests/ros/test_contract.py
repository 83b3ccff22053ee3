"""How ROS 2 tools see the node (one node process, several checks): every topic in the graph
has exactly one type, /clock included; /rosout carries the arms' events with the node's logger
name and dVRK's levels; the status is on /diagnostics."""

import os
import time

import math

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import Log
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from common import Recorder, check, fail, LATCHED

NS = os.environ.get("EXPECT_NS", "")
LOGGER = os.environ.get("EXPECT_LOGGER", "dvrk_tissue_sim")
NAMES = ["yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw"]
rec = Recorder("contract_probe")
rec.subscribe(Clock, "/clock")
rec.subscribe(Log, "/rosout", LATCHED)
rec.subscribe(DiagnosticArray, "/diagnostics", LATCHED)
rec.subscribe(JointState, f"{NS}/PSM1/measured_js")
rec.wait_for(lambda: rec.count("/clock") > 0, 15.0, "/clock")

# The graph, once the node's topics are all discovered (its last input topic among them).
def topics():
    return dict(rec.node.get_topic_names_and_types())

rec.wait_for(lambda: f"{NS}/PSM1/state_command" in topics(), 10.0, "the node's topics")
rec.spin_for(0.5)
graph = topics()
several = {t: types for t, types in graph.items() if len(types) != 1}
if several:
    fail(f"topics with more than one type: {several}")
check(graph.get("/clock") == ["rosgraph_msgs/msg/Clock"],
      f"/clock has the one type rosgraph_msgs/msg/Clock ({len(graph)} topics, one type each)")

# /rosout: a rejected command at ERROR (dVRK's level for `error`), a move's status at INFO,
# both under the node's logger name; nothing of the probe's own.
def ours(level, text):
    return [m for _, m in rec.messages["/rosout"]
            if m.name == LOGGER and m.level == level and text in m.msg]

servo = rec.publisher(JointState, f"{NS}/PSM1/servo_jp")
move = rec.publisher(JointState, f"{NS}/PSM1/move_jp")
rec.wait_subscribers(servo)
rec.wait_subscribers(move)
servo.publish(JointState(name=NAMES, position=[math.nan, 0.0, 0.12, 0.0, 0.0, 0.0]))
rec.wait_for(lambda: ours(Log.ERROR, "servo_jp: rejected: "), 5.0, "the rejection on /rosout")
check(not ours(Log.WARN, "servo_jp: rejected: "), "the rejection on /rosout once, at ERROR")
move.publish(JointState(name=NAMES, position=[0.05, 0.0, 0.12, 0.0, 0.0, 0.0]))
rec.wait_for(lambda: ours(Log.INFO, "moving to"), 5.0, "the move's status on /rosout at INFO")
check(True, f"/rosout: the arm's error at ERROR and its status at INFO, logger {LOGGER}")

# /diagnostics: the node's status, as diagnostic_aggregator and rqt_robot_monitor read it.
rec.wait_for(lambda: rec.count("/diagnostics") > 0, 5.0, "/diagnostics")
status = rec.latest("/diagnostics").status[0]
values = {kv.key: kv.value for kv in status.values}
check(status.name == f"{LOGGER.split('.')[-1]}: simulation" and "real_time_factor" in values,
      f"/diagnostics: {status.name!r}, level {status.level}, {sorted(values)}")
check("/sim/status" not in graph and f"{NS}/sim/status" not in graph, "no sim/status topic")

rec.close()
