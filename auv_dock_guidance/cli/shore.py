"""`auv-dock monitor` and `auv-dock foxglove`: watching a run from the shore, read-only."""

from __future__ import annotations

import argparse
import math
import os
import time
from collections import deque
from typing import Any

from auv_dock_guidance.cli.common import domain_from_environment, domain_id, fail, positive_float, tcp_port
from auv_dock_guidance.launcher import running_systems, stop_on_signals


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    m = subparsers.add_parser("monitor", help="live terminal dashboard of a docking run (subscribes only)",
                              description="Guidance state and the last transition, range and bearing, detection "
                              "rate, thruster pulses, link health and diagnostics, with how stale each value is. "
                              "Without --domain-id: the domain of the one auv-dock run/demo/soak/bench running on "
                              "this machine, else $ROS_DOMAIN_ID (or 0). Not on a terminal: one line per change "
                              "of the guidance state.")
    m.add_argument("--domain-id", type=domain_id, help="ROS_DOMAIN_ID of the vehicle")
    m.add_argument("--once", type=positive_float, metavar="S", help="listen S seconds, print one snapshot, exit")
    m.set_defaults(run=run_monitor)
    f = subparsers.add_parser("foxglove", help="serve the debug topics to the Foxglove app (WebSocket)",
                              description="Forward the debug topics, as recorded CDR with their ROS 2 schemas, to "
                              "Foxglove over its WebSocket protocol. Open the layout config/foxglove_layout.json. "
                              "Without --domain-id: as auv-dock monitor.")
    f.add_argument("--port", type=tcp_port, default=8765)
    f.add_argument("--host", default="127.0.0.1", help="address to listen on (0.0.0.0 for the boat's network)")
    f.add_argument("--domain-id", type=domain_id)
    f.add_argument("--seconds", type=positive_float, help="stop after this long (default: until Ctrl-C)")
    f.set_defaults(run=run_foxglove)


NO_PUBLISHERS_AFTER_S = 5.0  # discovery on one machine takes a second or two


def watched_domain(requested: int | None) -> int:
    """The domain to listen on, and a line saying which and why: the one running system found
    on this machine (launcher.running_systems), else $ROS_DOMAIN_ID or 0."""
    if requested is not None:
        print(f"listening on ROS domain {requested}", flush=True)
        return requested
    systems = running_systems()
    if len(systems) > 1:
        fail("several auv-dock runs on this machine (" + ", ".join(
            f"{s.command} pid {s.pid} on domain {s.domain_id}" for s in systems) + "); choose one with --domain-id N")
    if systems:
        found = systems[0]
        print(f"listening on ROS domain {found.domain_id}: auv-dock {found.command} (pid {found.pid}) runs there",
              flush=True)
        return found.domain_id
    domain = domain_from_environment()
    print(f"no auv-dock run found on this machine; listening on ROS domain {domain} "
          f"({'$ROS_DOMAIN_ID' if os.environ.get('ROS_DOMAIN_ID') else 'the default'}; --domain-id N to choose)",
          flush=True)
    return domain


def no_publishers_note(domain: int) -> str:
    return (f"no publishers of the debug topics on ROS domain {domain} "
            f"(is the vehicle on this domain? choose with --domain-id N)")


class ShoreView:
    """What the monitor knows, each value with the time it arrived."""

    def __init__(self, domain: int = 0) -> None:
        self.domain = domain
        self.publishers: int | None = None  # on the watched topics; None until counted
        self.ever_published = False
        self.started = time.monotonic()
        self.values: dict[str, tuple[float, Any]] = {}
        self.detections: deque[tuple[float, bool]] = deque(maxlen=600)
        self.warnings: dict[str, tuple[float, str]] = {}

    def count_publishers(self, count: int) -> None:
        self.publishers = count
        self.ever_published = self.ever_published or count > 0

    def domain_note(self) -> str | None:
        """What a person must know about the domain: none publishes there (yet, or any more); None if fine."""
        if self.publishers:
            return None
        if self.ever_published:
            return f"the publishers on ROS domain {self.domain} are gone (the run ended?)"
        if time.monotonic() - self.started > NO_PUBLISHERS_AFTER_S:
            return no_publishers_note(self.domain)
        return None

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
        note = self.domain_note()
        if note is not None:
            table.add_row("[yellow]ROS domain[/]", f"[yellow]{note}[/]", "")
        else:
            table.add_row("ROS domain", f"{self.domain} ({self.publishers or 0} publishers)", "")
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


