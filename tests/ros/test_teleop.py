"""Teleoperation: the PSM follows 0.2x the MTM's displacement, and holds while clutched."""

from sensor_msgs.msg import JointState, Joy
from geometry_msgs.msg import PoseStamped

from common import Recorder, check

rec = Recorder("mtm_probe")
rec.subscribe(PoseStamped, "/PSM1/measured_cp")
mtm = rec.publisher(PoseStamped, "/MTMR/measured_cp")
gripper = rec.publisher(JointState, "/MTMR/gripper/measured_js")
clutch = rec.publisher(Joy, "/console/clutch")
present = rec.publisher(Joy, "/console/operator_present")
rec.wait_for(lambda: rec.latest("/PSM1/measured_cp") is not None, 10.0, "measured_cp")
for p in (mtm, gripper, clutch, present):
    rec.wait_subscribers(p)

mtm_pos = [0.0, -0.3, -0.1]


def send_mtm(repeat=1):
    for _ in range(repeat):
        m = PoseStamped()
        m.header.frame_id = "MTMR_base"
        m.pose.position.x, m.pose.position.y, m.pose.position.z = mtm_pos
        m.pose.orientation.w = 1.0
        mtm.publish(m)
        gripper.publish(JointState(name=["gripper"], position=[0.3]))
        rec.spin_for(0.01)


def psm():
    p = rec.latest("/PSM1/measured_cp").pose.position
    return [p.x, p.y, p.z]


def move_mtm(dx, steps=50):
    for _ in range(steps):
        mtm_pos[0] += dx / steps
        send_mtm()
        rec.spin_for(0.01)
    send_mtm(20)
    rec.spin_for(0.3)


send_mtm(20)
clutch.publish(Joy(buttons=[0]))
present.publish(Joy(buttons=[1]))
send_mtm(30)
rec.spin_for(0.3)
p0 = psm()
move_mtm(0.05)
p1 = psm()
d1 = [b - a for a, b in zip(p0, p1)]
print(f"RESULT following: MTM +50.0 mm x -> PSM {[round(v * 1000, 2) for v in d1]} mm")
check(abs(d1[0] - 0.010) < 0.0005 and abs(d1[1]) < 0.0005 and abs(d1[2]) < 0.0005,
      "unclutched: PSM moves 0.2x the MTM displacement")

clutch.publish(Joy(buttons=[1]))
rec.spin_for(0.2)
move_mtm(0.04)
p2 = psm()
d2 = [b - a for a, b in zip(p1, p2)]
print(f"RESULT clutched: MTM +40.0 mm x -> PSM {[round(v * 1000, 3) for v in d2]} mm")
check(max(abs(v) for v in d2) < 1e-4, "clutched: PSM does not move")

clutch.publish(Joy(buttons=[0]))
send_mtm(20)
rec.spin_for(0.2)
p3 = psm()
move_mtm(-0.03)
p4 = psm()
d3 = [b - a for a, b in zip(p3, p4)]
print(f"RESULT re-engaged: MTM -30.0 mm x -> PSM {[round(v * 1000, 2) for v in d3]} mm")
check(abs(d3[0] + 0.006) < 0.0005, "after the clutch: follows again from where it was")
rec.close()
