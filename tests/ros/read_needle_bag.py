"""Reads where the needle went in a bag of config/suture.toml, from /tf with the PyPI
rosbags package. Held by PSM1 the needle's frame hangs under PSM1 at its mount; let go, or
taken by PSM2's grasper, under world.
- `release` (tests/ros/test_needle_release.py): PSM1 let it go; it falls onto the tissue
  under it and comes to rest there.
- `handover` (tests/ros/test_needle_handover.py): PSM2 took it and lifted it 10 mm; it rose
  with PSM2 and did not fall when PSM1 opened; then PSM1 closed on it and took it back, and
  held it when PSM2 opened (under PSM1 again to the end).

usage: read_needle_bag.py BAG KIND"""

import sys
from pathlib import Path

from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from common import check

bag, kind = Path(sys.argv[1]), sys.argv[2]
samples = []  # (stamp s, parent, z)
with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_KILTED)) as reader:
    connections = [c for c in reader.connections if c.topic == "/tf"]
    for connection, _, rawdata in reader.messages(connections=connections):
        message = reader.deserialize(rawdata, connection.msgtype)
        for t in message.transforms:
            if t.child_frame_id == "needle":
                stamp = t.header.stamp.sec + t.header.stamp.nanosec * 1e-9
                samples.append((stamp, t.header.frame_id, t.transform.translation.z))

check(len(samples) > 10, f"{len(samples)} needle frames on /tf")
# The parents in order, each run of samples under one parent once.
runs = [s[1] for i, s in enumerate(samples) if i == 0 or s[1] != samples[i - 1][1]]
check(runs[0] == "PSM1", "held, the needle hangs under PSM1")
free = [s for s in samples if s[1] == "world"]
check(len(free) > 0, "let go, the needle hangs under world")
start_z, end_z = free[0][2], free[-1][2]
if kind == "handover":
    check(runs == ["PSM1", "world", "PSM1"],
          f"under PSM1, then world while PSM2 holds it, then PSM1 again: {runs}")
    lowest = min(s[2] for s in free)
    retaken = next(s for s in samples if s[1] == "PSM1" and s[0] > free[-1][0])
    print(f"needle taken at {free[0][0]:.3f} s at z {start_z * 1e3:.2f} mm; "
          f"at {free[-1][0]:.3f} s z {end_z * 1e3:.2f} mm (lowest {lowest * 1e3:.2f} mm); "
          f"PSM1 took it back at {retaken[0]:.3f} s and held it to {samples[-1][0]:.3f} s",
          flush=True)
    check(lowest > start_z - 0.0002, "it never fell while PSM2 held it")
    check(abs(end_z - start_z - 0.01) < 0.0005, "it rose 10 mm with PSM2")
    sys.exit(0)
check(runs == ["PSM1", "world"], f"once let go it stays under world: {runs}")
lowest = min(s[2] for s in free)
print(f"needle let go at {free[0][0]:.3f} s at z {start_z * 1e3:.2f} mm; "
      f"at {free[-1][0]:.3f} s z {end_z * 1e3:.2f} mm (lowest {lowest * 1e3:.2f} mm)", flush=True)
# Let go with its arc standing over the wound, its ends level with its centre, 5 mm above
# the blocks (which span 2-12 mm), it falls onto them point first: the wire keeps the
# tissue's velocity only along its tangent (seed 002 eq. 19), which at the ends points
# down, so the points go in as a sharp point does, turning as the arc does, and stop in
# the blocks. It must not reach the table.
check(end_z < start_z - 0.001, "it fell")
check(lowest > 0.006, "it stopped in the blocks, well above the table")
last_second = [s[2] for s in free if s[0] > free[-1][0] - 0.3]
check(max(last_second) - min(last_second) < 0.0005, "it came to rest")
