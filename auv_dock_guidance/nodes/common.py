"""What every node shares: start-up and shutdown, declared parameters with ranges."""

from __future__ import annotations

import faulthandler
import math
import os
import signal
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import rclpy
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.exceptions import InvalidParameterValueException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile

from auv_dock_guidance.errors import DockGuidanceError
from auv_dock_guidance.geometry.mounting import CameraMounting
from auv_dock_guidance.launcher import end_with_launcher

# guidance/transition is latched: whoever subscribes late (a shore laptop, a recorder) still
# gets the recent transitions, with the reason for the state the vehicle is in.
TRANSITION_QOS = QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL)


@dataclass(frozen=True)
class Param:
    """One declared parameter: default, what it means, and its allowed range."""

    name: str
    default: Any
    description: str
    low: float | None = None
    high: float | None = None
    read_only: bool = False

    def descriptor(self) -> ParameterDescriptor:
        d = ParameterDescriptor(description=self.description, read_only=self.read_only)
        if self.low is not None and self.high is not None:
            if isinstance(self.default, bool):
                pass
            elif isinstance(self.default, int):
                d.integer_range = [IntegerRange(from_value=int(self.low), to_value=int(self.high), step=1)]
            elif isinstance(self.default, float):
                d.floating_point_range = [FloatingPointRange(from_value=float(self.low), to_value=float(self.high))]
        return d


MOUNTING_PARAMS = [
    Param("camera_mounting.x_m", 0.9, "camera's optical centre ahead of base_link (m)", -20.0, 20.0, read_only=True),
    Param("camera_mounting.y_m", 0.0, "camera's optical centre left of base_link (m)", -20.0, 20.0, read_only=True),
    Param("camera_mounting.z_m", 0.0, "camera's optical centre above base_link (m)", -20.0, 20.0, read_only=True),
    Param("camera_mounting.roll_deg", 0.0, "camera roll about base_link's x (deg, REP 103)", -180.0, 180.0,
          read_only=True),
    Param("camera_mounting.pitch_deg", 0.0, "camera pitch (deg, REP 103: positive looks down)", -90.0, 90.0,
          read_only=True),
    Param("camera_mounting.yaw_deg", 0.0, "camera yaw (deg, REP 103: positive looks left)", -180.0, 180.0,
          read_only=True),
]


def camera_mounting(values: dict[str, Any]) -> CameraMounting:
    """The mounting from MOUNTING_PARAMS' values (base_link -> camera_optical_frame)."""
    return CameraMounting(
        x_m=float(values["camera_mounting.x_m"]), y_m=float(values["camera_mounting.y_m"]),
        z_m=float(values["camera_mounting.z_m"]), roll_rad=math.radians(values["camera_mounting.roll_deg"]),
        pitch_rad=math.radians(values["camera_mounting.pitch_deg"]),
        yaw_rad=math.radians(values["camera_mounting.yaw_deg"]),
    )


def declare(node: Node, params: Iterable[Param]) -> dict[str, Any]:
    """Declare every parameter (a YAML file or -p overrides apply) and return the values."""
    values = {}
    for p in params:
        values[p.name] = node.declare_parameter(p.name, p.default, p.descriptor()).value
    return values


def on_parameter_change(node: Node, apply: Callable[[dict[str, Any]], str | None]) -> None:
    """Validate runtime changes: ``apply`` gets the changed values and returns a reason to refuse, or None."""

    def callback(changes: list[Parameter]) -> SetParametersResult:
        values = {c.name: c.value for c in changes}
        for name, value in values.items():
            if isinstance(value, float) and not math.isfinite(value):
                return SetParametersResult(successful=False, reason=f"{name}: {value} is not a finite number")
        reason = apply(values)
        if reason is None:
            node.get_logger().info("parameters changed: " + ", ".join(f"{k}={v}" for k, v in values.items()))
        return SetParametersResult(successful=reason is None, reason=reason or "")

    node.add_on_set_parameters_callback(callback)


