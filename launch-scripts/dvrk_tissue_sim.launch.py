"""ROS 2 launch file for users with ROS 2 installed:

    ros2 launch launch-scripts/dvrk_tissue_sim.launch.py scene:=config/default.toml \
        node_name:=dvrk_tissue_sim namespace:=/

Starts the node binary (build it first with `cargo build --release`) from the repository
root. rclpy / rclcpp subscribers of the tissue cloud should load
config/fastdds_large_data.xml (FASTDDS_DEFAULT_PROFILES_FILE) with Fast DDS.
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
        ExecuteProcess(
            cmd=[
                os.path.join(ROOT, "target", "release", "dvrk-tissue-sim"), "run",
                "--scene", LaunchConfiguration("scene"),
                "--node-name", LaunchConfiguration("node_name"),
                "--namespace", LaunchConfiguration("namespace"),
            ],
            cwd=ROOT,
            output="screen",
        ),
    ])
