"""ros2 launch auv_dock_guidance dock_guidance.launch.py [port:=/dev/ttyUSB0] [source:=device] [path:=0]

The four nodes with config/dock_guidance.yaml, on a real ROS 2 install. On a machine with
only the PyPI wheels, `auv-dock run` starts the same set from the same file.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, SetEnvironmentVariable
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from auv_dock_guidance.launcher import udp_only_environment


def generate_launch_description():
    config = os.path.join(get_package_share_directory("auv_dock_guidance"), "config")
    params = os.path.join(config, "dock_guidance.yaml")
    port = LaunchConfiguration("port")
    source = LaunchConfiguration("source")
    path = LaunchConfiguration("path")
    udp_only = udp_only_environment(os.environ)  # off shared memory, also when discovery is localhost-only
    return LaunchDescription([
        DeclareLaunchArgument("port", default_value="/dev/ttyUSB0", description="main controller serial port"),
        DeclareLaunchArgument("source", default_value="device", description="device | video | folder | sim"),
        DeclareLaunchArgument("path", default_value="0", description="camera index/path, video or folder"),
        SetEnvironmentVariable("FASTRTPS_DEFAULT_PROFILES_FILE", os.path.join(config, "fastdds_shm.xml")),
        # camera_ingest and detector share one process: 1080p frames stay inside it. Niced, so
        # that it yields the CPU to guidance and the serial bridge when the computer is short of it.
        Node(package="auv_dock_guidance", executable="dock_vision_pipeline", prefix="nice -n 5",
             parameters=[params, {"source": source, "path": path}], output="screen"),
        # Small messages only: off shared memory, so a restart after a crash is never deaf.
        Node(package="auv_dock_guidance", executable="dock_guidance", name="guidance",
             parameters=[params], output="screen", additional_env=udp_only),
        Node(package="auv_dock_guidance", executable="dock_serial_bridge", name="serial_bridge",
             parameters=[params, {"port": port}], output="screen", additional_env=udp_only),
    ])
