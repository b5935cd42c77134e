"""`auv-dock monitor` and `auv-dock foxglove`: watching a run from the shore, read-only."""

from __future__ import annotations

import argparse
import math
import os
import time
from collections import deque
from typing import Any

from auv_dock_guidance.cli.common import domain_id, positive_float, tcp_port


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    m = subparsers.add_parser("monitor", help="live terminal dashboard of a docking run (subscribes only)",
                              description="Guidance state and the last transition, range and bearing, detection "
                              "rate, thruster pulses, link health and diagnostics, with how stale each value is.")
    m.add_argument("--domain-id", type=domain_id, help="ROS_DOMAIN_ID of the vehicle")
    m.add_argument("--once", type=positive_float, metavar="S", help="listen S seconds, print one snapshot, exit")
    m.set_defaults(run=run_monitor)
    f = subparsers.add_parser("foxglove", help="serve the debug topics to the Foxglove app (WebSocket)",
                              description="Forward the debug topics, as recorded CDR with their ROS 2 schemas, to "
                              "Foxglove over its WebSocket protocol. Open the layout config/foxglove_layout.json.")
    f.add_argument("--port", type=tcp_port, default=8765)
    f.add_argument("--host", default="127.0.0.1", help="address to listen on (0.0.0.0 for the boat's network)")
    f.add_argument("--domain-id", type=domain_id)
    f.add_argument("--seconds", type=positive_float, help="stop after this long (default: until Ctrl-C)")
    f.set_defaults(run=run_foxglove)


class ShoreView:
    """What the monitor knows, each value with the time it arrived."""

    def __init__(self) -> None:
        self.values: dict[str, tuple[float, Any]] = {}
        self.detections: deque[tuple[float, bool]] = deque(maxlen=600)
        self.warnings: dict[str, tuple[float, str]] = {}

    def put(self, key: str, value: Any) -> None:
        self.values[key] = (time.monotonic(), value)

    def age(self, key: str) -> float:
        return time.monotonic() - self.values[key][0] if key in self.values else math.inf

    def get(self, key: str) -> Any:
        return self.values.get(key, (0.0, None))[1]

    def detection_rate(self) -> tuple[float, float]:
        now = time.monotonic()
        recent = [found for t, found in self.detections if now - t < 5.0]
        return (sum(recent) / len(recent) if recent else 0.0, len(recent) / 5.0)

    def render(self) -> Any:
        from rich.table import Table

        def stale(key: str) -> str:
            age = self.age(key)
            return "never" if math.isinf(age) else (f"{age:.1f} s ago" if age >= 1.0 else "live")

        table = Table(title="auv_dock_guidance: shore monitor (read-only)", expand=True)
        table.add_column("what")
        table.add_column("value")
        table.add_column("age", justify="right")
        table.add_row("guidance state", str(self.get("state") or "-"), stale("state"))
        table.add_row("last transition", str(self.get("transition") or "-"), stale("transition"))
        bearing = self.get("bearing")
        table.add_row("range / yaw / pitch", "-" if bearing is None else
                      f"{bearing[2]:.2f} m  {math.degrees(bearing[0]):+.2f} deg  {math.degrees(bearing[1]):+.2f} deg",
                      stale("bearing"))
        rate, fps = self.detection_rate()
        table.add_row("detection rate / fps", f"{100 * rate:.0f} %  {fps:.1f} fps", stale("detected"))
        pwm = self.get("pwm")
        bars = "-" if pwm is None else "  ".join(
            f"{p:4d} {'#' * int(max(0, p - 1500) / 40):<10}{'-' * int(max(0, 1500 - p) / 40):<10}" for p in pwm)
        table.add_row("thrusters (us)", bars, stale("pwm"))
        link = self.get("link")
        table.add_row("link", "-" if link is None else link, stale("link"))
        for name, (_, text) in sorted(self.warnings.items()):
            table.add_row(f"[yellow]{name}[/]", f"[yellow]{text}[/]", "")
        return table


