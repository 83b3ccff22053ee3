"""Graph introspection: our node, its topics and their exact ROS type names; discovery time."""

import os
import time

import rclpy

from common import Recorder, check, fail

start = time.monotonic()
rec = Recorder("graph_probe")
EXPECTED = {
    "/PSM1/measured_js": "sensor_msgs/msg/JointState",
    "/PSM1/setpoint_js": "sensor_msgs/msg/JointState",
    "/PSM1/measured_cp": "geometry_msgs/msg/PoseStamped",
    "/PSM1/setpoint_cp": "geometry_msgs/msg/PoseStamped",
    "/PSM1/measured_cv": "geometry_msgs/msg/TwistStamped",
    "/PSM1/jaw/measured_js": "sensor_msgs/msg/JointState",
    "/PSM1/jaw/setpoint_js": "sensor_msgs/msg/JointState",
    "/PSM1/operating_state": "crtk_msgs/msg/OperatingState",
    "/PSM1/error": "std_msgs/msg/String",
    "/PSM1/warning": "std_msgs/msg/String",
    "/PSM1/status": "std_msgs/msg/String",
    "/PSM1/servo_jp": "sensor_msgs/msg/JointState",
    "/PSM1/servo_cp": "geometry_msgs/msg/PoseStamped",
    "/PSM1/move_jp": "sensor_msgs/msg/JointState",
    "/PSM1/move_cp": "geometry_msgs/msg/PoseStamped",
    "/PSM1/jaw/servo_jp": "sensor_msgs/msg/JointState",
    "/PSM1/hold": "std_msgs/msg/Empty",
    "/PSM1/free": "std_msgs/msg/Empty",
    "/PSM1/state_command": "crtk_msgs/msg/StringStamped",
    "/PSM1/body/servo_cf": "geometry_msgs/msg/WrenchStamped",
    "/MTMR/measured_cp": "geometry_msgs/msg/PoseStamped",
    "/MTMR/gripper/measured_js": "sensor_msgs/msg/JointState",
    "/console/clutch": "sensor_msgs/msg/Joy",
    "/console/operator_present": "sensor_msgs/msg/Joy",
    "/tissue/points": "sensor_msgs/msg/PointCloud2",
    "/tissue/surface": "visualization_msgs/msg/Marker",
    "/tissue/pieces": "std_msgs/msg/UInt32",
    "/tools/probe/wrench": "geometry_msgs/msg/WrenchStamped",
    "/tf": "tf2_msgs/msg/TFMessage",
}
node_name = os.environ.get("EXPECT_NODE", "dvrk_tissue_sim")
found_node = None
types = {}
deadline = time.monotonic() + 20.0
while time.monotonic() < deadline:
    rclpy.spin_once(rec.node, timeout_sec=0.02)
    if found_node is None and (node_name, "/") in rec.node.get_node_names_and_namespaces():
        found_node = time.monotonic() - start
    types = dict(rec.node.get_topic_names_and_types())
    if found_node is not None and all(t in types for t in EXPECTED):
        break
all_topics = time.monotonic() - start
check(found_node is not None, f"node {node_name} is on the graph")
for topic, type_name in EXPECTED.items():
    if types.get(topic) != [type_name]:
        fail(f"{topic}: expected type {type_name}, graph says {types.get(topic)}")
check(True, f"all {len(EXPECTED)} topics with exact type names")
print(f"RESULT discovery_node_s={found_node:.3f} discovery_all_topics_s={all_topics:.3f}")
rec.close()
