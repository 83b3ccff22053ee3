"""dVRK's Python PSM client against the node on config/default.toml, with crtk_msgs built
from its definitions (.ci/crtk_msgs.sh). The probe opens exactly the publishers and
subscribers `dvrk.psm(ral, 'PSM1')` opens (dvrk_python's arm and psm classes on
crtk_python_client's utils, listed below as facts from their sources), checks every one
matches the node within 5 s as the client's `check_connections()` does, then runs a dVRK
user's first script: enable, home, move_jp and wait, servo_cp, open and close the jaw,
forward_kinematics (and local/forward_kinematics); then `dvrk.ecm(ral, 'ECM')`'s connections
and a move of the scope."""

import math
import time

from crtk_msgs.msg import OperatingState, StringStamped
from crtk_msgs.srv import QueryForwardKinematics
from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Empty, Float64, Float64MultiArray

from common import Recorder, check, fail

ARM = "/PSM1"
# (topic under the arm, type, latched): what the client subscribes.
SUBSCRIBES = [
    ("operating_state", OperatingState, False),
    ("setpoint_js", JointState, False),
    ("setpoint_cp", PoseStamped, False),
    ("measured_js", JointState, False),
    ("measured_cp", PoseStamped, False),
    ("measured_cv", TwistStamped, False),
    ("spatial/measured_cf", WrenchStamped, False),
    ("spatial/jacobian", Float64MultiArray, False),
    ("body/measured_cf", WrenchStamped, False),
    ("body/jacobian", Float64MultiArray, False),
    ("local/measured_cp", PoseStamped, False),
    ("local/setpoint_cp", PoseStamped, False),
    ("trajectory_j/ratio", Float64, False),
    ("jaw/measured_js", JointState, False),
    ("jaw/setpoint_js", JointState, False),
]
# (topic under the arm, type, latched): what the client publishes.
PUBLISHES = [
    ("state_command", StringStamped, True),
    ("hold", Empty, False),
    ("free", Empty, False),
    ("servo_jp", JointState, False),
    ("servo_jr", JointState, False),
    ("servo_cp", PoseStamped, False),
    ("servo_jf", JointState, False),
    ("move_jp", JointState, False),
    ("move_jr", JointState, False),
    ("move_cp", PoseStamped, False),
    ("spatial/servo_cf", WrenchStamped, False),
    ("body/servo_cf", WrenchStamped, False),
    ("body/set_cf_orientation_absolute", Bool, True),
    ("use_gravity_compensation", Bool, True),
    ("trajectory_j/set_ratio", Float64, True),
    ("emulate_tool_present", Bool, True),
    ("jaw/servo_jp", JointState, False),
    ("jaw/move_jp", JointState, False),
    ("jaw/servo_jf", JointState, False),
]

rec = Recorder("dvrk_psm_client")
node = rec.node


def qos(latched):
    # crtk's ral: keep last, depth 10 (1 for a latched publisher), transient local if latched.
    from rclpy.qos import DurabilityPolicy, QoSProfile
    profile = QoSProfile(depth=10)
    if latched:
        profile.durability = DurabilityPolicy.TRANSIENT_LOCAL
    return profile


def open_client(arm, psm):
    """The client's subscriptions and publishers on `arm` (dvrk.psm, or dvrk.ecm: the arm
    class alone, without the jaw and emulate_tool_present)."""
    kept = lambda suffix: psm or not (suffix.startswith("jaw/") or suffix == "emulate_tool_present")
    subscriptions = [rec.subscribe(t, f"{arm}/{s}", qos(latched))
                     for s, t, latched in SUBSCRIBES if kept(s)]
    publishers = {s: node.create_publisher(t, f"{arm}/{s}", qos(latched))
                  for s, t, latched in PUBLISHES if kept(s)}
    return subscriptions, publishers


def check_connections(arm, subscriptions, publishers, first):
    """The client's check_connections(): every publisher has a subscriber and every
    subscriber a publisher within 5 s (from when the node is up: `first` is matched)."""
    rec.wait_for(lambda: first.get_publisher_count() > 0, 60.0, "the node")
    start = time.monotonic()
    unmatched = lambda: ([s.topic_name for s in subscriptions if s.get_publisher_count() == 0]
                         + [p.topic_name for p in publishers.values()
                            if p.get_subscription_count() == 0])
    rec.wait_for(lambda: not unmatched(), 5.0, f"every connection (left: {unmatched()})")
    check(True, f"{arm}: {len(subscriptions)} subscribers and {len(publishers)} publishers "
          f"of dVRK's client matched in {time.monotonic() - start:.2f} s")


subscriptions, publishers = open_client(ARM, psm=True)
ecm_subscriptions, ecm_publishers = open_client("/ECM", psm=False)
forward = node.create_client(QueryForwardKinematics, f"{ARM}/forward_kinematics")
local_forward = node.create_client(QueryForwardKinematics, f"{ARM}/local/forward_kinematics")
check_connections(ARM, subscriptions, publishers, subscriptions[0])
check_connections("/ECM", ecm_subscriptions, ecm_publishers, subscriptions[0])

state = lambda: rec.latest(f"{ARM}/operating_state")
states_since = lambda n: [m for _, m in rec.messages[f"{ARM}/operating_state"][n:]]