def _node(domain_id: int | None, name: str) -> Any:
    import rclpy

    if domain_id is not None:
        os.environ["ROS_DOMAIN_ID"] = str(domain_id)
    rclpy.init()
    # A watcher has nothing to say: no /rosout, no parameter services.
    return rclpy.create_node(name, enable_rosout=False, start_parameter_services=False)


def run_monitor(args: argparse.Namespace) -> int:
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from geometry_msgs.msg import Vector3Stamped
    from rich.console import Console
    from rich.live import Live
    from std_msgs.msg import Bool, String, UInt16MultiArray

    from auv_dock_guidance.nodes.common import TRANSITION_QOS

    view = ShoreView()
    node = _node(args.domain_id, "auv_dock_shore_monitor")
    node.create_subscription(String, "guidance/state", lambda m: view.put("state", m.data), 10)
    node.create_subscription(String, "guidance/transition", lambda m: view.put("transition", m.data), TRANSITION_QOS)
    node.create_subscription(Vector3Stamped, "dock/bearing",
                             lambda m: view.put("bearing", (m.vector.x, m.vector.y, m.vector.z)), 10)

    def on_detected(m: Bool) -> None:
        view.put("detected", m.data)
        view.detections.append((time.monotonic(), m.data))

    node.create_subscription(Bool, "dock/detected", on_detected, 10)
    node.create_subscription(UInt16MultiArray, "thrusters/command", lambda m: view.put("pwm", list(m.data)), 10)

    def on_diagnostics(m: DiagnosticArray) -> None:
        for status in m.status:
            values = {kv.key: kv.value for kv in status.values}
            if status.name.endswith("serial_bridge"):
                view.put("link", f"{status.message}; frames {values.get('frames_received')}, CRC errors "
                         f"{values.get('crc_errors')}, failsafe events {values.get('failsafe_events')}")
            if status.level != DiagnosticStatus.OK:
                view.warnings[status.name] = (time.monotonic(), status.message)
            else:
                view.warnings.pop(status.name, None)

    node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, 10)
    console = Console()
    try:
        if args.once:
            end = time.monotonic() + args.once
            while time.monotonic() < end:
                rclpy.spin_once(node, timeout_sec=0.1)
            console.print(view.render())
            return 0
        with Live(view.render(), console=console, refresh_per_second=4) as live:
            while True:
                rclpy.spin_once(node, timeout_sec=0.1)
                live.update(view.render())
    except KeyboardInterrupt:
        return 0
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def run_foxglove(args: argparse.Namespace) -> int:
    import foxglove
    import rclpy
    from rosbags.typesys import Stores, get_typestore

    from auv_dock_guidance.recording import DEBUG_TOPICS, listening_qos, message_class

    typestore = get_typestore(Stores.ROS2_JAZZY)
    server = foxglove.start_server(name="auv_dock_guidance", host=args.host, port=args.port)
    node = _node(args.domain_id, "auv_dock_foxglove_bridge")
    channels = []
    for topic, msgtype in DEBUG_TOPICS.items():
        definition, _ = typestore.generate_msgdef(msgtype, ros_version=2)
        schema = foxglove.Schema(name=msgtype, encoding="ros2msg", data=definition.encode())
        channel = foxglove.Channel("/" + topic.lstrip("/"), schema=schema, message_encoding="cdr")
        channels.append(channel)
        node.create_subscription(message_class(msgtype), topic,
                                 lambda raw, ch=channel: ch.log(bytes(raw), log_time=time.time_ns()),
                                 listening_qos(topic), raw=True)
    print(f"Foxglove: open ws://{args.host}:{args.port} (layout config/foxglove_layout.json); Ctrl-C stops", flush=True)
    end = time.monotonic() + args.seconds if args.seconds else None
    try:
        while end is None or time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.1)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        server.stop()
    return 0
