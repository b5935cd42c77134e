"""The guidance node in time: a stall of its own process is not a failure of the telemetry."""

import math
import threading
import time

import numpy as np
import pytest
from geometry_msgs.msg import PointStamped, PoseWithCovarianceStamped
from node_harness import beside, spin_until  # test/nodes is on the path (pytest's prepend import)
from sensor_msgs.msg import Imu
from std_msgs.msg import Bool

from auv_dock_guidance.control.cascade import Attitude
from auv_dock_guidance.control.guidance import State
from auv_dock_guidance.geometry.uncertainty import UNKNOWN_VARIANCE
from auv_dock_guidance.nodes.conversions import attitude_to_imu, seconds_stamp
from auv_dock_guidance.nodes.guidance import GuidanceNode, position_covariance_optical


def test_a_stall_of_the_guidance_process_does_not_abort_it_while_telemetry_keeps_coming(ros):
    node = GuidanceNode()
    harness, executor = beside(node)
    imu = harness.create_publisher(Imu, "vehicle/imu", 10)
    target = harness.create_publisher(PointStamped, "dock/target", 10)
    detected = harness.create_publisher(Bool, "dock/detected", 10)
    running = threading.Event()
    running.set()

    def main_controller_and_camera() -> None:
        """Telemetry at 50 Hz and a dock 8 m ahead at 10 Hz, whatever the guidance process is doing."""
        tick = 0
        while running.is_set():
            now = time.time()
            imu.publish(attitude_to_imu(Attitude(now, 0.0, 0.0, 0.0, 2.0), (0.0, 0.0, 0.0), "base_link"))
            if tick % 5 == 0:
                point = PointStamped()
                point.header.stamp = seconds_stamp(now)
                point.point.z = 8.0
                target.publish(point)
                detected.publish(Bool(data=True))
            tick += 1
            time.sleep(0.02)

    publisher = threading.Thread(target=main_controller_and_camera, daemon=True)
    publisher.start()
    try:
        spin_until(executor, lambda: node.guidance.state is State.TRACK)
        time.sleep(0.8)  # this process stalls (not spinning); the telemetry keeps coming and queues
        end = time.monotonic() + 0.5
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.02)
            assert node.guidance.state is not State.ABORT, "a stall of guidance's own process aborted it"
        assert node.guidance.state is State.TRACK
        running.clear()
        publisher.join()
        spin_until(executor, lambda: node.guidance.state is State.ABORT, timeout_s=3.0)  # telemetry really stops
    finally:
        running.clear()
        publisher.join()
        node.destroy_node()
        harness.destroy_node()


def test_dock_pose_position_covariance_is_taken_only_when_it_says_something():
    msg = PoseWithCovarianceStamped()
    block = np.diag([0.01, 0.02, 0.3])
    covariance = np.zeros((6, 6))
    covariance[:3, :3] = block
    covariance[3:, 3:] = UNKNOWN_VARIANCE * np.eye(3)  # orientation unobserved: the position still counts
    msg.pose.covariance = covariance.ravel().tolist()
    assert position_covariance_optical(msg) == pytest.approx(block)
    for unusable in (UNKNOWN_VARIANCE, math.nan):
        covariance[2, 2] = unusable
        msg.pose.covariance = covariance.ravel().tolist()
        assert position_covariance_optical(msg) is None
