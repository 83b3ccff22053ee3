"""Helpers shared by the rclpy tests: a node that records the latest message per topic."""

import math
import sys
import time

import rclpy
from rclpy.qos import QoSProfile, DurabilityPolicy, ReliabilityPolicy, HistoryPolicy
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState, Joy


def fail(message):
    print(f"FAIL: {message}", flush=True)
    sys.exit(1)


def check(condition, message):
    if not condition:
        fail(message)
    print(f"ok: {message}", flush=True)


LATCHED = QoSProfile(
    depth=100,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
    reliability=ReliabilityPolicy.RELIABLE,
    history=HistoryPolicy.KEEP_LAST,
)


class Recorder:
    """Subscribes topics and keeps every message (with arrival time)."""

    def __init__(self, name):
        rclpy.init()
        self.node = rclpy.create_node(name)
        self.messages = {}

    def subscribe(self, msg_type, topic, qos=10):
        self.messages[topic] = []

        def callback(msg, topic=topic):
            self.messages[topic].append((time.monotonic(), msg))

        return self.node.create_subscription(msg_type, topic, callback, qos)

    def publisher(self, msg_type, topic, qos=10):
        return self.node.create_publisher(msg_type, topic, qos)

    def spin_for(self, seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            rclpy.spin_once(self.node, timeout_sec=0.01)

    def wait_for(self, predicate, timeout, what):
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if predicate():
                return
            rclpy.spin_once(self.node, timeout_sec=0.01)
        fail(f"timed out after {timeout} s waiting for {what}")

    def latest(self, topic):
        msgs = self.messages.get(topic) or []
        return msgs[-1][1] if msgs else None

    def count(self, topic):
        return len(self.messages.get(topic) or [])

    def wait_subscribers(self, publisher, timeout=10.0):
        self.wait_for(lambda: publisher.get_subscription_count() > 0, timeout,
                      f"the node to subscribe {publisher.topic_name}")

    def sim_time(self, topic="/PSM1/measured_js"):
        """Simulated time: the stamp of the latest message on `topic` (subscribed)."""
        stamp = self.latest(topic).header.stamp
        return stamp.sec + stamp.nanosec * 1e-9

    def wait_sim(self, seconds, what, topic="/PSM1/measured_js"):
        """Waits `seconds` of simulated time, however slowly the simulation runs."""
        end = self.sim_time(topic) + seconds
        self.wait_for(lambda: self.sim_time(topic) >= end, 600.0, what)

    def close(self):
        self.node.destroy_node()
        rclpy.shutdown()



class ScriptedMtm:
    """An MTM played by a script, as dVRK's console sees one: `<mtm>/measured_cp` at `position`
    (`<mtm>_base`, identity orientation), the gripper at `gripper` (open), and the console's
    clutch and operator pedals. The teleoperated PSM's `measured_cp` is recorded to see where
    the arm went."""

    def __init__(self, rec, measured_cp_depth=10, mtm="MTMR", arm="PSM1"):
        self.rec = rec
        self.mtm = mtm
        self.arm = arm
        self.position = [0.0, -0.3, -0.1]
        self.gripper = 0.3
        rec.subscribe(PoseStamped, f"/{arm}/measured_cp", qos=measured_cp_depth)
        self._mtm = rec.publisher(PoseStamped, f"/{mtm}/measured_cp")
        self._gripper = rec.publisher(JointState, f"/{mtm}/gripper/measured_js")
        self._clutch = rec.publisher(Joy, "/console/clutch")
        self._present = rec.publisher(Joy, "/console/operator_present")
        rec.wait_for(lambda: rec.latest(f"/{arm}/measured_cp") is not None, 10.0,
                     f"{arm} measured_cp")
        for p in (self._mtm, self._gripper, self._clutch, self._present):
            rec.wait_subscribers(p)

    def send(self, repeat=1):
        """Publishes the MTM pose and gripper `repeat` times, 10 ms apart."""
        for _ in range(repeat):
            m = PoseStamped()
            m.header.frame_id = f"{self.mtm}_base"
            m.pose.position.x, m.pose.position.y, m.pose.position.z = self.position
            m.pose.orientation.w = 1.0
            self._mtm.publish(m)
            self._gripper.publish(JointState(name=["gripper"], position=[self.gripper]))
            self.rec.spin_for(0.01)

    def clutch(self, pressed):
        self._clutch.publish(Joy(buttons=[1 if pressed else 0]))

    def operator_present(self, pressed):
        self._present.publish(Joy(buttons=[1 if pressed else 0]))

    def move(self, dx, steps=50, pause=0.0, settle=30, rest=0.0):
        """Moves the MTM `dx` metres along x in `steps` messages (`pause` s more between them),
        then holds it there for `settle` messages and `rest` seconds."""
        for _ in range(steps):
            self.position[0] += dx / steps
            self.send()
            if pause:
                self.rec.spin_for(pause)
        self.send(settle)
        if rest:
            self.rec.spin_for(rest)

    def psm(self):
        """The PSM's latest measured position (m, in its base frame)."""
        p = self.rec.latest(f"/{self.arm}/measured_cp").pose.position
        return [p.x, p.y, p.z]

# ---- PSM forward kinematics from dVRK's modified DH table (independent of our URDF) ----

def _mat(rows):
    return [list(r) for r in rows]


def _mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def _dh(alpha, a, theta, d):
    ca, sa, ct, st = math.cos(alpha), math.sin(alpha), math.cos(theta), math.sin(theta)
    # Craig: RotX(alpha) TransX(a) RotZ(theta) TransZ(d)
    return _mat([
        [ct, -st, 0.0, a],
        [st * ca, ct * ca, -sa, -sa * d],
        [st * sa, ct * sa, ca, ca * d],
        [0.0, 0.0, 0.0, 1.0],
    ])


PSM_DH = [  # alpha, a, d, offset, prismatic
    (math.pi / 2, 0.0, 0.0, math.pi / 2, False),
    (-math.pi / 2, 0.0, 0.0, -math.pi / 2, False),
    (math.pi / 2, 0.0, 0.0, -0.4318, True),
    (0.0, 0.0, 0.4162, 0.0, False),
    (-math.pi / 2, 0.0, 0.0, -math.pi / 2, False),
    (-math.pi / 2, 0.0091, 0.0, -math.pi / 2, False),
]
TOOL_OFFSET = _mat([[0, -1, 0, 0], [0, 0, 1, 0], [-1, 0, 0, 0], [0, 0, 0, 1]])


def psm_fk(q):
    """4x4 pose of the PSM tool frame in PSM_base for joints q."""
    t = _mat([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    for (alpha, a, d, offset, prismatic), qi in zip(PSM_DH, q):
        if prismatic:
            t = _mul(t, _dh(alpha, a, 0.0, qi + offset))
        else:
            t = _mul(t, _dh(alpha, a, qi + offset, d))
    return _mul(t, TOOL_OFFSET)


def quat_to_matrix(x, y, z, w):
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
