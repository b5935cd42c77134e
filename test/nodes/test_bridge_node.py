"""The serial_bridge node on its own: foreign command publishers, telemetry out."""

from __future__ import annotations

import time

import rclpy
from sensor_msgs.msg import Imu
from std_msgs.msg import UInt16MultiArray

from auv_dock_guidance.launcher import NodeGroup, ros_environment
from auv_dock_guidance.sim.main_controller import MainControllerSim

NEUTRAL = (1500, 1500, 1500, 1500)


def test_commands_from_a_node_other_than_guidance_never_drive_the_thrusters(domain_id, tmp_path):
    controller = MainControllerSim().start()
    group = NodeGroup(["serial_bridge"], overrides={"serial_bridge": {"port": controller.port, "arm_on_start": True}},
                      env=ros_environment(domain_id=domain_id), log_dir=tmp_path)
    rclpy.init(domain_id=domain_id)
    node = rclpy.create_node("shore_laptop")
    imu: list[Imu] = []
    node.create_subscription(Imu, "vehicle/imu", imu.append, 10)
    rogue = node.create_publisher(UInt16MultiArray, "thrusters/command", 10)
    group.start()
    try:
        end = time.monotonic() + 12.0
        while time.monotonic() < end:
            rogue.publish(UInt16MultiArray(data=[1900, 1900, 1900, 1900]))
            rclpy.spin_once(node, timeout_sec=0.05)
            if imu and time.monotonic() > end - 6.0:
                break
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        group.stop()
        controller.stop()
    assert imu, "no telemetry came out of the bridge"
    assert all(r.pwm_us == NEUTRAL for r in controller.records())
    assert "foreign" in (tmp_path / "serial_bridge.log").read_text()
