"""Bad input is rejected with a log line naming topic and reason; the node keeps publishing
and the last valid command holds."""

import math

from sensor_msgs.msg import JointState, Joy
from geometry_msgs.msg import PoseStamped
from std_msgs.msg import String

from common import Recorder, check, LATCHED

rec = Recorder("bad_input_probe")
rec.subscribe(JointState, "/PSM1/measured_js")
rec.subscribe(String, "/PSM1/error", LATCHED)
servo = rec.publisher(JointState, "/PSM1/servo_jp")
move = rec.publisher(JointState, "/PSM1/move_jp")
jaw = rec.publisher(JointState, "/PSM1/jaw/servo_jp")
servo_cp = rec.publisher(PoseStamped, "/PSM1/servo_cp")
mtm = rec.publisher(PoseStamped, "/MTMR/measured_cp")
clutch = rec.publisher(Joy, "/console/clutch")
rec.wait_for(lambda: rec.latest("/PSM1/measured_js") is not None, 10.0, "measured_js")
for p in (servo, move, jaw, servo_cp):
    rec.wait_subscribers(p)

NAMES = ["yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw"]
valid = [0.02, -0.02, 0.125, 0.05, 0.0, 0.0]
servo.publish(JointState(name=NAMES, position=valid))
rec.wait_for(lambda: list(rec.latest("/PSM1/measured_js").position) == valid, 5.0,
             "the valid command to arrive")


def pose(x, y, z, qx=0.0, qy=0.0, qz=0.0, qw=1.0):
    m = PoseStamped()
    m.pose.position.x, m.pose.position.y, m.pose.position.z = x, y, z
    o = m.pose.orientation
    o.x, o.y, o.z, o.w = qx, qy, qz, qw
    return m


cp_home = None
BAD = [
    ("servo_jp", "not a finite number", servo, JointState(name=NAMES, position=[math.nan, 0, 0.12, 0, 0, 0])),
    ("servo_jp", "expected 6 joint values", servo, JointState(position=[0.0, 0.0, 0.12])),
    ("servo_jp", "unknown joint `elbow`", servo,
     JointState(name=["yaw", "pitch", "elbow", "roll", "wrist_pitch", "wrist_yaw"], position=valid)),
    ("servo_jp", "outside its limits", servo, JointState(name=NAMES, position=[0.02, -0.02, 0.3, 0.05, 0, 0])),
    ("servo_jp", "would jump", servo, JointState(name=NAMES, position=[0.9, -0.02, 0.125, 0.05, 0, 0])),
    ("servo_jp", "not a finite number", servo, JointState(name=NAMES, position=[0.02, math.inf, 0.125, 0.05, 0, 0])),
    ("move_jp", "outside its limits", move, JointState(name=NAMES, position=[2.5, 0, 0.1, 0, 0, 0])),
    ("jaw/servo_jp", "not a finite number", jaw, JointState(name=["jaw"], position=[math.nan])),
    ("jaw/servo_jp", "unknown joint `claw`", jaw, JointState(name=["claw"], position=[0.1])),
    ("servo_cp", "NaN or infinite", servo_cp, pose(math.nan, 0.0, -0.1)),
    ("servo_cp", "quaternion has length", servo_cp, pose(0.0, 0.0, -0.11, 0.0, 0.0, 0.0, 0.0)),
    ("servo_cp", "safety distance", servo_cp, pose(0.0, 0.0, -0.02, 0.7071068, 0.7071068, 0.0, 0.0)),
]
for topic, reason, publisher, msg in BAD:
    before_errors = rec.count("/PSM1/error")
    publisher.publish(msg)

    def logged():
        return any(f"{topic}: rejected" in m.data and reason in m.data
                   for _, m in rec.messages["/PSM1/error"][before_errors:])

    rec.wait_for(logged, 5.0, f"an error naming {topic} and '{reason}'")
    n = rec.count("/PSM1/measured_js")
    rec.spin_for(0.3)
    check(rec.count("/PSM1/measured_js") > n + 5, f"{topic} ({reason}): node keeps publishing")
    check(list(rec.latest("/PSM1/measured_js").position) == valid,
          f"{topic} ({reason}): rejected, the last valid command holds")
    # One line per topic and second: wait so the next rejection on this topic is logged too.
    rec.spin_for(1.05)

# A joint name carrying a newline is quoted escaped: it cannot forge a line of the log or of
# `error`.
before_errors = rec.count("/PSM1/error")
servo.publish(JointState(name=["yaw\nWARN forged"] + NAMES[1:], position=valid))
rec.wait_for(lambda: rec.count("/PSM1/error") > before_errors, 5.0, "the forged name's rejection")
text = rec.messages["/PSM1/error"][before_errors][1].data
check("\n" not in text and "yaw\\nWARN forged" in text, f"the newline is escaped: {text!r}")
rec.spin_for(1.05)

# Oversized input (five thousand positions, a 20 kB joint name) is dropped on receipt: not
# converted, not quoted on `error`, and the node goes on with the last valid command. (A
# sample over 64 KiB never reaches the node: its DDS layer refuses to reassemble it, which
# tests/hostile_network.rs checks.)
before_errors = rec.count("/PSM1/error")
servo.publish(JointState(name=NAMES, position=[0.0] * 5_000))
rec.spin_for(1.05)  # one log line per topic and second
servo.publish(JointState(name=["y" * 20_000] + NAMES[1:], position=valid))
n = rec.count("/PSM1/measured_js")
rec.spin_for(1.0)
check(rec.count("/PSM1/measured_js") > n + 20, "node keeps publishing after oversized input")
check(rec.count("/PSM1/error") == before_errors, "oversized input is not echoed on error")
check(list(rec.latest("/PSM1/measured_js").position) == valid,
      "oversized input dropped, the last valid command holds")

# MTM side: NaN poses and Joy without buttons are rejected too (logged by the node).
mtm.publish(pose(math.nan, 0.0, 0.0))
clutch.publish(Joy(buttons=[]))
n = rec.count("/PSM1/measured_js")
rec.spin_for(0.5)
check(rec.count("/PSM1/measured_js") > n + 10, "node alive after bad MTM and pedal messages")
print(f"RESULT rejected {len(BAD)} bad arm commands, node kept publishing")
rec.close()
