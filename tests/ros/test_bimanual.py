"""Bimanual teleoperation as on a dVRK console: MTMR drives PSM1 and MTML drives PSM2, each at
0.2x its MTM's displacement, each MTM's gripper its own PSM's jaw, and the one clutch pedal
holds both arms."""

from sensor_msgs.msg import JointState

from common import Recorder, ScriptedMtm, check

rec = Recorder("bimanual_probe")
right = ScriptedMtm(rec, mtm="MTMR", arm="PSM1")
left = ScriptedMtm(rec, mtm="MTML", arm="PSM2")
ARMS = ("PSM1", "PSM2")
for arm in ARMS:
    rec.subscribe(JointState, f"/{arm}/jaw/measured_js")
rec.wait_for(lambda: all(rec.latest(f"/{a}/jaw/measured_js") for a in ARMS), 10.0,
             "both arms' jaw/measured_js")


def send_both(repeat):
    for _ in range(repeat):
        right.send()
        left.send()


def move(mtm, dx, steps=40):
    """Moves one MTM `dx` along x while both keep publishing, then lets the arms settle."""
    for _ in range(steps):
        mtm.position[0] += dx / steps
        send_both(1)
    send_both(20)
    rec.spin_for(0.3)


def positions():
    return right.psm(), left.psm()


def jaws():
    return [rec.latest(f"/{a}/jaw/measured_js").position[0] for a in ARMS]


def displacement(before, after):
    return [[b - a for a, b in zip(p, q)] for p, q in zip(before, after)]


def mm(d):
    return [round(v * 1000, 2) for v in d]


send_both(20)
right.clutch(False)
right.operator_present(True)
send_both(30)
rec.spin_for(0.3)

p0 = positions()
move(right, 0.04)
p1 = positions()
d_right, d_left = displacement(p0, p1)
print(f"RESULT MTMR +40.0 mm x -> PSM1 {mm(d_right)} mm, PSM2 {mm(d_left)} mm")
check(abs(d_right[0] - 0.008) < 0.0005 and max(abs(d_right[1]), abs(d_right[2])) < 0.0005,
      "MTMR moves PSM1 0.2x its displacement")
check(max(abs(v) for v in d_left) < 1e-4, "MTMR leaves PSM2 where it was")

move(left, -0.03)
p2 = positions()
d_right, d_left = displacement(p1, p2)
print(f"RESULT MTML -30.0 mm x -> PSM1 {mm(d_right)} mm, PSM2 {mm(d_left)} mm")
check(abs(d_left[0] + 0.006) < 0.0005 and max(abs(d_left[1]), abs(d_left[2])) < 0.0005,
      "MTML moves PSM2 0.2x its displacement")
check(max(abs(v) for v in d_right) < 1e-4, "MTML leaves PSM1 where it was")

j0 = jaws()
left.gripper = 0.6
send_both(40)
rec.spin_for(0.3)
j1 = jaws()
print(f"RESULT MTML gripper 0.3 -> 0.6 rad: PSM1 jaw {j0[0]:.3f} -> {j1[0]:.3f} rad, "
      f"PSM2 jaw {j0[1]:.3f} -> {j1[1]:.3f} rad")
check(j1[1] - j0[1] > 0.2, "MTML's gripper opens PSM2's jaw")
check(abs(j1[0] - j0[0]) < 1e-3, "MTML's gripper leaves PSM1's jaw")

right.clutch(True)
rec.spin_for(0.2)
for _ in range(40):
    right.position[0] += 0.001
    left.position[0] += 0.001
    send_both(1)
send_both(20)
rec.spin_for(0.3)
p3 = positions()
d_right, d_left = displacement(p2, p3)
print(f"RESULT clutched, both MTMs +40.0 mm x -> PSM1 {mm(d_right)} mm, PSM2 {mm(d_left)} mm")
check(max(abs(v) for v in d_right + d_left) < 1e-4, "the one clutch holds both arms")
rec.close()
