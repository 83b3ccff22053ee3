"""How ROS 2 tools see the node (one node process, several checks): every topic in the graph
has exactly one type, /clock included; /rosout carries the arms' events with the node's logger
name and dVRK's levels; the status is on /diagnostics; every topic dVRK's Python PSM client
(dvrk_python's psm on crtk_python_client) opens, besides crtk_msgs ones, matches the node with
dVRK's types, and the relative, force and trajectory-ratio commands do what dVRK's do."""

import os
import time

import math

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import Log
from rosgraph_msgs.msg import Clock
from geometry_msgs.msg import PoseStamped, WrenchStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64, Float64MultiArray, String

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

# dVRK's PSM client: the subscribers and publishers it opens that the node lacked before
# (dvrk_python's arm and psm classes; crtk_msgs topics are checked in tests/ros_contract.rs).
CLIENT_SUBSCRIBES = {
    "local/measured_cp": (PoseStamped, 10),
    "local/setpoint_cp": (PoseStamped, 10),
    "body/measured_cf": (WrenchStamped, 10),
    "spatial/measured_cf": (WrenchStamped, 10),
    "body/jacobian": (Float64MultiArray, 10),
    "spatial/jacobian": (Float64MultiArray, 10),
    "tool_type": (String, LATCHED),
    "trajectory_j/ratio": (Float64, LATCHED),
    "error": (String, LATCHED),
}
CLIENT_PUBLISHES = {
    "servo_jr": JointState,
    "move_jr": JointState,
    "servo_jf": JointState,
    "spatial/servo_cf": WrenchStamped,
    "trajectory_j/set_ratio": Float64,
    "body/set_cf_orientation_absolute": Bool,
    "emulate_tool_present": Bool,
}
arm = f"{NS}/PSM1"
for suffix, (msg_type, qos) in CLIENT_SUBSCRIBES.items():
    rec.subscribe(msg_type, f"{arm}/{suffix}", qos)
publishers = {s: rec.publisher(t, f"{arm}/{s}") for s, t in CLIENT_PUBLISHES.items()}
start = time.monotonic()
rec.wait_for(lambda: all(rec.count(f"{arm}/{s}") > 0 for s in CLIENT_SUBSCRIBES), 5.0,
             "a message on every topic the client subscribes")
for p in publishers.values():
    rec.wait_subscribers(p, timeout=5.0)
check(True, f"{len(CLIENT_SUBSCRIBES)} subscribed and {len(CLIENT_PUBLISHES)} published topics "
      f"of dVRK's PSM client matched in {time.monotonic() - start:.2f} s")

latest = lambda s: rec.latest(f"{arm}/{s}")
check(latest("tool_type").data == "probe", "tool_type: the scene's tool, latched")
jac = latest("spatial/jacobian")
check(len(jac.data) == 36 and [d.size for d in jac.layout.dim] == [6, 6]
      and all(math.isfinite(v) for v in jac.data), "spatial/jacobian: 6 × 6, finite")
check(latest("spatial/measured_cf").header.frame_id == "PSM1_base"
      and latest("body/measured_cf").header.frame_id == "PSM1", "measured_cf frames")
check(latest("local/measured_cp").header.frame_id == "PSM1_base", "local/measured_cp frame")

# servo_jr steps the joints from where they are; servo_jf and spatial/servo_cf are refused
# with the reason on `error`; trajectory_j/set_ratio is echoed on trajectory_j/ratio.
rec.wait_sim(0.3, "the probe's move to end")
before = list(rec.latest(f"{NS}/PSM1/measured_js").position)
publishers["servo_jr"].publish(JointState(name=NAMES, position=[0, 0, 0.002, 0, 0, 0]))
rec.wait_for(lambda: abs(rec.latest(f"{NS}/PSM1/measured_js").position[2] - before[2] - 0.002)
             < 1e-9, 5.0, "servo_jr to step insertion by 2 mm")
check(True, "servo_jr stepped insertion by 2 mm")
errors_before = rec.count(f"{arm}/error")
publishers["servo_jf"].publish(JointState(effort=[0.0] * 6))
publishers["spatial/servo_cf"].publish(WrenchStamped())
refused = lambda: {m.data.split(": rejected:")[0].split("/", 1)[-1]
                   for _, m in rec.messages[f"{arm}/error"][errors_before:]}
rec.wait_for(lambda: refused() >= {"servo_jf", "spatial/servo_cf"}, 5.0,
             "servo_jf and spatial/servo_cf refused on error")
check(True, "servo_jf and spatial/servo_cf refused on error: "
      + latest("error").data)
publishers["trajectory_j/set_ratio"].publish(Float64(data=0.5))
rec.wait_for(lambda: latest("trajectory_j/ratio").data == 0.5, 5.0, "trajectory_j/ratio 0.5")
check(True, "trajectory_j/ratio follows set_ratio")

rec.close()
