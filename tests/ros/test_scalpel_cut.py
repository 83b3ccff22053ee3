"""PSM1 holds a scalpel (config/cutting_psm.toml) and cuts a block through, driven as a dVRK
user drives it: `move_jp` inserting 15 mm pushes the blade's edge from 2 mm above the block
to 1 mm below the table, then back home. The node's `tissue/pieces` (std_msgs/UInt32)
counts one piece before the cut, two once the edge is through, and still two after the blade
has left. Waits follow simulated time (the stamps of PSM1/measured_js)."""

from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import UInt32

from common import Recorder, check

PIECES = "/tissue/pieces"

rec = Recorder("scalpel_cut_probe")
rec.subscribe(JointState, "/PSM1/measured_js")
rec.subscribe(PoseStamped, "/PSM1/measured_cp")
rec.subscribe(UInt32, PIECES)
move = rec.publisher(JointState, "/PSM1/move_jp")
rec.wait_for(lambda: rec.latest("/PSM1/measured_js") is not None
             and rec.latest(PIECES) is not None, 60.0, "the arm and the piece count")
rec.wait_subscribers(move)


def fresh_pieces(what):
    """The piece count of a frame counted after now (two new counts: the first may have been
    on its way)."""
    seen = rec.count(PIECES)
    rec.wait_for(lambda: rec.count(PIECES) >= seen + 2, 600.0, what)
    return rec.latest(PIECES).data


def spine_z():
    """Height of the tool frame (the blade's spine) above PSM1's base (m, negative: below)."""
    return rec.latest("/PSM1/measured_cp").pose.position.z


before = fresh_pieces("a count before the cut")
check(before == 1, f"one piece before the cut ({before})")

q = list(rec.latest("/PSM1/measured_js").position)
home = q[2]
z_home = spine_z()
move.publish(JointState(position=q[:2] + [home + 0.015] + q[3:]))
rec.wait_for(lambda: abs(rec.latest("/PSM1/measured_js").position[2] - home - 0.015) < 1e-4,
             600.0, "the 15 mm insertion")
# measured_cp comes on its own topic: wait until it has caught up with the joints.
rec.wait_for(lambda: abs(z_home - spine_z() - 0.015) < 1e-4, 60.0,
             "measured_cp 15 mm lower with the insertion")
check(True, f"the blade went down with the insertion ({(z_home - spine_z()) * 1e3:.2f} mm)")
rec.wait_sim(0.1, "the blade to rest at the bottom")
through = fresh_pieces("a count with the blade through")
print(f"RESULT through: pieces {through}")
check(through == 2, f"two pieces with the edge through the block ({through})")

move.publish(JointState(position=q))
rec.wait_for(lambda: abs(rec.latest("/PSM1/measured_js").position[2] - home) < 1e-4, 600.0,
             "the blade back home")
rec.wait_sim(0.5, "half a second with the blade out")
after = [m.data for _, m in rec.messages[PIECES][-3:]]
after.append(fresh_pieces("a count after the blade left"))
print(f"RESULT after: pieces {after}")
check(all(n == 2 for n in after), f"still two pieces after the blade left ({after})")
rec.close()
