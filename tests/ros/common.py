"""Helpers shared by the rclpy tests: a node that records the latest message per topic."""

import math
import sys
import time

import rclpy
from rclpy.qos import QoSProfile, DurabilityPolicy, ReliabilityPolicy, HistoryPolicy


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

        self.node.create_subscription(msg_type, topic, callback, qos)

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

    def close(self):
        self.node.destroy_node()
        rclpy.shutdown()


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