def _node(domain: int, name: str) -> Any:
    """Our node; SIGTERM and SIGHUP end the watch as Ctrl-C does (launcher.stop_on_signals)."""
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    rclpy.init(domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
    # A watcher has nothing to say: no /rosout, no parameter services.
    return rclpy.create_node(name, enable_rosout=False, start_parameter_services=False)


def _publishers(node: Any, topics: list[str]) -> int:
    return sum(node.count_publishers(t) for t in topics)


def run_monitor(args: argparse.Namespace) -> int:
    with stop_on_signals():
        return _monitor(args)


def _monitor(args: argparse.Namespace) -> int:
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from geometry_msgs.msg import Vector3Stamped
    from rich.console import Console
    from rich.live import Live
    from std_msgs.msg import Bool, String, UInt16MultiArray

    from auv_dock_guidance.nodes.common import TRANSITION_QOS, destroy_and_shut_down

    domain = watched_domain(args.domain_id)
    view = ShoreView(domain)
    node = _node(domain, "auv_dock_shore_monitor")
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
    topics = ["guidance/state", "dock/detected", "thrusters/command", "/diagnostics"]
    try:
        if args.once:
            end = time.monotonic() + args.once
            while time.monotonic() < end:
                rclpy.spin_once(node, timeout_sec=0.1)
            view.count_publishers(_publishers(node, topics))
            console.print(view.render())
            if not view.values:
                console.print(f"nothing received in {args.once:g} s: {no_publishers_note(domain)}")
                return 1
            return 0
        if not console.is_terminal:
            return _log_changes(node, view, topics)
        with Live(view.render(), console=console, refresh_per_second=4) as live:
            while True:
                rclpy.spin_once(node, timeout_sec=0.1)
                view.count_publishers(_publishers(node, topics))
                live.update(view.render())
    except KeyboardInterrupt:
        return 0
    finally:
        destroy_and_shut_down([node])


def _log_changes(node: Any, view: ShoreView, topics: list[str]) -> int:
    """Not on a terminal (a log file, a pipe): one line per new guidance state or transition."""
    import rclpy

    said: dict[str, Any] = {}
    while True:
        rclpy.spin_once(node, timeout_sec=0.1)
        for key in ("state", "transition"):
            value = view.get(key)
            if value is not None and value != said.get(key):
                said[key] = value
                print(f"{time.strftime('%H:%M:%S')} {'guidance state' if key == 'state' else 'transition'}: "
                      f"{value}", flush=True)
        view.count_publishers(_publishers(node, topics))
        note = view.domain_note()
        if note != said.get("note", "") and (note is not None or view.publishers):
            print(f"{time.strftime('%H:%M:%S')} {note or f'publishers on ROS domain {view.domain}'}", flush=True)
            said["note"] = note


def run_foxglove(args: argparse.Namespace) -> int:
    with stop_on_signals():
        return _foxglove(args)


def _foxglove(args: argparse.Namespace) -> int:
    import foxglove
    import rclpy
    from rosbags.typesys import Stores, get_typestore

    from auv_dock_guidance.nodes.common import destroy_and_shut_down
    from auv_dock_guidance.recording import DEBUG_TOPICS, listening_qos, message_class

    typestore = get_typestore(Stores.ROS2_JAZZY)
    domain = watched_domain(args.domain_id)
    try:
        server = foxglove.start_server(name="auv_dock_guidance", host=args.host, port=args.port)
    except RuntimeError as exc:
        fail(f"cannot serve on {args.host}:{args.port}: {exc}", code=1)
    node = _node(domain, "auv_dock_foxglove_bridge")
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
    start = time.monotonic()
    end = start + args.seconds if args.seconds else None
    heard = False
    try:
        while end is None or time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.1)
            if not heard and time.monotonic() - start > NO_PUBLISHERS_AFTER_S:
                heard = _publishers(node, list(DEBUG_TOPICS)) > 0
                print("publishers found; forwarding" if heard else no_publishers_note(domain), flush=True)
                start = math.inf if heard else time.monotonic() + 25.0  # say it again every 30 s
    except KeyboardInterrupt:
        pass
    finally:
        destroy_and_shut_down([node])
        server.stop()
    return 0