class InputProblems:
    """Input a node refused: counted by kind for /diagnostics, logged with its reason.

    Each kind is logged at most once per ``log_every_s`` (with the running count), so a
    stream of bad messages neither floods the log nor hides a second kind of problem.
    """

    def __init__(self, node: Node, log_every_s: float = 5.0) -> None:
        self._logger = node.get_logger()
        self._log_every_s = log_every_s
        self.counts: Counter[str] = Counter()
        self._last_seen: dict[str, float] = {}
        self._last_logged: dict[str, float] = {}
        self.last_reason = ""

    def report(self, kind: str, reason: str) -> None:
        now = time.monotonic()
        self.counts[kind] += 1
        self._last_seen[kind] = now
        self.last_reason = f"{kind}: {reason}"
        if now - self._last_logged.get(kind, -math.inf) >= self._log_every_s:
            self._last_logged[kind] = now
            self._logger.error(f"{self.last_reason} (refused, {self.counts[kind]} so far)")

    def recent(self, window_s: float = 5.0) -> list[str]:
        """Kinds refused within the last ``window_s``."""
        now = time.monotonic()
        return sorted(k for k, t in self._last_seen.items() if now - t <= window_s)

    def values(self) -> dict[str, int]:
        """Counts for a diagnostic's key/values (``rejected_<kind>``)."""
        return {f"rejected_{kind}": n for kind, n in sorted(self.counts.items())}


def diagnostic_status(name: str, hardware_id: str, level: bytes, message: str, values: dict[str, Any]) -> Any:
    """One /diagnostics entry; values become key/value strings."""
    from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

    return DiagnosticStatus(level=level, name=f"auv_dock_guidance: {name}", message=message, hardware_id=hardware_id,
                            values=[KeyValue(key=k, value=str(v)) for k, v in values.items()])


def publish_diagnostics(node: Node, publisher: Any, status: Any) -> None:
    from diagnostic_msgs.msg import DiagnosticArray

    array = DiagnosticArray(status=[status])
    array.header.stamp = node.get_clock().now().to_msg()
    publisher.publish(array)


def run_node(factory: Callable[[], Node], args: list[str] | None = None) -> int:
    """Initialise rclpy, spin one node until Ctrl-C or shutdown, and clean up."""
    return run_nodes([factory], args)


def run_nodes(factories: list[Callable[[], Node]], args: list[str] | None = None) -> int:
    """Several nodes in one process on one executor; exit code 2 on a configuration error."""
    faulthandler.register(signal.SIGUSR1, all_threads=True)  # where a hung node hangs, into its log
    rclpy.init(args=args)
    end_with_launcher()  # after init: rclpy's SIGTERM handler stops the node cleanly
    nodes: list[Node] = []
    code = 0
    try:
        executor = SingleThreadedExecutor()
        for factory in factories:
            nodes.append(factory())
            executor.add_node(nodes[-1])
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RuntimeError:
        if not context_shutting_down():
            raise
        # Ctrl-C shut the context down while the executor was taking a message: a clean stop.
    except (DockGuidanceError, InvalidParameterValueException) as exc:
        print(f"error: {exc}", file=sys.stderr, flush=True)
        code = 2
    finally:
        for node in nodes:
            close = getattr(node, "close", None)
            if close is not None:
                close()  # thrusters neutral, ports closed: before anything that could hang
        destroy_and_shut_down(nodes)
    return code


def destroy_and_shut_down(nodes: Iterable[Node]) -> None:
    """Destroy the nodes and shut rclpy down, or exit the process if that hangs (below).

    Every process with a ROS context ends through here: the nodes, and the commands that
    own them (bench, demo, bag, monitor), whose stop must be as bounded as their nodes'."""
    watchdog = _end_if_teardown_hangs()
    try:
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    finally:
        watchdog.cancel()


TEARDOWN_EXIT_CODE = 3


def context_shutting_down(within_s: float = 1.0, context: rclpy.context.Context | None = None) -> bool:
    """Whether the context is shut down, or is within ``within_s``: rclpy's signal handler shuts it
    down from its own thread, and under load a take can fail on the half-finalized subscription
    ("Unable to convert call argument") before ``rclpy.ok()`` turns False (the race
    ros/joint_state_publisher#117 reports). A real error still raises, a second late."""
    deadline = time.monotonic() + within_s
    while rclpy.ok(context=context):
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.02)
    return True


def _end_if_teardown_hangs(seconds: float = 4.0) -> threading.Timer:
    """Exit with TEARDOWN_EXIT_CODE if destroying the nodes and rclpy does not finish in time.

    Teardown below us (rclpy, Fast DDS) was seen to hang once in about 80 shutdowns under
    load, ignoring SIGINT and SIGTERM: a process that cannot exit blocks its own restart.
    """
    def give_up() -> None:
        print(f"error: shutdown did not finish within {seconds:.0f} s; exiting", file=sys.stderr, flush=True)
        os._exit(TEARDOWN_EXIT_CODE)

    timer = threading.Timer(seconds, give_up)
    timer.daemon = True
    timer.start()
    return timer
