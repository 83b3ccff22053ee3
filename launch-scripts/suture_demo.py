#!/usr/bin/env python3
"""Suture demo: PSM1 throws one stitch across the wound of config/suture.toml, PSM2 takes the
needle from it and pulls the stitch closed, both arms driven with CRTK commands as a dVRK
user scripts them.
    launch-scripts/run_node.sh config/suture.toml &
    .venv/bin/python launch-scripts/suture_demo.py
PSM1 holds a half-circle needle with its centre on the instrument's axis (suture.toml's
tool_xyz), so rolling the instrument turns the needle along its own arc; the thread's tail
is held over the left block. PSM2's grasper starts open over it.
1. `trajectory_j/set_ratio` 1/6: moves at a sixth of dVRK's speeds (the roll peaks at
   180 deg/s; a move's speed rises and falls smoothly, so a full turn takes 3.75 s).
2. `move_jp`, the roll from +180 to -180 deg: the needle's tip enters the left block, passes
   under the wound and leaves the right block; the thread swaged to it follows its path.
3. PSM2 `move_cp`: the grasper turned a quarter about the instrument (its jaws across the
   needle's wire) and moved onto the top of the needle's arc.
4. PSM2 `jaw/move_jp` -20 deg: the jaws close on the needle and press; it is PSM2's.
5. PSM1 `jaw/move_jp` 30 deg: the needle driver opens and lets the needle go.
6. PSM2 `move_cp` twice: the needle drawn up and back over the left block, which pulls the
   thread tight across the wound.
Waits follow simulated time (the stamps of PSM1/measured_js), so the script works however
fast the simulation runs. It reads the wound gap from `tissue/wound_gap` (std_msgs/Float64),
prints it before and after, and exits with status 1 unless the gap closed by half.
"""

import math
import sys

import rclpy
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

RATIO = 1.0 / 6.0
ROLL = 3  # index of the instrument's roll in PSM1's joints
# The needle's moves after the handover, in world coordinates (m): up 14 mm and 12 mm back
# over the left block, then 4 mm higher. PSM2's base keeps the world's axes.
LIFTS = [(-0.012, -0.004, 0.014), (-0.002, -0.001, 0.004)]
# From PSM2's home over the tail (-4, -7, 21.5) mm to 4 mm above the top of the needle's arc
# at (0, 0, 27) mm: the jaws' middle on the wire.
ONTO_NEEDLE = (0.004, 0.007, 0.0095)
GRASP_JAW = math.radians(-20.0)
RELEASE_JAW = math.radians(30.0)


def turned_a_quarter(q):
    """Quaternion q (x, y, z, w) turned 90 deg about its own z axis: q * (0, 0, s, s)."""
    s = math.sqrt(0.5)
    x, y, z, w = q
    return (s * (x + y), s * (y - x), s * (z + w), s * (w - z))


