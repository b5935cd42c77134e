"""serial_bridge node: thruster commands to the main controller, its telemetry back; owns the failsafe.

Subscribes  thrusters/command (std_msgs/UInt16MultiArray, link_type serial),
            guidance/demands (geometry_msgs/Vector3Stamped, link_type mavlink),
            guidance/setpoint (geometry_msgs/Vector3Stamped: its stamp times the latency)
Publishes   vehicle/imu (sensor_msgs/Imu, REP 103), vehicle/depth (std_msgs/Float64),
            vehicle/armed (std_msgs/Bool), vehicle/docked (std_msgs/Bool),
            bridge/latency (std_msgs/Float64: camera frame -> command on the wire, s),
            /diagnostics (1 Hz: link health, failsafe events, CRC errors)
Service     bridge/arm (std_srvs/SetBool)
Only the guidance node's topic drives the thrusters, and only while armed: if any other
node publishes on it, the bridge disarms and says so. With no fresh command for
failsafe_timeout_s the bridge sends neutral on every tick. Garbage on the line, telemetry
with non-finite values and malformed commands are refused, logged and counted.
"""

from __future__ import annotations

import math
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from sensor_msgs.msg import Imu
from std_msgs.msg import Bool, Float64, UInt16MultiArray
from std_srvs.srv import SetBool

from auv_dock_guidance.control.cascade import Attitude
from auv_dock_guidance.control.mixer import MixerConfig
from auv_dock_guidance.errors import ConfigError
from auv_dock_guidance.link.bridge import LinkBridge
from auv_dock_guidance.link.protocol import Status, TelemetryMsg
from auv_dock_guidance.link.transport import SerialTransport
from auv_dock_guidance.nodes.common import (
    InputProblems,
    Param,
    declare,
    diagnostic_status,
    on_parameter_change,
    publish_diagnostics,
    run_node,
)
from auv_dock_guidance.nodes.conversions import attitude_to_imu, stamp_seconds

TELEMETRY_SILENT_S = 0.25  # telemetry older than this is logged as silent...
TELEMETRY_STALE_S = 0.5  # ...and diagnosed as missing (guidance aborts at this age: its telemetry_timeout_s)

PARAMS = [
    Param("port", "/dev/ttyUSB0", "serial device of the main controller", read_only=True),
    Param("baudrate", 115200, "serial speed", 1200, 4000000, read_only=True),
    Param("link_type", "serial", "serial (this package's protocol) or mavlink (ArduSub)", read_only=True),
    Param("thrusters_file", "", "thruster YAML for the PWM limits (empty: defaults)", read_only=True),
    Param("failsafe_timeout_s", 0.15, "no command this long: neutral at the next tick (s)", 0.02, 5.0),
    Param("tick_rate_hz", 50.0, "failsafe, heartbeat and telemetry rate (Hz)", 10.0, 1000.0, read_only=True),
    Param("arm_on_start", False, "arm at start (the demo); on a vehicle arm through the bridge/arm service"),
    Param("imu_frame_id", "base_link", "frame_id of the published Imu", read_only=True),
]


