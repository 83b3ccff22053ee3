"""An MTM that stops publishing mid-teleoperation: the PSM holds where it was (no drift) while
it is silent, and teleoperation resumes without a jump when it is back, from wherever the MTM
is then (the operator moved it 80 mm meanwhile), following at 0.2x again."""

import time

from common import Recorder, ScriptedMtm, check

rec = Recorder("vanishing_mtm")
mtm = ScriptedMtm(rec, measured_cp_depth=100)
mtm_pos = mtm.position
psm = mtm.psm
move_mtm = mtm.move


def mm(v):
    return [round(x * 1000, 3) for x in v]


mtm.send(20)
mtm.clutch(False)
mtm.operator_present(True)
mtm.send(30)
p0 = psm()
move_mtm(0.05)
p1 = psm()
d1 = [b - a for a, b in zip(p0, p1)]
print(f"RESULT following: MTM +50 mm x -> PSM {mm(d1)} mm")
check(abs(d1[0] - 0.010) < 0.0005, "following before the MTM goes silent")

# The MTM goes silent for 3 s (the node's limit is 0.5 s simulated); every measured_cp of the
# gap is kept.
gap = []
print("MTM_SILENT", flush=True)
end = time.monotonic() + 3.0
while time.monotonic() < end:
    rec.spin_for(0.01)
    gap.append(psm())
drift = max(max(abs(a - b) for a, b in zip(p, p1)) for p in gap)
print(f"RESULT silent 3 s: {len(gap)} measured_cp samples, largest move {drift * 1000:.6f} mm")
check(drift < 1e-6, "the PSM holds where it was while the MTM is silent")

# Back, 80 mm further on x: no jump, then following again.
mtm_pos[0] += 0.08
print("MTM_BACK", flush=True)
mtm.send(40)
p2 = psm()
jump = [b - a for a, b in zip(p1, p2)]
print(f"RESULT back 80 mm away: PSM moved {mm(jump)} mm")
check(max(abs(v) for v in jump) < 1e-4, "no jump when the MTM is back")
move_mtm(-0.03)
p3 = psm()
d3 = [b - a for a, b in zip(p2, p3)]
print(f"RESULT resumed: MTM -30 mm x -> PSM {mm(d3)} mm")
check(abs(d3[0] + 0.006) < 0.0005 and abs(d3[1]) < 0.0005 and abs(d3[2]) < 0.0005,
      "teleoperation resumes at 0.2x")
rec.close()