def command(name):
    publishers["state_command"].publish(StringStamped(string=name))


def busy_pair_since(n):
    """Whether the states since the n-th hold a busy one followed by an idle one: how
    crtk's `wait()` sees a move begin and end."""
    states = states_since(n)
    busy = [i for i, m in enumerate(states) if m.is_busy]
    return bool(busy) and any(not m.is_busy for m in states[busy[0]:])


# psm.enable(10), psm.home(10): a command answered by a state after it.
rec.wait_for(lambda: state() is not None, 30.0, "operating_state")
seen = rec.count(f"{ARM}/operating_state")
command("enable")
rec.wait_for(lambda: state().state == "ENABLED", 10.0, "ENABLED")
command("home")
rec.wait_for(lambda: busy_pair_since(seen) and state().is_homed, 30.0,
             "home's busy pair, then homed")
check(True, f"enable and home: {state().state}, homed")

# psm.move_jp(goal).wait(): the busy pair after the command.
rec.wait_for(lambda: rec.count(f"{ARM}/setpoint_js") > 0, 30.0, "setpoint_js")
home = list(rec.latest(f"{ARM}/setpoint_js").position)
goal = list(home)
goal[2] -= 0.004  # 4 mm out, away from the liver
seen = rec.count(f"{ARM}/operating_state")
publishers["move_jp"].publish(JointState(position=goal))
rec.wait_for(lambda: busy_pair_since(seen), 300.0, "move_jp's busy pair")
# The node sends the idle state after the joint state of the frame that ended the move (the
# executor may hand this probe the two in either order when both are waiting).
error = lambda: max(abs(a - b) for a, b in zip(rec.latest(f"{ARM}/measured_js").position, goal))
at_idle = error()
rec.wait_for(lambda: error() < 1e-6, 1.0, f"measured_js at the goal (off by {error():.2e})")
check(True, f"move_jp(...).wait(): insertion {goal[2]:.4f} m, as asked "
      f"(measured_js {at_idle * 1e3:.3f} mm off when the idle state was read)")

# psm.servo_cp(goal): 2 mm along the base's x from where the tool is.
cp = rec.latest(f"{ARM}/setpoint_cp")
target = PoseStamped(header=cp.header, pose=cp.pose)
target.pose.position.x += 0.002
publishers["servo_cp"].publish(target)
rec.wait_for(lambda: abs(rec.latest(f"{ARM}/measured_cp").pose.position.x
                         - target.pose.position.x) < 1e-4, 300.0, "servo_cp")
check(True, "servo_cp: the tool 2 mm along x")

# psm.jaw.open(), psm.jaw.close(): move_jp to 60° and to −20°, each waited for.
for name, angle in (("open", math.radians(60.0)), ("close", math.radians(-20.0))):
    publishers["jaw/move_jp"].publish(JointState(position=[angle]))
    rec.wait_for(lambda: abs(rec.latest(f"{ARM}/jaw/setpoint_js").position[0] - angle) < 1e-6,
                 300.0, f"jaw {name}")
    check(True, f"jaw.{name}(): {math.degrees(angle):.0f}°")

# psm.forward_kinematics(jp) and psm.local.forward_kinematics(jp): the tool frame at the
# joints now, as measured_cp (and local/measured_cp, the same base frame) say.
jp = list(rec.latest(f"{ARM}/measured_js").position)
measured = rec.latest(f"{ARM}/measured_cp").pose.position
for name, client in (("forward_kinematics", forward), ("local/forward_kinematics", local_forward)):
    client.wait_for_service(timeout_sec=10.0) or fail(f"no {name} service")
    future = client.call_async(QueryForwardKinematics.Request(jp=jp))
    rec.wait_for(future.done, 10.0, f"the {name} answer")
    answer = future.result()
    p = answer.cp.position
    check(answer.result
          and math.dist((p.x, p.y, p.z), (measured.x, measured.y, measured.z)) < 1e-6,
          f"{name}: ({p.x:.4f}, {p.y:.4f}, {p.z:.4f}) m, measured_cp's")

# ecm.move_jp(goal).wait(): the scope turns 0.05 rad in yaw; its wrench reads zero.
ecm_state = lambda: rec.latest("/ECM/operating_state")
rec.wait_for(lambda: ecm_state() is not None and rec.count("/ECM/setpoint_js") > 0, 30.0,
             "the ECM's state")
goal = list(rec.latest("/ECM/setpoint_js").position)
goal[0] += 0.05
seen = rec.count("/ECM/operating_state")
ecm_publishers["move_jp"].publish(JointState(position=goal))
rec.wait_for(lambda: any(m.is_busy for _, m in rec.messages["/ECM/operating_state"][seen:])
             and not ecm_state().is_busy, 300.0, "the ECM's move_jp busy pair")
error = lambda: max(abs(a - b) for a, b in zip(rec.latest("/ECM/measured_js").position, goal))
rec.wait_for(lambda: error() < 1e-6, 1.0, f"the ECM at its goal (off by {error():.2e})")
cf = rec.latest("/ECM/spatial/measured_cf")
check(cf.header.frame_id == "ECM_base" and cf.wrench.force.x == cf.wrench.force.z == 0.0,
      "ecm.move_jp(...).wait(): yaw +0.05 rad; spatial/measured_cf zero in ECM_base")

rec.close()
