"""Drives PSM1 with servo_jp (the probe pushed 16 mm into the tissue and back up 8 mm) while
the node records; used by tests/recording.rs."""

from sensor_msgs.msg import JointState

from common import Recorder, check

rec = Recorder("servo_driver")
rec.subscribe(JointState, "/PSM1/measured_js")
servo = rec.publisher(JointState, "/PSM1/servo_jp")
rec.wait_for(lambda: rec.latest("/PSM1/measured_js") is not None, 10.0, "measured_js")
rec.wait_subscribers(servo)
q = list(rec.latest("/PSM1/measured_js").position)
start = q[2]
for i in list(range(1, 33)) + list(range(31, 15, -1)):
    q[2] = start + 0.0005 * i
    servo.publish(JointState(position=list(q)))
    rec.spin_for(1.0 / 60.0)
rec.spin_for(0.5)
final = rec.latest("/PSM1/measured_js").position[2]
check(abs(final - (start + 0.008)) < 1e-6, f"insertion ended 8 mm in ({final:.4f} m)")
rec.close()
