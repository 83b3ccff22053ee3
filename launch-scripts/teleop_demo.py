#!/usr/bin/env python3
"""Teleoperation demo: a scripted MTM grasps the tissue with PSM1 and lifts it.

    launch-scripts/run_node.sh config/teleop.toml &
    .venv/bin/python launch-scripts/teleop_demo.py

Plays MTMR poses (measured_cp), its gripper angle (gripper/measured_js) and the console
pedals (operator_present, clutch) the way a real MTM and console publish them. The script
follows simulated time (PSM1/measured_cp stamps), so it works however fast the simulation
runs. With scale 0.2, the MTM moves 5x what the tool does.
"""

import math
import time

import rclpy
from geometry_msgs.msg import PoseStamped, WrenchStamped
from sensor_msgs.msg import JointState, Joy

SCALE = 0.2
# (duration in simulated s, MTM displacement in m from the start, gripper angle in rad)
SCRIPT = [
    (0.5, (0.0, 0.0, 0.0), math.radians(60)),      # open the gripper
    (1.5, (0.0, 0.0, -0.016 / SCALE), math.radians(60)),  # tool down 16 mm, jaws around tissue
    (0.8, (0.0, 0.0, -0.016 / SCALE), 0.0),         # close: grasp
    (1.5, (0.0, 0.0, -0.004 / SCALE), 0.0),         # lift 12 mm
    (1.0, (0.0, 0.0, -0.004 / SCALE), 0.0),         # hold
]


def main():
    rclpy.init()
    node = rclpy.create_node("teleop_demo")
    mtm = node.create_publisher(PoseStamped, "/MTMR/measured_cp", 10)
    gripper = node.create_publisher(JointState, "/MTMR/gripper/measured_js", 10)
    clutch = node.create_publisher(Joy, "/console/clutch", 10)
    present = node.create_publisher(Joy, "/console/operator_present", 10)
    state = {"t": None, "cp": None, "force": None}

    def on_cp(msg):
        state["t"] = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        state["cp"] = msg.pose.position

    def on_force(msg):
        state["force"] = msg.wrench.force

    node.create_subscription(PoseStamped, "/PSM1/measured_cp", on_cp, 10)
    node.create_subscription(WrenchStamped, "/MTMR/body/servo_cf", on_force, 10)
    print("waiting for PSM1 ...")
    while state["t"] is None:
        rclpy.spin_once(node, timeout_sec=0.1)
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
    offset, grip = (0.0, 0.0, 0.0), math.radians(60)
    for _ in range(50):
        send(offset, grip)
        rclpy.spin_once(node, timeout_sec=0.01)
    for duration, target, target_grip in SCRIPT:
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
              + (f", MTM force feedback ({f.x:+.3f}, {f.y:+.3f}, {f.z:+.3f}) N" if f else ""))
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
