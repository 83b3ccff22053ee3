"""Let go of the needle of config/suture.toml as a dVRK user does: PSM1 holds it in its
needle driver; `jaw/move_jp` to 30° opens the driver and lets it go. The script waits on
simulated time (the stamps of PSM1/measured_js) for the scene to settle, opens the jaw,
and waits 1.5 s more while the needle falls; tests/ros/read_needle_bag.py then reads where
it went from the node's bag (/tf)."""

import math

from sensor_msgs.msg import JointState

from common import Recorder, check

rec = Recorder("needle_release_probe")
rec.subscribe(JointState, "/PSM1/measured_js")
rec.subscribe(JointState, "/PSM1/jaw/measured_js")
jaw_move = rec.publisher(JointState, "/PSM1/jaw/move_jp")
rec.wait_for(lambda: rec.latest("/PSM1/measured_js") is not None
             and rec.latest("/PSM1/jaw/measured_js") is not None, 60.0, "PSM1's joints")
rec.wait_subscribers(jaw_move)
rec.wait_sim(0.3, "the scene to settle")
opened_at = rec.sim_time()
jaw_move.publish(JointState(name=["jaw"], position=[math.radians(30)]))
rec.wait_for(lambda: rec.latest("/PSM1/jaw/measured_js").position[0] > math.radians(25),
             600.0, "the jaw to open")
check(True, f"PSM1's jaw opened at {opened_at:.3f} s of simulated time")
rec.wait_sim(1.5, "the needle to fall")
print(f"released at {opened_at:.3f} s", flush=True)
rec.close()
