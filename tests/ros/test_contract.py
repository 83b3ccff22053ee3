"""How ROS 2 tools see the node (one node process, several checks): every topic in the graph
has exactly one type, /clock included."""

import os
import time

import rclpy
from rosgraph_msgs.msg import Clock

from common import Recorder, check, fail

NS = os.environ.get("EXPECT_NS", "")
rec = Recorder("contract_probe")
rec.subscribe(Clock, "/clock")
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

rec.close()