class SerialBridgeNode(Node):
    def __init__(self) -> None:
        super().__init__("serial_bridge")
        self.values = declare(self, PARAMS)
        if self.values["link_type"] not in ("serial", "mavlink"):
            raise ConfigError(f"link_type {self.values['link_type']!r} must be 'serial' or 'mavlink'")
        path = self.values["thrusters_file"]
        pwm = (MixerConfig.from_yaml(path) if path else MixerConfig()).pwm
        self.transport = SerialTransport(self.values["port"], self.values["baudrate"])
        self.bridge = LinkBridge(self.transport, pwm, self.values["failsafe_timeout_s"])
        self.mavlink = None
        if self.values["link_type"] == "mavlink":
            from auv_dock_guidance.link.mavlink import MavlinkCodec

            self.mavlink = MavlinkCodec()
            self.create_subscription(Vector3Stamped, "guidance/demands", self._on_demands, 10)
        else:
            self.create_subscription(UInt16MultiArray, "thrusters/command", self._on_command, 10)
        on_parameter_change(self, self._apply_parameters)
        self.create_subscription(Vector3Stamped, "guidance/setpoint", self._on_setpoint, 10)
        self.imu_pub = self.create_publisher(Imu, "vehicle/imu", 10)
        self.depth_pub = self.create_publisher(Float64, "vehicle/depth", 10)
        self.armed_pub = self.create_publisher(Bool, "vehicle/armed", 10)
        self.docked_pub = self.create_publisher(Bool, "vehicle/docked", 10)
        self.latency_pub = self.create_publisher(Float64, "bridge/latency", 50)
        self.diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_service(SetBool, "bridge/arm", self._on_arm)
        self.create_timer(1.0 / self.values["tick_rate_hz"], self._on_tick)
        self.create_timer(1.0, lambda: publish_diagnostics(self, self.diag_pub, self.diagnostics()))
        self.create_timer(0.5, self._check_command_publishers)
        self._foreign: list[str] = []
        self._checked_at = -math.inf
        self._unnamed = 0
        self._publisher_count = -1
        self._command_topic = "guidance/demands" if self.mavlink is not None else "thrusters/command"
        self._frame_stamp: float | None = None  # camera frame behind the newest setpoint
        self._timed_stamp: float | None = None
        self._last_telemetry_seq: int | None = None
        self._connected = False
        self._last_tick_time: float | None = None
        self._telemetry_silent = False
        self.problems = InputProblems(self)
        self._garbage_seen = 0  # decoder errors and dropped bytes already reported
        if self.values["arm_on_start"]:
            self._set_armed(True, "arm_on_start")

    def close(self) -> None:
        """Leave the thrusters neutral and the port closed on shutdown."""
        self.bridge.set_armed(False)
        self.transport.close()

    def _apply_parameters(self, changes: dict[str, Any]) -> str | None:
        if "failsafe_timeout_s" in changes:
            self.bridge.failsafe_timeout_s = float(changes["failsafe_timeout_s"])
        if "arm_on_start" in changes:
            return "arm_on_start only applies at start; use the bridge/arm service"
        return None

    def _set_armed(self, armed: bool, why: str) -> None:
        if armed != self.bridge.armed:
            self.get_logger().info(f"{'armed' if armed else 'disarmed'} ({why})")
        if self.mavlink is None:
            self.bridge.set_armed(armed)
        else:
            self.bridge.armed = armed
            self.transport.write(self.mavlink.neutral())

    def _on_arm(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        self._set_armed(request.data, "bridge/arm service")
        response.success, response.message = True, "armed" if request.data else "disarmed"
        return response

    def _on_setpoint(self, msg: Vector3Stamped) -> None:
        self._frame_stamp = stamp_seconds(msg.header.stamp)

    def _check_command_publishers(self) -> None:
        """Only the guidance node may drive the thrusters: anyone else publishing disarms the bridge."""
        topic = self._command_topic
        publishers = self.get_publishers_info_by_topic(topic)
        # A publisher still being discovered has no name yet: not trusted, not yet condemned.
        self._unnamed = sum(i.node_name == "_NODE_NAME_UNKNOWN_" for i in publishers)
        names = [f"{i.node_namespace.rstrip('/')}/{i.node_name}" for i in publishers
                 if i.node_name != "_NODE_NAME_UNKNOWN_"]
        foreign = sorted(n for n in names if n.rsplit("/", 1)[-1] != "guidance")
        if foreign and foreign != self._foreign:
            self.get_logger().error(f"{topic} has publishers other than guidance ({', '.join(foreign)}): disarmed")
            self._set_armed(False, "foreign publisher on " + topic)
        self._foreign = foreign
        self._checked_at = time.monotonic()

    def _sender_trusted(self) -> bool:
        """Check the publishers before acting on a command (at most twice a second)."""
        count = self.count_publishers(self._command_topic)
        if count != self._publisher_count or self._unnamed or time.monotonic() - self._checked_at > 0.5:
            self._check_command_publishers()
            self._publisher_count = count
        return not self._foreign and not self._unnamed

    def _on_command(self, msg: UInt16MultiArray) -> None:
        if not self._sender_trusted():
            return  # refused while anyone but guidance publishes commands
        if len(msg.data) != 4:
            self.problems.report("command", f"thruster command with {len(msg.data)} values (need 4)")
            return
        self.bridge.command([float(x) for x in msg.data])
        self._record_latency()

    def _on_demands(self, msg: Vector3Stamped) -> None:
        assert self.mavlink is not None
        if not self._sender_trusted():
            return
        v = msg.vector
        self.bridge.command([1500.0] * 4)  # keeps the failsafe clock; the pulses go out as RC override
        if self.bridge.armed:
            self.transport.write(self.mavlink.rc_override(v.x, v.y, v.z))
        self._record_latency()

    def _record_latency(self) -> None:
        stamp = self._frame_stamp
        if stamp is not None and stamp != self._timed_stamp and self.bridge.armed:
            self._timed_stamp = stamp
            self.latency_pub.publish(Float64(data=time.time() - stamp))

    def _on_tick(self) -> None:
        self._note_stalls()
        if self.mavlink is not None:
            self._tick_mavlink()
            return
        for frame in self.bridge.tick():
            if isinstance(frame.message, TelemetryMsg) and not frame.message.is_finite():
                self.problems.report("telemetry",
                                     f"non-finite attitude or depth from the main controller: {frame.message}")
        self._report_garbage()
        if self.transport.connected != self._connected:
            self._connected = self.transport.connected
            self.get_logger().info(f"serial port {self.transport.port} {'open' if self._connected else 'lost'}")
        telemetry = self.bridge.telemetry  # set with its arrival time, only when a valid one came
        if telemetry is not None and telemetry.time_ms != self._last_telemetry_seq:
            self._last_telemetry_seq = telemetry.time_ms
            self._publish_telemetry(telemetry)

    def _note_stalls(self) -> None:
        """Log a late tick (the process, or a call into the port, was held up) and telemetry that went silent."""
        now = time.monotonic()
        period = 1.0 / self.values["tick_rate_hz"]
        if self._last_tick_time is not None and now - self._last_tick_time > 5 * period:
            self.get_logger().warn(f"no tick for {now - self._last_tick_time:.3f} s (period {period:.3f} s)")
        self._last_tick_time = now
        age = self.bridge.telemetry_age_s()
        silent = TELEMETRY_SILENT_S < age < math.inf  # none yet is not silence: the controller may still boot
        if silent and not self._telemetry_silent:
            self.get_logger().warn(f"no telemetry from the main controller for {age:.3f} s")
        elif not silent and self._telemetry_silent:
            self.get_logger().info("telemetry from the main controller again")
        self._telemetry_silent = silent

    def _report_garbage(self) -> None:
        d = self.bridge.decoder.stats
        garbage = d.crc_errors + d.length_errors + d.unknown_ids + d.version_errors + d.bytes_dropped
        if garbage != self._garbage_seen:
            self._garbage_seen = garbage
            self.problems.report("serial_bytes", f"garbage on {self.transport.port}: {d.crc_errors} CRC errors, "
                                 f"{d.length_errors} bad lengths, {d.bytes_dropped} bytes dropped so far")

    def _tick_mavlink(self) -> None:
        assert self.mavlink is not None
        stale = time.monotonic() - self.bridge.last_command_time > self.bridge.failsafe_timeout_s
        if not self.bridge.armed or stale:
            self.transport.write(self.mavlink.neutral())
        state = self.mavlink.feed(self.transport.read())
        if math.isfinite(state.yaw):
            now = time.time()
            depth = state.depth if math.isfinite(state.depth) else 0.0
            attitude = Attitude(now, state.roll, state.pitch, state.yaw, depth)
            self.imu_pub.publish(attitude_to_imu(attitude, (state.roll_rate, state.pitch_rate, state.yaw_rate),
                                                 self.values["imu_frame_id"]))

    def _publish_telemetry(self, t: TelemetryMsg) -> None:
        now = time.time()
        attitude = Attitude(now, t.roll, t.pitch, t.yaw, t.depth)
        rates = (t.roll_rate, t.pitch_rate, t.yaw_rate)
        self.imu_pub.publish(attitude_to_imu(attitude, rates, self.values["imu_frame_id"]))
        self.depth_pub.publish(Float64(data=float(t.depth)))
        self.armed_pub.publish(Bool(data=bool(t.status & Status.ARMED)))
        self.docked_pub.publish(Bool(data=bool(t.status & Status.DOCKED)))

    def diagnostics(self) -> DiagnosticStatus:
        """Link health: ERROR without the port or with a foreign publisher; WARN without telemetry or refusing input."""
        s, d, ts = self.bridge.stats, self.bridge.decoder.stats, self.transport.stats
        age = self.bridge.telemetry_age_s()
        if self._foreign:
            level, message = DiagnosticStatus.ERROR, "foreign thruster command publisher: disarmed"
        elif not self.transport.connected:
            level, message = DiagnosticStatus.ERROR, "serial port not open"
        elif age > TELEMETRY_STALE_S:
            level, message = DiagnosticStatus.WARN, "no telemetry from the main controller"
        elif self.problems.recent():
            level, message = DiagnosticStatus.WARN, f"refusing input: {self.problems.last_reason}"
        else:
            level, message = DiagnosticStatus.OK, "armed" if self.bridge.armed else "disarmed"
        return diagnostic_status("serial_bridge", self.transport.port, level, message, {
            "armed": self.bridge.armed, "in_failsafe": self.bridge.in_failsafe,
            "failsafe_events": s.failsafe_events, "commands_sent": s.commands_sent,
            "rejected_values": s.rejected_values, "frames_received": d.frames, "crc_errors": d.crc_errors,
            "bytes_dropped": d.bytes_dropped, "reconnects": max(0, ts.opens - 1),
            "write_timeouts": ts.write_timeouts, "telemetry_age_s": f"{age:.3f}",
            "foreign_command_publishers": ", ".join(self._foreign) or "none", **self.problems.values(),
        })


def main(args: list[str] | None = None) -> int:
    return run_node(SerialBridgeNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
