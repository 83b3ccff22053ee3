"""ROS 2 launch file for users with ROS 2 installed:

    ros2 launch launch-scripts/dvrk_tissue_sim.launch.py scene:=config/default.toml \
        node_name:=dvrk_tissue_sim namespace:=/ use_sim_time:=false

Starts the node binary (build it first with `cargo build --release`) from the repository
root, with the standard ROS arguments (`--ros-args -r __ns:=... -r __node:=... -p ...`), so
remaps and parameters given here reach it as they reach any ROS 2 node. rclpy / rclcpp
subscribers of the tissue cloud should load config/fastdds_large_data.xml
(FASTDDS_DEFAULT_PROFILES_FILE) with Fast DDS. `rviz2 -d launch-scripts/dvrk_tissue_sim.rviz`
shows the scene.
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess
from launch.substitutions import LaunchConfiguration

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument("scene", default_value="config/default.toml"),
        DeclareLaunchArgument("node_name", default_value="dvrk_tissue_sim"),
        DeclareLaunchArgument("namespace", default_value="/"),
        DeclareLaunchArgument("use_sim_time", default_value="false"),
        ExecuteProcess(
            cmd=[
                os.path.join(ROOT, "target", "release", "dvrk-tissue-sim"), "run",
                "--ros-args",
                "-r", ["__ns:=", LaunchConfiguration("namespace")],
                "-r", ["__node:=", LaunchConfiguration("node_name")],
                "-p", ["scene:=", LaunchConfiguration("scene")],
                "-p", ["use_sim_time:=", LaunchConfiguration("use_sim_time")],
            ],
            cwd=ROOT,
            output="screen",
        ),
    ])
