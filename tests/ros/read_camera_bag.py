"""Reads the endoscope's pictures from a bag written by `dvrk-tissue-sim run --record` on
tests/scenes/camera.toml (2 × 160 × 120, 60°, 6 mm baseline) with the PyPI rosbags package,
and checks types, counts, stamps, frames, sizes, encodings and the CameraInfo matrices.

usage: read_camera_bag.py BAG KIND   (KIND: compressed or raw, the scene's camera.record)
"""

import math
import struct
import sys
from pathlib import Path

from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from common import check, fail

bag, kind = Path(sys.argv[1]), sys.argv[2]
WIDTH, HEIGHT, BASELINE = 160, 120, 0.006
# The node computes the matrices in single precision: 1e-4 px is their rounding.
FX = (WIDTH / 2) / math.tan(math.radians(60.0) / 2)

INFO = {"/ECM/left/camera_info": 0, "/ECM/right/camera_info": 1}
if kind == "compressed":
    PICTURES = {"/ECM/image_raw/compressed": "sensor_msgs/msg/CompressedImage"}
else:
    PICTURES = {"/ECM/image_raw": "sensor_msgs/msg/Image"}
    for eye in ("left", "right"):
        PICTURES[f"/ECM/{eye}/depth"] = "sensor_msgs/msg/Image"
        PICTURES[f"/ECM/{eye}/labels"] = "sensor_msgs/msg/Image"
EXPECTED = dict(PICTURES, **{t: "sensor_msgs/msg/CameraInfo" for t in INFO})


def jpeg_size(data):
    """(width, height) from a baseline JPEG's SOF0 segment."""
    data = bytes(data)
    if data[:2] != b"\xff\xd8":
        fail("the compressed picture is not a JPEG (no SOI marker)")
    at = 2
    while at + 4 <= len(data):
        marker, length = data[at + 1], struct.unpack(">H", data[at + 2:at + 4])[0]
        if marker == 0xC0:
            height, width = struct.unpack(">HH", data[at + 5:at + 9])
            return width, height
        at += 2 + length
    fail("no SOF0 segment in the JPEG")


with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_KILTED)) as reader:
    types = {c.topic: c.msgtype for c in reader.connections}
    for topic, msgtype in EXPECTED.items():
        check(types.get(topic) == msgtype, f"{topic} is {msgtype}")
    picture_topics = ("image_raw", "camera_info", "/depth", "/labels")
    unexpected = [t for t in types
                  if any(p in t for p in picture_topics) and t not in EXPECTED]
    check(not unexpected, f"no other camera topic with camera.record = {kind} ({unexpected})")
    stamps = {}
    for connection, timestamp, rawdata in reader.messages():
        topic = connection.topic
        if topic not in EXPECTED:
            continue
        msg = reader.deserialize(rawdata, connection.msgtype)
        h = msg.header.stamp
        if h.sec * 1_000_000_000 + h.nanosec != timestamp:
            fail(f"{topic}: header stamp {h.sec}.{h.nanosec:09d} != log time {timestamp}")
        stamps.setdefault(topic, []).append(timestamp)
        eye = "right" if "/right/" in topic else "left"
        if msg.header.frame_id != f"ECM_{eye}_optical_frame":
            fail(f"{topic}: frame {msg.header.frame_id}")
        if topic == "/ECM/image_raw/compressed":
            if msg.format != "jpeg" or jpeg_size(msg.data) != (2 * WIDTH, HEIGHT):
                fail(f"{topic}: {msg.format}, {jpeg_size(msg.data)}")
        elif topic == "/ECM/image_raw":
            if (msg.encoding, msg.width, msg.height, len(msg.data)) != (
                    "rgb8", 2 * WIDTH, HEIGHT, 3 * 2 * WIDTH * HEIGHT):
                fail(f"{topic}: {msg.encoding} {msg.width}×{msg.height}, {len(msg.data)} bytes")
        elif topic.endswith("/depth"):
            depth = struct.unpack(f"<{WIDTH * HEIGHT}f", bytes(msg.data))
            drawn = [d for d in depth if not math.isnan(d)]
            if msg.encoding != "32FC1" or not drawn or not all(0.005 < d < 10.0 for d in drawn):
                fail(f"{topic}: {msg.encoding}, {len(drawn)} drawn depths")
        elif topic.endswith("/labels"):
            if msg.encoding != "mono8" or 10 not in bytes(msg.data):
                fail(f"{topic}: {msg.encoding}, no tissue (label 10) drawn")
        else:
            k, p = list(msg.k), list(msg.p)
            tx = -FX * BASELINE if INFO[topic] == 1 else 0.0
            if (msg.width, msg.height) != (WIDTH, HEIGHT) or abs(k[0] - FX) > 1e-4 \
                    or abs(k[4] - FX) > 1e-4 or abs(p[3] - tx) > 1e-6:
                fail(f"{topic}: {msg.width}×{msg.height}, K {k}, P {p}")
    counts = {t: len(s) for t, s in stamps.items()}
    print("counts", counts)
    first = stamps[next(iter(PICTURES))]
    check(len(first) >= 15, f"{len(first)} pictures recorded")
    check(all(s == first for s in stamps.values()),
          "every camera topic carries each picture, at the same stamps")
    check(all(b - a > 0 for a, b in zip(first, first[1:])), "stamps rise")
