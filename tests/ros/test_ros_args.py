"""The node started with standard ROS arguments (tests/ros_contract.rs):
`--ros-args -r __ns:=/sim -r __node:=sim -r tissue/points:=cloud -p use_sim_time:=true
-p arm_rate_hz:=50`. The node is `sim` in `/sim`, its topics live there, the remapped cloud
is on /sim/cloud, and `ros2 param list` / `get` (the parameter services) show the declared
parameters with the values in use."""

import time

import rclpy
from rcl_interfaces.srv import GetParameters, ListParameters
from sensor_msgs.msg import JointState, PointCloud2

from common import Recorder, check, fail

rec = Recorder("ros_args_probe")
rec.subscribe(JointState, "/sim/PSM1/measured_js")
rec.subscribe(PointCloud2, "/sim/cloud")
rec.wait_for(lambda: rec.count("/sim/PSM1/measured_js") > 0, 15.0, "/sim/PSM1/measured_js")
rec.wait_for(lambda: rec.count("/sim/cloud") > 0, 10.0, "the cloud on /sim/cloud")
rec.wait_for(lambda: ("sim", "/sim") in rec.node.get_node_names_and_namespaces(), 5.0,
             "node sim in /sim")
graph = dict(rec.node.get_topic_names_and_types())
check("/sim/tissue/points" not in graph and "/tissue/points" not in graph,
      "node sim in /sim; tissue/points remapped to /sim/cloud")


def call(service_type, name, request):
    client = rec.node.create_client(service_type, name)
    if not client.wait_for_service(timeout_sec=10.0):
        fail(f"service {name} not found")
    future = client.call_async(request)
    end = time.monotonic() + 5.0
    while not future.done() and time.monotonic() < end:
        rclpy.spin_once(rec.node, timeout_sec=0.01)
    if not future.done():
        fail(f"{name}: no answer in 5 s")
    return future.result()


names = call(ListParameters, "/sim/sim/list_parameters", ListParameters.Request()).result.names
for expected in ("use_sim_time", "scene", "frame_rate_hz", "arm_rate_hz", "points_rate_hz"):
    if expected not in names:
        fail(f"{expected} not in list_parameters: {names}")
values = call(GetParameters, "/sim/sim/get_parameters",
              GetParameters.Request(names=["use_sim_time", "arm_rate_hz", "scene"])).values
check(values[0].bool_value is True and values[1].double_value == 50.0
      and values[2].string_value == "tests/scenes/small_dvrk_links.toml",
      f"list_parameters: {sorted(names)}; use_sim_time true, arm_rate_hz 50, the scene path")
rec.close()
