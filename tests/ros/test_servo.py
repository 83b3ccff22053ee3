"""servo_jp in -> measured_js / measured_cp out, consistent with the PSM's forward kinematics."""

from sensor_msgs.msg import JointState
from geometry_msgs.msg import PoseStamped

from common import Recorder, check, psm_fk, quat_to_matrix

rec = Recorder("servo_probe")
rec.subscribe(JointState, "/PSM1/measured_js")
rec.subscribe(PoseStamped, "/PSM1/measured_cp")
rec.subscribe(JointState, "/PSM1/jaw/measured_js")
servo = rec.publisher(JointState, "/PSM1/servo_jp")
jaw = rec.publisher(JointState, "/PSM1/jaw/servo_jp")
rec.wait_for(lambda: rec.latest("/PSM1/measured_js") is not None, 10.0, "measured_js")
rec.wait_subscribers(servo)
home = list(rec.latest("/PSM1/measured_js").position)
check(list(rec.latest("/PSM1/measured_js").name) ==
      ["yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw"], "dVRK joint names")
check(abs(home[2] - 0.12) < 1e-9, f"starts at the scene's home pose {home}")

goal = [0.10, -0.08, 0.13, 0.30, 0.20, -0.15]
steps = 20
for i in range(1, steps + 1):
    q = [h + (g - h) * i / steps for h, g in zip(home, goal)]
    msg = JointState(name=["yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw"],
                     position=q)
    servo.publish(msg)
    rec.spin_for(0.03)
jaw.publish(JointState(name=["jaw"], position=[0.5]))


def arrived():
    js = rec.latest("/PSM1/measured_js")
    jw = rec.latest("/PSM1/jaw/measured_js")
    return (js is not None and max(abs(a - b) for a, b in zip(js.position, goal)) < 1e-9
            and jw is not None and abs(jw.position[0] - 0.5) < 1e-9)


rec.wait_for(arrived, 5.0, "measured_js to reach the commanded joints")
check(True, "measured_js equals the last servo_jp; jaw/measured_js the last jaw/servo_jp")
rec.spin_for(0.2)
cp = rec.latest("/PSM1/measured_cp")
check(cp.header.frame_id == "PSM1_base", "measured_cp in frame PSM1_base")
fk = psm_fk(goal)
p = cp.pose.position
err = max(abs(p.x - fk[0][3]), abs(p.y - fk[1][3]), abs(p.z - fk[2][3]))
o = cp.pose.orientation
r = quat_to_matrix(o.x, o.y, o.z, o.w)
rerr = max(abs(r[i][j] - fk[i][j]) for i in range(3) for j in range(3))
print(f"RESULT fk_position_error_m={err:.2e} fk_rotation_error={rerr:.2e}")
check(err < 1e-6 and rerr < 1e-6, "measured_cp matches the DH forward kinematics")
js = rec.latest("/PSM1/measured_js")
check(js.header.stamp.sec > 0 or js.header.stamp.nanosec > 0, "stamps are simulated time, non-zero")
rec.close()
