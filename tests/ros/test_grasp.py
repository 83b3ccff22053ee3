"""Grasp and lift on the default scene as a dVRK user scripts it: open the jaws, insert the
tips into the liver, close (a negative jaw command: the jaws meet and squeeze), lift 25 mm
(a surgeon's retraction), hold, open. The grasped region must rise with the jaws, the liver
must stay one piece (tissue/pieces, which counts total Lagrangian MPM's rest connectivity,
and the cloud itself: no point a cell from its neighbours), the gripper's pull must rise with
the lift and carry the tissue while holding, and opening must let the tissue go. Waits follow simulated time
(the stamps of PSM1/measured_js), so the script works however slowly the simulation runs."""

import math
import struct

from geometry_msgs.msg import WrenchStamped
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import UInt32

from common import Recorder, check

rec = Recorder("grasp_probe")
rec.subscribe(JointState, "/PSM1/measured_js")
rec.subscribe(JointState, "/PSM1/jaw/measured_js")
rec.subscribe(PointCloud2, "/tissue/points")
rec.subscribe(WrenchStamped, "/tools/gripper/wrench")
rec.subscribe(UInt32, "/tissue/pieces")
move = rec.publisher(JointState, "/PSM1/move_jp")
jaw_move = rec.publisher(JointState, "/PSM1/jaw/move_jp")
rec.wait_for(lambda: rec.latest("/tissue/points") is not None
             and rec.latest("/PSM1/measured_js") is not None
             and rec.latest("/PSM1/jaw/measured_js") is not None, 60.0, "the arm and the cloud")
rec.wait_subscribers(move)
rec.wait_subscribers(jaw_move)


def points(cloud):
    data = bytes(cloud.data)
    return [struct.unpack_from("<3f", data, i * cloud.point_step) for i in range(cloud.width)]


def pieces_within(pts, link):
    """Connected pieces of the points, two linked when nearer than `link` (m)."""
    cells = {}
    for i, p in enumerate(pts):
        cells.setdefault(tuple(math.floor(c / link) for c in p), []).append(i)
    parent = list(range(len(pts)))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    steps = [(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)]
    for (x, y, z), members in cells.items():
        for a, b, c in steps:
            for j in cells.get((x + a, y + b, z + c), ()):
                for i in members:
                    if j > i and sum((u - v) ** 2 for u, v in zip(pts[i], pts[j])) < link * link:
                        parent[root(i)] = root(j)
    return len({root(i) for i in range(len(pts))})


def jaw():
    m = rec.latest("/PSM1/jaw/measured_js")
    return m.position[0], m.effort[0]


start = points(rec.latest("/tissue/points"))
# The instrument hangs straight down over the liver's centre: the grasped region is the
# tissue within 4 mm of its axis, in the top 5 mm.
near = [i for i, p in enumerate(start) if math.hypot(p[0], p[1]) <= 0.004]
top = max(start[i][2] for i in near)
region = [i for i in near if start[i][2] >= top - 0.005]
check(len(region) > 10, f"{len(region)} points under the jaws")


def region_z():
    cloud = points(rec.latest("/tissue/points"))
    return sum(cloud[i][2] for i in region) / len(region)


z0 = region_z()
q = list(rec.latest("/PSM1/measured_js").position)
home_insertion = q[2]

jaw_move.publish(JointState(name=["jaw"], position=[math.radians(50)]))
rec.wait_for(lambda: abs(jaw()[0] - math.radians(50)) < 0.01, 600.0, "the jaws to open 50°")
# Home leaves the tips 6 mm above the liver: 11 mm more insertion puts them 5 mm in.
move.publish(JointState(position=q[:2] + [home_insertion + 0.011] + q[3:]))
rec.wait_for(lambda: abs(rec.latest("/PSM1/measured_js").position[2] - home_insertion - 0.011)
             < 1e-4, 600.0, "the insertion")
jaw_move.publish(JointState(name=["jaw"], position=[math.radians(-20)]))
rec.wait_for(lambda: jaw()[0] < 0.01 and jaw()[1] < -0.1, 600.0, "the jaws to close and squeeze")
print(f"RESULT closed jaw={jaw()[0]:.4f} rad effort={jaw()[1]:.3f} N·m")

LIFT = 0.025


def stamp(msg):
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


lift_from = stamp(rec.latest("/PSM1/measured_js"))
move.publish(JointState(position=q[:2] + [home_insertion + 0.011 - LIFT] + q[3:]))
rec.wait_for(lambda: abs(rec.latest("/PSM1/measured_js").position[2] - home_insertion - 0.011
                         + LIFT) < 1e-4, 1200.0, "the 25 mm lift")
lift_to = stamp(rec.latest("/PSM1/measured_js"))
rec.wait_sim(0.3, "the hold")
held_rise = region_z() - z0
# The scene's cell (dx = 2 mm): at the hold, every point within a cell of a neighbour.
apart = pieces_within(points(rec.latest("/tissue/points")), 0.002)
wrenches = [m for _, m in rec.messages["/tools/gripper/wrench"][-10:]]
# Tool z points down along the instrument: the tissue pulls the lifted jaws down, along +z.
pull = sum(w.wrench.force.z for w in wrenches) / len(wrenches)
pieces = [m.data for _, m in rec.messages["/tissue/pieces"]]
print(f"RESULT held rise {held_rise * 1e3:.2f} mm, pull {pull:.3f} N along the tool's z, "
      f"pieces seen {sorted(set(pieces))}, cloud pieces at the hold {apart}")
check(held_rise >= 0.8 * LIFT,
      f"the grasped region rose {held_rise * 1e3:.2f} mm (>= 80 % of the 25 mm lift)")
check(pull > 1.0, f"the gripper wrench carries the pull ({pull:.3f} N)")
check(len(pieces) > 0 and set(pieces) == {1}, f"tissue/pieces read one piece ({sorted(set(pieces))})")
check(apart == 1, f"at the hold the cloud is one piece of points within a cell ({apart})")
# The pull rises with the lift: from a tenth of the way up, every frame's wrench at least the
# one before less 2 % of the final pull (the frame-to-frame ripple). A frame's wrench may
# come more than once; its stamp names the frame.
rising = sorted({stamp(w): w.wrench.force.z for _, w in rec.messages["/tools/gripper/wrench"]
                 if lift_from + 0.1 * (lift_to - lift_from) <= stamp(w) <= lift_to}.items())
check(len(rising) > 10, f"{len(rising)} frames' wrenches during the lift")
drop, at = max((f0 - f1, t1) for (_, f0), (t1, f1) in zip(rising, rising[1:]))
print(f"RESULT pull from {rising[0][1]:.3f} N to {rising[-1][1]:.3f} N over {len(rising)} frames, "
      f"largest fall {drop:.4f} N")
check(drop <= 0.02 * pull, f"the pull fell by {drop:.4f} N at t = {at:.3f} s during the lift")

jaw_move.publish(JointState(name=["jaw"], position=[math.radians(50)]))
rec.wait_sim(1.0, "the release")
released_rise = region_z() - z0
wrenches = [m for _, m in rec.messages["/tools/gripper/wrench"][-5:]]
after = max(abs(w.wrench.force.z) for w in wrenches)
print(f"RESULT released rise {released_rise * 1e3:.2f} mm, force {after:.4f} N")
check(released_rise < 0.3 * held_rise, f"opening let the tissue go ({released_rise * 1e3:.2f} mm)")
check(after < 0.01, f"the gripper feels nothing once open ({after:.4f} N)")
rec.close()
