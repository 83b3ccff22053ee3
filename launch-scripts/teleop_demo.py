#!/usr/bin/env python3
"""Teleoperation demo: a scripted MTM grasps the tissue with PSM1, lifts it and lets go.

    launch-scripts/run_node.sh config/teleop.toml &
    .venv/bin/python launch-scripts/teleop_demo.py

Plays MTMR poses (measured_cp), its gripper angle (gripper/measured_js) and the console
pedals (operator_present, clutch) the way a real MTM and console publish them. The script
follows simulated time (PSM1/measured_cp stamps), so it works however fast the simulation
runs. With scale 0.2, the MTM moves 5x what the tool does. Squeezing the MTM gripper past
its zero (as a hand does on a real MTM) maps to a negative jaw angle: the jaws meet and press
with dVRK's jaw effort, and the grip holds.

At the end it prints how far the grasped tissue rose and the force the MTM felt while
holding, and exits with status 1 if nothing was lifted.
"""

import math
import struct
import sys

import rclpy
from geometry_msgs.msg import PoseStamped, WrenchStamped
from sensor_msgs.msg import JointState, Joy, PointCloud2

SCALE = 0.2
OPEN = math.radians(60)
SQUEEZED = -0.25  # MTM gripper squeezed past its zero: jaw about -19 deg
# (duration in simulated s, MTM displacement in m from the start, gripper angle in rad)
SCRIPT = [
    (0.5, (0.0, 0.0, 0.0), OPEN),                      # open the jaws
    (1.5, (0.0, 0.0, -0.011 / SCALE), OPEN),           # tool down 11 mm: tips 5 mm in the liver
    (0.6, (0.0, 0.0, -0.011 / SCALE), SQUEEZED),       # squeeze: the jaws close on the tissue
    (0.4, (0.0, 0.0, -0.011 / SCALE), SQUEEZED),       # ... and press
    (1.5, (0.0, 0.0, -0.001 / SCALE), SQUEEZED),       # lift 10 mm
    (0.5, (0.0, 0.0, -0.001 / SCALE), SQUEEZED),       # hold
    (1.0, (0.0, 0.0, -0.001 / SCALE), OPEN),           # open: let go
]
HOLD_STEP = 5  # the step after which the lift is measured


def main():
    rclpy.init()
    node = rclpy.create_node("teleop_demo")
    mtm = node.create_publisher(PoseStamped, "/MTMR/measured_cp", 10)
    gripper = node.create_publisher(JointState, "/MTMR/gripper/measured_js", 10)
    clutch = node.create_publisher(Joy, "/console/clutch", 10)
    present = node.create_publisher(Joy, "/console/operator_present", 10)
    state = {"t": None, "cp": None, "force": None, "cloud": None}

    def on_cp(msg):
        state["t"] = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        state["cp"] = msg.pose.position

    def on_force(msg):
        state["force"] = msg.wrench.force

    node.create_subscription(PoseStamped, "/PSM1/measured_cp", on_cp, 10)
    def on_cloud(msg):
        state["cloud"] = msg

    node.create_subscription(WrenchStamped, "/MTMR/body/servo_cf", on_force, 10)
    node.create_subscription(PointCloud2, "/tissue/points", on_cloud, 2)
    print("waiting for PSM1 ...")
    while state["t"] is None or state["cloud"] is None:
        rclpy.spin_once(node, timeout_sec=0.1)

    def heights():
        data = bytes(state["cloud"].data)
        step = state["cloud"].point_step
        return [struct.unpack_from("<3f", data, i * step) for i in range(state["cloud"].width)]

    # The grasped region: the tissue within 4 mm of the instrument's axis, in its top 5 mm.
    rest = heights()
    near = [i for i, p in enumerate(rest) if math.hypot(p[0], p[1]) <= 0.004]
    top = max(rest[i][2] for i in near)
    region = [i for i in near if rest[i][2] >= top - 0.005]

    def rise():
        now = heights()
        return sum(now[i][2] - rest[i][2] for i in region) / len(region)

    start = [0.0, -0.3, -0.1]

    def send(offset, grip):
        m = PoseStamped()
        m.header.frame_id = "MTMR_base"
        m.pose.position.x = start[0] + offset[0]
        m.pose.position.y = start[1] + offset[1]
        m.pose.position.z = start[2] + offset[2]
        m.pose.orientation.w = 1.0
        mtm.publish(m)
        gripper.publish(JointState(name=["gripper"], position=[grip]))

    clutch.publish(Joy(buttons=[0]))
    present.publish(Joy(buttons=[1]))
    offset, grip = (0.0, 0.0, 0.0), OPEN
    for _ in range(50):
        send(offset, grip)
        rclpy.spin_once(node, timeout_sec=0.01)
    held_rise, held_force = None, None
    for step, (duration, target, target_grip) in enumerate(SCRIPT):
        t0 = state["t"]
        begin, begin_grip = offset, grip
        while state["t"] - t0 < duration:
            s = min(1.0, (state["t"] - t0) / duration)
            offset = tuple(b + (e - b) * s for b, e in zip(begin, target))
            grip = begin_grip + (target_grip - begin_grip) * s
            send(offset, grip)
            rclpy.spin_once(node, timeout_sec=0.005)
        cp, f = state["cp"], state["force"]
        print(f"t={state['t']:.2f}s tool at ({cp.x:+.4f}, {cp.y:+.4f}, {cp.z:+.4f}) m in PSM1_base"
              + (f", MTM force feedback ({f.x:+.3f}, {f.y:+.3f}, {f.z:+.3f}) N" if f else "")
              + f", tissue under the jaws {rise() * 1e3:+.1f} mm")
        if step == HOLD_STEP:
            held_rise, held_force = rise(), f
    released = rise()
    node.destroy_node()
    rclpy.shutdown()
    force = math.sqrt(held_force.x ** 2 + held_force.y ** 2 + held_force.z ** 2) if held_force else 0.0
    print(f"lifted: the grasped tissue rose {held_rise * 1e3:.1f} mm while held, the MTM felt "
          f"{force:.3f} N; {released * 1e3:.1f} mm after opening")
    if held_rise < 0.005 or force <= 0.0:
        print("nothing was lifted", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
