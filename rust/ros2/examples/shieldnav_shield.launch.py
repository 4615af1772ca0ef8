"""Launches shieldnav-ros2 beside a robot: the planner's command is remapped to the shield's
input and the shield's output to the base.

    ros2 launch shieldnav_shield.launch.py params:=shieldnav_shield.yaml

The binary is found on PATH (`cargo install --path rust/ros2`) or given as `binary:=...`.
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess
from launch.substitutions import LaunchConfiguration

HERE = os.path.dirname(os.path.abspath(__file__))


def generate_launch_description():
    return LaunchDescription(
        [
            DeclareLaunchArgument("binary", default_value="shieldnav-ros2"),
            DeclareLaunchArgument("params", default_value=os.path.join(HERE, "shieldnav_shield.yaml")),
            DeclareLaunchArgument("scan", default_value="/scan"),
            DeclareLaunchArgument("odom", default_value="/odom"),
            DeclareLaunchArgument("nominal", default_value="/nav/cmd_vel"),
            DeclareLaunchArgument("cmd", default_value="/cmd_vel"),
            ExecuteProcess(
                cmd=[
                    LaunchConfiguration("binary"),
                    "--params",
                    LaunchConfiguration("params"),
                    "--ros-args",
                    "-r",
                    ["/scan:=", LaunchConfiguration("scan")],
                    "-r",
                    ["/odom:=", LaunchConfiguration("odom")],
                    "-r",
                    ["/cmd_vel_nominal:=", LaunchConfiguration("nominal")],
                    "-r",
                    ["/cmd_vel:=", LaunchConfiguration("cmd")],
                ],
                output="screen",
            ),
        ]
    )
