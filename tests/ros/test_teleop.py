"""Teleoperation: the PSM follows 0.2x the MTM's displacement, and holds while clutched."""

from common import Recorder, ScriptedMtm, check

rec = Recorder("mtm_probe")
mtm = ScriptedMtm(rec)
psm = mtm.psm


def move_mtm(dx):
    mtm.move(dx, pause=0.01, settle=20, rest=0.3)


mtm.send(20)
mtm.clutch(False)
mtm.operator_present(True)
mtm.send(30)
rec.spin_for(0.3)
p0 = psm()
move_mtm(0.05)
p1 = psm()
d1 = [b - a for a, b in zip(p0, p1)]
print(f"RESULT following: MTM +50.0 mm x -> PSM {[round(v * 1000, 2) for v in d1]} mm")
check(abs(d1[0] - 0.010) < 0.0005 and abs(d1[1]) < 0.0005 and abs(d1[2]) < 0.0005,
      "unclutched: PSM moves 0.2x the MTM displacement")

mtm.clutch(True)
rec.spin_for(0.2)
move_mtm(0.04)
p2 = psm()
d2 = [b - a for a, b in zip(p1, p2)]
print(f"RESULT clutched: MTM +40.0 mm x -> PSM {[round(v * 1000, 3) for v in d2]} mm")
check(max(abs(v) for v in d2) < 1e-4, "clutched: PSM does not move")

mtm.clutch(False)
mtm.send(20)
rec.spin_for(0.2)
p3 = psm()
move_mtm(-0.03)
p4 = psm()
d3 = [b - a for a, b in zip(p3, p4)]
print(f"RESULT re-engaged: MTM -30.0 mm x -> PSM {[round(v * 1000, 2) for v in d3]} mm")
check(abs(d3[0] + 0.006) < 0.0005, "after the clutch: follows again from where it was")
rec.close()
