"""The jaw as dVRK's: jaw/servo_jp moves it with no effort left once there; jaw/servo_jf
closes it with that effort (the jaws meet and press: effort reported in jaw/measured_js),
clamped to the limit; a bad effort is rejected; jaw/servo_jp takes the position servo back."""

import math

from sensor_msgs.msg import JointState
from std_msgs.msg import String

from common import LATCHED, Recorder, check

LIMIT = 0.16  # dVRK's Large Needle Driver jaw effort limit (N·m), the default

rec = Recorder("jaw_probe")
rec.subscribe(String, "/PSM1/tool_type", LATCHED)
rec.subscribe(JointState, "/PSM1/jaw/measured_js")
rec.subscribe(JointState, "/PSM1/jaw/setpoint_js")
servo = rec.publisher(JointState, "/PSM1/jaw/servo_jp")
effort = rec.publisher(JointState, "/PSM1/jaw/servo_jf")
rec.wait_for(lambda: rec.latest("/PSM1/jaw/measured_js") is not None, 10.0, "jaw/measured_js")
rec.wait_for(lambda: rec.latest("/PSM1/tool_type") is not None, 10.0, "tool_type")
check(rec.latest("/PSM1/tool_type").data == "LARGE_NEEDLE_DRIVER:400006",
      f"tool_type of a gripper is dVRK's Large Needle Driver: {rec.latest('/PSM1/tool_type').data}")
rec.wait_subscribers(servo)
rec.wait_subscribers(effort)


def jaw():
    m = rec.latest("/PSM1/jaw/measured_js")
    return m.position[0], m.effort[0]


# Open in small steps (a jump is refused).
for i in range(1, 11):
    servo.publish(JointState(name=["jaw"], position=[0.03 * i]))
    rec.spin_for(0.05)
rec.wait_for(lambda: abs(jaw()[0] - 0.3) < 1e-4 and abs(jaw()[1]) < 1e-3, 10.0,
             "the jaw to reach 0.3 rad with no effort left")
check(abs(rec.latest("/PSM1/jaw/setpoint_js").position[0] - 0.3) < 1e-12, "setpoint_js is the command")
print(f"RESULT open jaw={jaw()[0]:.5f} rad effort={jaw()[1]:.2e} N·m")

effort.publish(JointState(name=["jaw"], effort=[-0.05]))
rec.wait_for(lambda: jaw()[0] == 0.0 and abs(jaw()[1] + 0.05) < 1e-9, 10.0,
             "servo_jf -0.05 to close the jaws and press with 0.05 N·m")
check(True, "jaw/servo_jf closes the jaws; measured_js reports the effort")

effort.publish(JointState(name=["jaw"], effort=[-1.0]))
rec.wait_for(lambda: abs(jaw()[1] + LIMIT) < 1e-9, 10.0, "an effort beyond the limit, clamped")
check(True, f"servo_jf -1 N·m is clamped to -{LIMIT} N·m")

effort.publish(JointState(name=["jaw"], effort=[math.nan]))
effort.publish(JointState(name=["jaw"], effort=[0.1, 0.2]))
rec.spin_for(1.0)
check(abs(jaw()[1] + LIMIT) < 1e-9 and jaw()[0] == 0.0, "NaN and two efforts are rejected: the last effort holds")

servo.publish(JointState(name=["jaw"], position=[0.3]))
rec.wait_for(lambda: abs(jaw()[0] - 0.3) < 1e-4, 10.0, "jaw/servo_jp to take the position servo back")
check(True, "jaw/servo_jp ends the effort command")
rec.close()
