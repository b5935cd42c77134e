"""Record live topics into a ROS 2 bag (MCAP by default) without rosbag2: raw CDR straight to rosbags.

The subscriptions take the serialized bytes (``raw=True``), so nothing is deserialized
and serialized again; rosbags writes the message definitions, so Foxglove and
``ros2 bag`` open the file.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from auv_dock_guidance.errors import DockGuidanceError
from auv_dock_guidance.nodes.common import TRANSITION_QOS

DEBUG_TOPICS = {
    "dock/target": "geometry_msgs/msg/PointStamped",
    "dock/bearing": "geometry_msgs/msg/Vector3Stamped",
    "dock/detected": "std_msgs/msg/Bool",
    "dock/pose": "geometry_msgs/msg/PoseWithCovarianceStamped",
    "dock/marker": "visualization_msgs/msg/Marker",
    "dock/debug_image/compressed": "sensor_msgs/msg/CompressedImage",
    "guidance/state": "std_msgs/msg/String",
    "guidance/transition": "std_msgs/msg/String",
    "guidance/setpoint": "geometry_msgs/msg/Vector3Stamped",
    "guidance/demands": "geometry_msgs/msg/Vector3Stamped",
    "thrusters/command": "std_msgs/msg/UInt16MultiArray",
    "vehicle/imu": "sensor_msgs/msg/Imu",
    "vehicle/depth": "std_msgs/msg/Float64",
    "/diagnostics": "diagnostic_msgs/msg/DiagnosticArray",
}


def listening_qos(topic: str) -> QoSProfile:
    """How an observer subscribes: best effort (never slows the vehicle), but the latched
    transitions as latched, so the reasons for the current state arrive however late it joins."""
    if topic.lstrip("/") == "guidance/transition":
        return TRANSITION_QOS
    return QoSProfile(depth=50, reliability=ReliabilityPolicy.BEST_EFFORT)


def message_class(msgtype: str) -> type:
    """The rclpy message class for 'pkg/msg/Name'."""
    package, _, name = msgtype.split("/")
    module = __import__(f"{package}.msg", fromlist=[name])
    return getattr(module, name)


@dataclass(frozen=True)
class FrameTransform:
    """Where ``child`` is in ``parent``: translation (m) and rotation (x, y, z, w)."""

    parent: str
    child: str
    translation_m: tuple[float, float, float]
    rotation_xyzw: tuple[float, float, float, float]


class BagRecorder:
    def __init__(self, node: Node, path: Path, topics: dict[str, str], storage: str = "mcap") -> None:
        if path.exists():
            raise DockGuidanceError(f"{path} exists; a bag is never written over")
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        self._writer = Writer(path, version=9, storage_plugin=plugin)
        self._writer.open()
        self._lock = threading.Lock()
        self._closed = False
        self.counts: dict[str, int] = {}
        self.bytes: dict[str, int] = {}
        typestore = get_typestore(Stores.ROS2_JAZZY)
        self._typestore = typestore
        self._tf_connections: dict[str, Any] = {}
        self._subscriptions = []
        for topic, msgtype in topics.items():
            name = topic if topic.startswith("/") else f"/{topic}"
            connection = self._writer.add_connection(name, msgtype, typestore=typestore)
            self.counts[name] = 0
            self.bytes[name] = 0
            self._subscriptions.append(node.create_subscription(
                message_class(msgtype), topic, self._writer_for(connection, name, node), listening_qos(topic),
                raw=True))

    def _writer_for(self, connection, name: str, node: Node):
        def write(data: bytes) -> None:
            stamp = node.get_clock().now().nanoseconds
            with self._lock:
                if not self._closed:
                    self._writer.write(connection, stamp, data)
                    self.counts[name] += 1
                    self.bytes[name] += len(data)
        return write

    def write_transforms(self, transforms: list[FrameTransform], stamp_ns: int, static: bool = False) -> None:
        """Transforms on /tf (or /tf_static) as tf2_msgs/TFMessage, written by rosbags: the
        PyPI wheels have no tf2_msgs to publish them live, but a bag played in Foxglove or
        RViz shows the frames all the same."""
        topic = "/tf_static" if static else "/tf"
        ts = self._typestore
        types = ts.types
        stamp = types["builtin_interfaces/msg/Time"](sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)
        message = types["tf2_msgs/msg/TFMessage"](transforms=[
            types["geometry_msgs/msg/TransformStamped"](
                header=types["std_msgs/msg/Header"](stamp=stamp, frame_id=t.parent),
                child_frame_id=t.child,
                transform=types["geometry_msgs/msg/Transform"](
                    translation=types["geometry_msgs/msg/Vector3"](*(float(v) for v in t.translation_m)),
                    rotation=types["geometry_msgs/msg/Quaternion"](*(float(v) for v in t.rotation_xyzw))))
            for t in transforms])
        data = bytes(ts.serialize_cdr(message, "tf2_msgs/msg/TFMessage"))
        with self._lock:
            if self._closed:
                return
            if topic not in self._tf_connections:
                self._tf_connections[topic] = self._writer.add_connection(topic, "tf2_msgs/msg/TFMessage",
                                                                          typestore=ts)
            self._writer.write(self._tf_connections[topic], stamp_ns, data)

    def close(self) -> None:
        with self._lock:
            if not self._closed:
                self._closed = True
                self._writer.close()
