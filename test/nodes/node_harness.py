"""A harness node beside the node under test, on one executor, and spinning until something happened."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, Image
from std_msgs.msg import Bool

from auv_dock_guidance.nodes.detector import DetectorNode


def beside(node: Node, name: str = "harness") -> tuple[Node, SingleThreadedExecutor]:
    """A harness node next to ``node``, both on one executor."""
    harness = rclpy.create_node(name)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    executor.add_node(harness)
    return harness, executor


def spin_until(executor: SingleThreadedExecutor, done: Callable[[], bool], timeout_s: float = 10.0) -> None:
    end = time.monotonic() + timeout_s
    while not done():
        assert time.monotonic() < end, "timed out waiting for the node"
        executor.spin_once(timeout_sec=0.05)


def detector_with_camera() -> tuple[DetectorNode, Node, SingleThreadedExecutor, Any, Any, list[Bool]]:
    """A detector node beside a harness that publishes frames and camera info to it (newest
    frame, reliable, as camera_ingest does) and collects dock/detected: (detector, harness,
    executor, image publisher, camera info publisher, detections)."""
    detector = DetectorNode()
    harness, executor = beside(detector)
    newest = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
    images = harness.create_publisher(Image, "camera/image_raw", newest)
    infos = harness.create_publisher(CameraInfo, "camera/camera_info", 1)
    detected: list[Bool] = []
    harness.create_subscription(Bool, "dock/detected", detected.append, 10)
    return detector, harness, executor, images, infos, detected
