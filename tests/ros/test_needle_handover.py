"""Hand the needle of config/suture.toml from PSM1 to PSM2 as a dVRK user does: PSM2 opens
its grasper (open from its home already), turns it a quarter about the instrument so that
its jaws close across the wire, and moves it onto the top of the needle's arc (10 mm above
the needle's centre at (0, 0, 17) mm); closes it (`jaw/move_jp` -20 deg); PSM1 opens its
needle driver (30 deg); PSM2 lifts 10 mm. Then PSM1 takes it back: its open driver follows
the needle up 10 mm, closes on it (0 deg), PSM2 opens, and PSM1 lifts it 4 mm more. Waits
follow simulated time (the stamps of PSM1/measured_js). tests/ros/read_needle_bag.py then
reads from the node's bag (/tf) that the needle rose with PSM2 and hung under PSM1 again."""

import math

from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState

from common import Recorder, check

rec = Recorder("needle_handover_probe")
for arm in ("PSM1", "PSM2"):
    rec.subscribe(JointState, f"/{arm}/measured_js")
    rec.subscribe(JointState, f"/{arm}/jaw/measured_js")
    rec.subscribe(PoseStamped, f"/{arm}/measured_cp")
jaw = {arm: rec.publisher(JointState, f"/{arm}/jaw/move_jp") for arm in ("PSM1", "PSM2")}
move_cp = {arm: rec.publisher(PoseStamped, f"/{arm}/move_cp") for arm in ("PSM1", "PSM2")}
rec.wait_for(lambda: all(rec.latest(f"/{arm}/{topic}") is not None
                         for arm in ("PSM1", "PSM2")
                         for topic in ("measured_js", "jaw/measured_js", "measured_cp")),
             60.0, "both arms")
for publisher in (*jaw.values(), *move_cp.values()):
    rec.wait_subscribers(publisher)


def jaw_at(arm):
    return rec.latest(f"/{arm}/jaw/measured_js").position[0]


def turned_a_quarter(q):
    """q (x, y, z, w) turned 90 deg about its own z axis: q * (0, 0, sin 45, cos 45)."""
    s = c = math.sqrt(0.5)
    x, y, z, w = q
    return (x * c + y * s, y * c - x * s, z * c + w * s, w * c - z * s)


def move(arm, step, orientation, what):
    """Moves `arm`'s tool frame by `step` (m, in its base frame) to `orientation`."""
    rec.wait_sim(0.05, f"{arm}'s measured_cp to catch up")
    start = rec.latest(f"/{arm}/measured_cp").pose
    target = PoseStamped()
    target.header.frame_id = f"{arm}_base"
    target.pose.position.x = start.position.x + step[0]
    target.pose.position.y = start.position.y + step[1]
    target.pose.position.z = start.position.z + step[2]
    (target.pose.orientation.x, target.pose.orientation.y,
     target.pose.orientation.z, target.pose.orientation.w) = orientation
    move_cp[arm].publish(target)
    goal = (target.pose.position.x, target.pose.position.y, target.pose.position.z)

    def arrived():
        p = rec.latest(f"/{arm}/measured_cp").pose.position
        return math.dist((p.x, p.y, p.z), goal) < 1e-4

    rec.wait_for(arrived, 600.0, what)


rec.wait_sim(0.2, "the scene to settle")
jaw["PSM2"].publish(JointState(name=["jaw"], position=[math.radians(30)]))
rec.wait_for(lambda: jaw_at("PSM2") > math.radians(25), 600.0, "PSM2's grasper to open")
o = rec.latest("/PSM2/measured_cp").pose.orientation
# PSM2's base keeps the world's axes: from the tail at (-4, -7, 21.5) mm to 4 mm above the
# needle's top at (0, 0, 27) mm, the jaws' middle on the wire.
move("PSM2", (0.004, 0.007, 0.0095), turned_a_quarter((o.x, o.y, o.z, o.w)),
     "PSM2 over the needle")
jaw["PSM2"].publish(JointState(name=["jaw"], position=[math.radians(-20)]))
rec.wait_for(lambda: jaw_at("PSM2") < 0.03, 600.0, "PSM2's grasper to close on the needle")
rec.wait_sim(0.2, "PSM2's jaws to press")
grasped_at = rec.sim_time()
jaw["PSM1"].publish(JointState(name=["jaw"], position=[math.radians(30)]))
rec.wait_for(lambda: jaw_at("PSM1") > math.radians(25), 600.0, "PSM1's driver to open")
rec.wait_sim(0.2, "the needle in PSM2's jaws alone")
o = rec.latest("/PSM2/measured_cp").pose.orientation
move("PSM2", (0.0, 0.0, 0.01), (o.x, o.y, o.z, o.w), "PSM2's 10 mm lift")
rec.wait_sim(0.3, "the hold")
check(True, f"PSM2 closed on the needle at {grasped_at:.3f} s and lifted it")
print(f"grasped at {grasped_at:.3f} s", flush=True)
# PSM1's base is turned 90 deg about x: its +y is the world's +z. Its open driver follows
# the needle up, so that where it holds the needle is where the needle is, and closes.
o = rec.latest("/PSM1/measured_cp").pose.orientation
move("PSM1", (0.0, 0.01, 0.0), (o.x, o.y, o.z, o.w), "PSM1's driver up to the needle")
jaw["PSM1"].publish(JointState(name=["jaw"], position=[0.0]))
rec.wait_for(lambda: jaw_at("PSM1") < math.radians(5), 600.0, "PSM1's driver to close")
retaken_at = rec.sim_time()
jaw["PSM2"].publish(JointState(name=["jaw"], position=[math.radians(30)]))
rec.wait_for(lambda: jaw_at("PSM2") > math.radians(25), 600.0, "PSM2's grasper to open")
move("PSM1", (0.0, 0.004, 0.0), (o.x, o.y, o.z, o.w), "PSM1's 4 mm lift")
rec.wait_sim(0.3, "the hold")
check(True, f"PSM1 closed on the needle by {retaken_at:.3f} s and lifted it")
rec.close()
