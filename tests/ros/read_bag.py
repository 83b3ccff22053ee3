"""Reads a bag written by `dvrk-tissue-sim run --record` with the PyPI rosbags package and
checks topics, types, counts, monotonic timestamps and decoded contents.

usage: read_bag.py BAG KIND   (KIND: replay, node or interrupted)
"""

import sys
from pathlib import Path

from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from common import check, fail

bag, kind = Path(sys.argv[1]), sys.argv[2]
EXPECTED = {
    "/PSM1/servo_jp": "sensor_msgs/msg/JointState",
    "/PSM1/measured_js": "sensor_msgs/msg/JointState",
    "/PSM1/jaw/measured_js": "sensor_msgs/msg/JointState",
    "/PSM1/measured_cp": "geometry_msgs/msg/PoseStamped",
    "/PSM1/measured_cv": "geometry_msgs/msg/TwistStamped",
    "/tissue/points": "sensor_msgs/msg/PointCloud2",
    "/tissue/surface": "visualization_msgs/msg/Marker",
    "/tools/probe/wrench": "geometry_msgs/msg/WrenchStamped",
    "/tf": "tf2_msgs/msg/TFMessage",
}
if kind in ("node", "interrupted"):
    EXPECTED["/PSM1/operating_state"] = "crtk_msgs/msg/OperatingState"

# crtk_msgs is not in the standard type store: rosbags takes the bag's own definitions.
with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_KILTED)) as reader:
    types = {c.topic: c.msgtype for c in reader.connections}
    for topic, msgtype in EXPECTED.items():
        check(types.get(topic) == msgtype, f"{topic} is {msgtype}")
    counts = {}
    last = {}
    stamps_ok = True
    decoded = {}
    for connection, timestamp, rawdata in reader.messages():
        topic = connection.topic
        counts[topic] = counts.get(topic, 0) + 1
        if timestamp < last.get(topic, 0):
            stamps_ok = False
        last[topic] = timestamp
        msg = reader.deserialize(rawdata, connection.msgtype)
        if hasattr(msg, "header") and topic != "/PSM1/servo_jp" and not topic.endswith("operating_state"):
            h = msg.header.stamp
            if h.sec * 1_000_000_000 + h.nanosec != timestamp:
                fail(f"{topic}: header stamp {h.sec}.{h.nanosec:09d} != log time {timestamp}")
        decoded[topic] = msg
    print("counts", counts)
    check(stamps_ok, "log times never go back on any topic")
    check(reader.message_count == sum(counts.values()) > 0,
          f"{reader.message_count} messages, summary and stream agree")
    cloud = decoded["/tissue/points"]
    check([f.name for f in cloud.fields] == ["x", "y", "z", "volumetric_strain"]
          and cloud.width > 1000 and len(cloud.data) == cloud.width * cloud.point_step,
          f"cloud of {cloud.width} points with fields x, y, z, volumetric_strain")
    check(decoded["/tools/probe/wrench"].header.frame_id == "PSM1", "wrench in frame PSM1")
    js = decoded["/PSM1/measured_js"]
    check(list(js.name) == ["yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw"],
          "measured_js joint names")
    surface = decoded["/tissue/surface"]
    check(surface.type == 11 and len(surface.points) % 3 == 0 and len(surface.points) > 0,
          "surface is a TRIANGLE_LIST")
    check(decoded["/PSM1/measured_cp"].header.frame_id == "PSM1_base", "measured_cp in PSM1_base")
    check(counts["/PSM1/servo_jp"] >= (33 if kind == "replay" else 20), "servo_jp inputs recorded")
    if kind == "replay":
        check(abs(js.position[2] - 0.1365) < 1e-9, "last measured insertion 0.1365 m")
        check(counts["/PSM1/measured_js"] == 38 and counts["/tissue/points"] == 19,
              "38 arm states and 19 clouds (60 Hz frames, clouds at 30 Hz)")
    else:
        check(decoded["/PSM1/operating_state"].state == "ENABLED", "operating state ENABLED")
