"""Pick up the suture thread of config/thread.toml as a dVRK user scripts it: open the jaws,
insert until the tips straddle the thread lying on the table, close (a negative jaw command:
the jaws meet on the thread and press), lift 40 mm, hold, open. The thread's middle must rise
with the jaws, keep its length, and fall back to the table once the jaws open. The thread is
read from its centreline marker (threads/suture/centreline); waits follow simulated time
(the stamps of PSM1/measured_js), so the script works however slowly the simulation runs."""

import math

from sensor_msgs.msg import JointState
from visualization_msgs.msg import Marker

from common import Recorder, check

CENTRELINE = "/threads/suture/centreline"

rec = Recorder("thread_pickup_probe")
rec.subscribe(JointState, "/PSM1/measured_js")
rec.subscribe(JointState, "/PSM1/jaw/measured_js")
rec.subscribe(Marker, CENTRELINE)
move = rec.publisher(JointState, "/PSM1/move_jp")
jaw_move = rec.publisher(JointState, "/PSM1/jaw/move_jp")
rec.wait_for(lambda: rec.latest(CENTRELINE) is not None
             and rec.latest("/PSM1/measured_js") is not None
             and rec.latest("/PSM1/jaw/measured_js") is not None, 60.0,
             "the arm and the thread's centreline")
rec.wait_subscribers(move)
rec.wait_subscribers(jaw_move)


def centreline():
    marker = rec.latest(CENTRELINE)
    return [(p.x, p.y, p.z) for p in marker.points]


def middle_z(points):
    """Height of the thread within 5 mm of the instrument's axis (x = y = 0)."""
    near = [p[2] for p in points if math.hypot(p[0], p[1]) <= 0.005]
    check(len(near) > 0, f"{len(near)} centreline points under the jaws")
    return sum(near) / len(near)


def length(points):
    return sum(math.dist(a, b) for a, b in zip(points, points[1:]))


def jaw():
    m = rec.latest("/PSM1/jaw/measured_js")
    return m.position[0], m.effort[0]


# The thread falls 6 mm onto the table first (scene start): let it settle.
rec.wait_sim(0.5, "the thread to settle")
rest = centreline()
rest_length = length(rest)
z0 = middle_z(rest)
check(z0 < 0.001, f"the thread lies on the table (middle at {z0 * 1e3:.2f} mm)")

q = list(rec.latest("/PSM1/measured_js").position)
home_insertion = q[2]
# At home the jaws close along x, along the thread; rolling the instrument a quarter turn
# puts the thread across them, as a surgeon would.
q[3] += math.pi / 2
move.publish(JointState(position=q))
rec.wait_for(lambda: abs(rec.latest("/PSM1/measured_js").position[3] - q[3]) < 1e-3, 600.0,
             "the quarter roll")
jaw_move.publish(JointState(name=["jaw"], position=[math.radians(50)]))
rec.wait_for(lambda: abs(jaw()[0] - math.radians(50)) < 0.01, 600.0, "the jaws to open 50°")
# Home holds the jaw pivot 40 mm above the table; 30.5 mm more insertion puts it 9.5 mm up,
# the jaws' 10 mm tips reaching down past the thread.
move.publish(JointState(position=q[:2] + [home_insertion + 0.0305] + q[3:]))
rec.wait_for(lambda: abs(rec.latest("/PSM1/measured_js").position[2] - home_insertion - 0.0305)
             < 1e-4, 600.0, "the insertion")
jaw_move.publish(JointState(name=["jaw"], position=[math.radians(-20)]))
rec.wait_for(lambda: jaw()[0] < 0.03, 600.0, "the jaws to close on the thread")
rec.wait_sim(0.2, "the jaws to press")
move.publish(JointState(position=q[:2] + [home_insertion - 0.0095] + q[3:]))
rec.wait_for(lambda: abs(rec.latest("/PSM1/measured_js").position[2] - home_insertion + 0.0095)
             < 1e-4, 600.0, "the 40 mm lift")
rec.wait_sim(0.3, "the hold")
held = centreline()
rise = middle_z(held) - z0
stretch = length(held) / rest_length - 1.0
lowest_end = min(held[0][2], held[-1][2])
print(f"RESULT held: middle rose {rise * 1e3:.2f} mm, ends at {held[0][2] * 1e3:.2f} / "
      f"{held[-1][2] * 1e3:.2f} mm, length change {stretch * 100:+.4f} %")
check(rise >= 0.035, f"the grasped middle rose {rise * 1e3:.2f} mm with the 40 mm lift (>= 35)")
check(abs(stretch) < 0.001, f"the thread keeps its length ({stretch * 100:+.4f} %, within 0.1 %)")
check(lowest_end < rise + z0 - 0.002, "the ends hang below the grasp")

jaw_move.publish(JointState(name=["jaw"], position=[math.radians(50)]))
rec.wait_sim(1.0, "the thread to fall")
fallen = centreline()
top = max(p[2] for p in fallen)
print(f"RESULT released: highest point {top * 1e3:.2f} mm")
check(top < 0.003, f"opening let the thread fall back to the table (highest {top * 1e3:.2f} mm)")
rec.close()