def main():
    rclpy.init()
    node = rclpy.create_node("suture_demo")
    move_jp = node.create_publisher(JointState, "/PSM1/move_jp", 10)
    move_cp = {arm: node.create_publisher(PoseStamped, f"/{arm}/move_cp", 10)
               for arm in ("PSM1", "PSM2")}
    jaw_move_jp = {arm: node.create_publisher(JointState, f"/{arm}/jaw/move_jp", 10)
                   for arm in ("PSM1", "PSM2")}
    ratio = node.create_publisher(Float64, "/PSM1/trajectory_j/set_ratio", 10)
    state = {"t": None, "q": None, "cp": {}, "jaw": {}, "gap": None, "gaps": 0, "ratio": None}

    def on_js(msg):
        state["t"] = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        state["q"] = list(msg.position)

    def on_cp(arm):
        def store(msg):
            state["cp"][arm] = msg
        return store

    def on_jaw(arm):
        def store(msg):
            state["jaw"][arm] = msg.position[0]
        return store

    def on_gap(msg):
        state["gap"] = msg.data
        state["gaps"] += 1

    def on_ratio(msg):
        state["ratio"] = msg.data

    node.create_subscription(JointState, "/PSM1/measured_js", on_js, 10)
    for arm in ("PSM1", "PSM2"):
        node.create_subscription(PoseStamped, f"/{arm}/measured_cp", on_cp(arm), 10)
        node.create_subscription(JointState, f"/{arm}/jaw/measured_js", on_jaw(arm), 10)
    node.create_subscription(Float64, "/tissue/wound_gap", on_gap, 10)
    node.create_subscription(Float64, "/PSM1/trajectory_j/ratio", on_ratio, 10)

    def wait_for(done, what, timeout_s=900.0):
        """Spins until done() holds; fails after timeout_s of wall time."""
        start = node.get_clock().now()
        while not done():
            rclpy.spin_once(node, timeout_sec=0.05)
            if (node.get_clock().now() - start).nanoseconds * 1e-9 > timeout_s:
                print(f"timed out waiting for {what}", file=sys.stderr)
                sys.exit(2)

    def fresh_gap(what):
        """A wound gap measured after now (two new ones: the first may have been on its way)."""
        seen = state["gaps"]
        wait_for(lambda: state["gaps"] >= seen + 2, what)
        return state["gap"]

    def wait_sim(seconds, what):
        t0 = state["t"]
        wait_for(lambda: state["t"] - t0 >= seconds, what)

    def move_by(arm, step, what, turn=False):
        """move_cp of `arm` by `step` (in its base frame), turned a quarter about the
        instrument with `turn`, waiting until it gets there."""
        wait_sim(0.05, f"{arm}'s measured_cp to catch up with its joints")
        start = state["cp"][arm].pose
        target = PoseStamped()
        target.header.frame_id = f"{arm}_base"
        target.pose.orientation = start.orientation
        if turn:
            o = start.orientation
            (target.pose.orientation.x, target.pose.orientation.y,
             target.pose.orientation.z, target.pose.orientation.w) = turned_a_quarter(
                (o.x, o.y, o.z, o.w))
        target.pose.position.x = start.position.x + step[0]
        target.pose.position.y = start.position.y + step[1]
        target.pose.position.z = start.position.z + step[2]
        move_cp[arm].publish(target)

        def arrived():
            p = state["cp"][arm].pose.position
            goal = target.pose.position
            return math.dist((p.x, p.y, p.z), (goal.x, goal.y, goal.z)) < 1e-4

        wait_for(arrived, what)

    print("waiting for PSM1, PSM2 and the wound gap ...")
    wait_for(lambda: state["q"] is not None and len(state["cp"]) == 2
             and state["gap"] is not None, "PSM1, PSM2 and tissue/wound_gap")
    before = fresh_gap("the wound gap at the start")
    print(f"t={state['t']:.2f}s wound gap {before * 1e3:.2f} mm")

    ratio.publish(Float64(data=RATIO))
    wait_for(lambda: state["ratio"] is not None and abs(state["ratio"] - RATIO) < 1e-9,
             "trajectory_j/ratio to take the new ratio")

    goal = list(state["q"])
    goal[ROLL] -= 2.0 * math.pi
    move_jp.publish(JointState(position=goal))
    wait_for(lambda: abs(state["q"][ROLL] - goal[ROLL]) < 1e-4, "the roll through the tissue")
    thrown = fresh_gap("the wound gap after the throw")
    print(f"t={state['t']:.2f}s the needle turned once through both blocks, "
          f"wound gap {thrown * 1e3:.2f} mm")

    move_by("PSM2", ONTO_NEEDLE, "PSM2's grasper onto the needle", turn=True)
    jaw_move_jp["PSM2"].publish(JointState(position=[GRASP_JAW]))
    wait_for(lambda: state["jaw"].get("PSM2", 1.0) < 0.03, "PSM2's jaws to close on the needle")
    wait_sim(0.2, "PSM2's jaws to press")
    jaw_move_jp["PSM1"].publish(JointState(position=[RELEASE_JAW]))
    wait_for(lambda: state["jaw"].get("PSM1", 0.0) > RELEASE_JAW - 0.05,
             "PSM1's needle driver to open")
    print(f"t={state['t']:.2f}s PSM2 holds the needle and PSM1 has let it go")

    for step in LIFTS:
        move_by("PSM2", step, "the needle drawn back over the wound")
        print(f"t={state['t']:.2f}s needle moved by {step} m, "
              f"wound gap {fresh_gap('the wound gap after the move') * 1e3:.2f} mm")

    wait_sim(0.5, "half a second for the tissue to settle")
    after = fresh_gap("the wound gap at the end")
    node.destroy_node()
    rclpy.shutdown()
    print(f"wound gap {before * 1e3:.2f} mm -> {after * 1e3:.2f} mm")
    if not after < 0.5 * before:
        print("the wound did not close by half", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
