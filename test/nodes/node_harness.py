"""A harness node beside the node under test, on one executor, and spinning until something happened."""

from __future__ import annotations

import time
from collections.abc import Callable

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node


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
