"""guidance node: the dock's position and the vehicle's attitude in, thruster commands out.

The dock comes from the camera; ``camera_mounting.*`` (base_link -> camera optical frame)
re-expresses it about the vehicle's centre line before it is steered on. dock/pose gives
the dock's axis too (its orientation's x axis, where the tilt-aware fit resolved it: a
small tilt variance), which ``axis_alignment`` lines up with, and the position's covariance, which
the tracker adds to its own measurement noise; while dock/pose comes,
dock/target (the same position) is not acted on twice.

Subscribes  dock/pose (geometry_msgs/PoseWithCovarianceStamped), dock/target (geometry_msgs/PointStamped),
            dock/detected (std_msgs/Bool),
            vehicle/imu (sensor_msgs/Imu), vehicle/depth (std_msgs/Float64), vehicle/docked (std_msgs/Bool)
Publishes   thrusters/command (std_msgs/UInt16MultiArray: pulse widths in us for
            port upper, starboard upper, port lower, starboard lower),
            guidance/demands (geometry_msgs/Vector3Stamped: x surge, y yaw, z pitch, normalized),
            guidance/setpoint (geometry_msgs/Vector3Stamped: x yaw rad, y pitch rad, z speed m/s;
            stamped with the camera frame that produced it),
            guidance/state (std_msgs/String), guidance/transition (std_msgs/String, latched),
            /diagnostics (1 Hz: state, input ages, refused input)
Service     guidance/reset (std_srvs/Trigger): back to SEARCH (re-arm after DOCKED or ABORT)
A new target is acted on at once (lowest latency); a timer runs the inner loop between frames.
Non-finite, repeated or out-of-order targets and IMU messages are refused, logged and counted.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PointStamped, PoseWithCovarianceStamped, Vector3Stamped
from rclpy.node import Node
from sensor_msgs.msg import Imu
from std_msgs.msg import Bool, Float64, MultiArrayDimension, String, UInt16MultiArray
from std_srvs.srv import Trigger

from auv_dock_guidance.control.approach import ApproachConfig
from auv_dock_guidance.control.cascade import Attitude, CascadeConfig, Target
from auv_dock_guidance.control.guidance import Guidance, GuidanceConfig, GuidanceOutput, State
from auv_dock_guidance.control.mixer import MixerConfig
from auv_dock_guidance.control.pid import PidGains
from auv_dock_guidance.control.tracker import TrackerConfig
from auv_dock_guidance.errors import DockGuidanceError
from auv_dock_guidance.geometry.uncertainty import UNKNOWN_VARIANCE
from auv_dock_guidance.nodes.common import (
    MOUNTING_PARAMS,
    TRANSITION_QOS,
    InputProblems,
    Param,
    camera_mounting,
    declare,
    diagnostic_status,
    on_parameter_change,
    publish_diagnostics,
    run_node,
)
from auv_dock_guidance.nodes.conversions import imu_to_attitude, seconds_stamp, stamp_seconds
from auv_dock_guidance.stamps import StampGate

PARAMS = [
    Param("control_rate_hz", 50.0, "inner-loop rate between camera frames (Hz)", 5.0, 500.0, read_only=True),
    Param("thrusters_file", "", "thruster allocation YAML (empty: the default four stern thrusters)", read_only=True),
    Param("confirm_frames", 3, "detections in a row before tracking", 1, 30),
    Param("terminal_range_m", 2.5, "range below which the terminal phase starts (m)", 0.3, 20.0),
    Param("blind_range_m", 1.15, "below this range losing the ring is expected (m)", 0.1, 10.0),
    Param("close_fix_range_m", 0.75, "down to this range a ring the frame cuts still fixes the track sideways (m)",
          0.1, 10.0),
    Param("track_lost_timeout_s", 2.0, "marker lost this long while tracking: back to search (s)", 0.1, 60.0),
    Param("terminal_lost_timeout_s", 3.0, "marker lost this long in terminal while it should be visible: abort (s)",
          0.1, 60.0),
    Param("terminal_blind_timeout_s", 12.0, "no detection at all this long in terminal: abort (s)", 0.5, 120.0),
    Param("search_timeout_s", 120.0, "no marker this long: abort (s)", 1.0, 3600.0),
    Param("telemetry_timeout_s", 0.5, "telemetry older than this: abort (s)", 0.05, 10.0),
    Param("camera_timeout_s", 1.0, "no processed camera frame this long while driving: abort (s)", 0.1, 10.0),
    Param("recovery_s", 2.0, "a camera or telemetry abort clears after this long healthy (s)", 0.1, 60.0),
    Param("cruise_speed_mps", 0.41, "approach speed (m/s)", 0.0, 3.0),
    Param("terminal_speed_mps", 0.25, "speed in the terminal phase (m/s)", 0.0, 3.0),
    Param("full_thrust_speed_mps", 1.0, "steady speed at full surge thrust (m/s)", 0.1, 5.0),
    Param("outer.kp", 0.12, "outer loop: rad of turn per metre of offset", 0.0, 5.0),
    Param("outer.ki", 0.01, "outer loop integral gain", 0.0, 5.0),
    Param("inner.kp", 1.5, "inner loop: moment per rad of attitude error", 0.0, 50.0),
    Param("inner.ki", 0.1, "inner loop integral gain (yaw)", 0.0, 50.0),
    Param("inner.pitch_ki", 0.6, "inner pitch loop integral gain: it trims the righting moment, which each pitch "
          "goal changes", 0.0, 50.0),
    Param("inner.kd", 0.6, "inner loop derivative gain", 0.0, 50.0),
    Param("max_turn_deg", 25.0, "largest yaw turn the outer loop may ask for (deg)", 1.0, 90.0),
    Param("velocity_steering", True, "track the dock in the level frame and crab into the estimated current"),
    Param("axis_alignment", True, "line up with the dock's axis (the orientation on dock/pose) before the entry"),
    Param("max_retries", 3, "back off and retry this often when the entry would miss, then abort", 0, 20),
    Param("last_try_tolerance_m", 0.18, "with no retry left, go in if the predicted miss is within this (m)",
          0.01, 1.0),
    Param("retry_blind_timeout_s", 40.0, "backing off (perhaps turned round) without a detection this long: search (s)",
          1.0, 600.0),
    Param("faced_unseen_timeout_s", 4.0, "facing the dock by the track after backing off, unseen this long: search (s)",
          0.5, 600.0),
    Param("max_speed_mps", 0.9, "fastest approach through the water, used against a cross current (m/s)", 0.1, 5.0),
    Param("entry_crab_deg", 8.0, "largest heading off the dock's axis for the last metres (deg)", 1.0, 30.0),
    Param("sidestep", False, "back off sideways in reverse when the approach line is out of reach (else retry)"),
    Param("side_room_m", 0.0, "room beside the dock's axis to a wall, each side, less the hull (m); 0: open water",
          0.0, 1000.0),
]


def guidance_config(v: dict[str, Any], mixer: MixerConfig, camera_ahead_m: float = 0.9) -> GuidanceConfig:
    turn = math.radians(v["max_turn_deg"])
    outer = PidGains(kp=v["outer.kp"], ki=v["outer.ki"], output_limit=turn)
    inner = PidGains(kp=v["inner.kp"], ki=v["inner.ki"], kd=v["inner.kd"], output_limit=0.6)
    cascade = CascadeConfig(
        outer_yaw=outer, outer_pitch=outer, inner_yaw=inner, inner_pitch=replace(inner, ki=v["inner.pitch_ki"]),
        cruise_speed_mps=v["cruise_speed_mps"], terminal_speed_mps=v["terminal_speed_mps"],
        full_thrust_speed_mps=v["full_thrust_speed_mps"],
    )
    approach = ApproachConfig(max_speed_mps=v["max_speed_mps"], entry_crab_deg=v["entry_crab_deg"],
                              sidestep=v["sidestep"], side_room_m=v["side_room_m"] or math.inf)
    return GuidanceConfig(
        velocity_steering=v["velocity_steering"], axis_alignment=v["axis_alignment"], max_retries=v["max_retries"],
        last_try_tolerance_m=v["last_try_tolerance_m"], retry_blind_timeout_s=v["retry_blind_timeout_s"],
        faced_unseen_timeout_s=v["faced_unseen_timeout_s"],
        approach=approach, tracker=TrackerConfig(camera_ahead_m=camera_ahead_m),
        confirm_frames=v["confirm_frames"], terminal_range_m=v["terminal_range_m"], blind_range_m=v["blind_range_m"],
        close_fix_range_m=v["close_fix_range_m"],
        track_lost_timeout_s=v["track_lost_timeout_s"], terminal_lost_timeout_s=v["terminal_lost_timeout_s"],
        terminal_blind_timeout_s=v["terminal_blind_timeout_s"],
        search_timeout_s=v["search_timeout_s"], telemetry_timeout_s=v["telemetry_timeout_s"],
        camera_timeout_s=v["camera_timeout_s"], recovery_s=v["recovery_s"],
        cascade=cascade, mixer=mixer,
    )


class GuidanceNode(Node):
    def __init__(self) -> None:
        super().__init__("guidance")
        self.values = declare(self, PARAMS)
        self.mounting = camera_mounting(declare(self, MOUNTING_PARAMS))
        path = self.values["thrusters_file"]
        self.mixer_config = MixerConfig.from_yaml(path) if path else MixerConfig()
        self.guidance = Guidance(guidance_config(self.values, self.mixer_config, self.mounting.x_m))
        on_parameter_change(self, self._apply_parameters)
        # Navigation first: after a stall of this process the executor takes one message per
        # subscription per round in this order, so a queued detection meets the queued attitude.
        self._imu_sub = self.create_subscription(Imu, "vehicle/imu", self._on_imu, 10)
        self.create_subscription(Float64, "vehicle/depth", self._on_depth, 10)
        self._target_sub = self.create_subscription(PointStamped, "dock/target", self._on_target, 10)
        self.create_subscription(PoseWithCovarianceStamped, "dock/pose", self._on_pose, 10)
        self._pose_seen_s: float | None = None  # node clock when dock/pose last came
        self.create_subscription(Bool, "vehicle/docked", self._on_docked, 10)
        self.create_subscription(Bool, "dock/detected", self._on_detected, 10)
        self.command_pub = self.create_publisher(UInt16MultiArray, "thrusters/command", 10)
        self.demands_pub = self.create_publisher(Vector3Stamped, "guidance/demands", 10)
        self.setpoint_pub = self.create_publisher(Vector3Stamped, "guidance/setpoint", 10)
        self.state_pub = self.create_publisher(String, "guidance/state", 10)
        self.transition_pub = self.create_publisher(String, "guidance/transition", TRANSITION_QOS)
        self.diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_service(Trigger, "guidance/reset", self._on_reset)
        self._last_tick: float | None = None  # monotonic time of the last control tick
        self.create_timer(1.0 / self.values["control_rate_hz"], self._on_timer)
        self.create_timer(1.0, self._publish_state)
        self.create_timer(1.0, lambda: publish_diagnostics(self, self.diag_pub, self.diagnostics()))
        self.problems = InputProblems(self)
        self._imu_order = StampGate()
        self._attitude: Attitude | None = None
        self._imu_received: float | None = None  # monotonic time the newest attitude arrived
        self._tick_gap = 0.0  # s between the last two control ticks
        self._depth = 0.0
        self._docked = False
        self._clock_steps_logged = 0
        self._last_transition = "none"
        self._layout = [MultiArrayDimension(label=name, size=1, stride=1) for name in self.mixer_config.names]

    def _apply_parameters(self, changes: dict[str, Any]) -> str | None:
        values = {**self.values, **changes}
        try:
            config = guidance_config(values, self.mixer_config, self.mounting.x_m)
        except DockGuidanceError as exc:
            return str(exc)
        self.values = values
        self.guidance.reconfigure(config)
        return None

    def _on_imu(self, msg: Imu) -> None:
        attitude = imu_to_attitude(msg, self._depth)
        if not attitude.is_valid():
            q = msg.orientation
            self.problems.report("imu", f"orientation ({q.x}, {q.y}, {q.z}, {q.w}) is not a finite rotation")
            return
        out_of_order = self._imu_order.admit(attitude.stamp_s)
        if out_of_order is not None:
            self.problems.report("imu_stamp", f"{out_of_order} (stamped {attitude.stamp_s:.3f} s)")
            return
        self._attitude = attitude
        self._imu_received = time.monotonic()

    def _on_depth(self, msg: Float64) -> None:
        if not math.isfinite(msg.data):
            self.problems.report("depth", f"depth {msg.data} is not a finite number")
            return
        self._depth = msg.data

    def _on_docked(self, msg: Bool) -> None:
        self._docked = msg.data

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        previous = self.guidance.state
        self.guidance.reset()
        line = f"{previous.value} -> SEARCH: reset by the guidance/reset service"
        self.get_logger().info(line)
        self.transition_pub.publish(String(data=line))
        response.success, response.message = True, line
        return response

    def _on_detected(self, msg: Bool) -> None:
        self.guidance.frame_processed(self.get_clock().now().nanoseconds * 1e-9)
        if not msg.data:
            self.guidance.marker_missed()

    def _on_target(self, msg: PointStamped) -> None:
        now = self.get_clock().now().nanoseconds * 1e-9
        if self._pose_seen_s is not None and 0.0 <= now - self._pose_seen_s < POSE_PREFERRED_S:
            return  # dock/pose carries the same position, and the axis
        p = msg.point
        forward, right, down = self.mounting.target_about_vehicle(np.array([p.x, p.y, p.z]))
        self._step(Target(stamp_seconds(msg.header.stamp), forward, right, down))

    def _on_pose(self, msg: PoseWithCovarianceStamped) -> None:
        self._pose_seen_s = self.get_clock().now().nanoseconds * 1e-9
        p = msg.pose.pose.position
        forward, right, down = self.mounting.target_about_vehicle(np.array([p.x, p.y, p.z]))
        turn = self.mounting.vehicle_from_optical()  # about the vehicle as the position is
        normal, sigma = dock_axis_optical(msg)
        axis = None
        if normal is not None:
            x, y, z = turn @ normal
            axis = (float(x), float(y), float(z))
        optical = position_covariance_optical(msg)
        covariance = None if optical is None else tuple(float(v) for v in (turn @ optical @ turn.T).ravel())
        self._step(Target(stamp_seconds(msg.header.stamp), forward, right, down, axis, sigma, covariance))

    def _on_timer(self) -> None:
        """A control tick; the first after a hiccup of this process (three periods without a tick) is
        skipped: timers run before subscriptions, and the telemetry queued meanwhile must be taken
        before its age is judged (else a scheduling hiccup here aborts as "telemetry stale")."""
        now = time.monotonic()
        self._tick_gap = now - self._last_tick if self._last_tick is not None else 0.0
        self._last_tick = now
        if self._tick_gap <= 3.0 / self.values["control_rate_hz"]:
            self._step(None)

    def _step(self, target: Target | None) -> None:
        now = self.get_clock().now().nanoseconds * 1e-9
        out = self.guidance.update(now, target, self._attitude, self._docked)
        if out.rejected is not None:
            self.problems.report("target", out.rejected)
            target = None
        if self.guidance.clock_steps_back != self._clock_steps_logged:
            self._clock_steps_logged = self.guidance.clock_steps_back
            self.get_logger().warn("the clock stepped back: timers continue from the elapsed time, loops restart")
        if out.transition is not None:
            t = out.transition
            line = f"{t.previous.value} -> {t.state.value}: {t.reason}"
            self._last_transition = line
            self.get_logger().info(line + (self._timing() if t.state is State.ABORT else ""))
            self.transition_pub.publish(String(data=line))
            self._publish_state()
        last = self.guidance.last_target
        # Stamp with the camera frame behind the command, so the bridge can time frame -> wire.
        self._publish(out, target.stamp_s if target is not None else (last.stamp_s if last else now))

    def _timing(self) -> str:
        """Where an abort's time went: the newest attitude's stamp and arrival, the gap between its last ticks."""
        now, wall = time.monotonic(), time.time()
        stamped = f"{wall - self._attitude.stamp_s:.3f}" if self._attitude is not None else "-"
        received = f"{now - self._imu_received:.3f}" if self._imu_received is not None else "-"
        return f" (newest attitude stamped {stamped} s ago, received {received} s ago; " \
               f"control ticks {self._tick_gap:.3f} s apart)"

    def _publish(self, out: GuidanceOutput, stamp_s: float) -> None:
        stamp = seconds_stamp(stamp_s)
        if out.demands is not None:
            d = out.demands
            setpoint = Vector3Stamped()
            setpoint.header.stamp = stamp
            setpoint.vector.x, setpoint.vector.y = d.yaw_setpoint_rad, d.pitch_setpoint_rad
            setpoint.vector.z = d.speed_setpoint_mps
            self.setpoint_pub.publish(setpoint)
            demands = Vector3Stamped()
            demands.header.stamp = stamp
            demands.vector.x, demands.vector.y, demands.vector.z = d.surge, d.yaw, d.pitch
            self.demands_pub.publish(demands)
        command = UInt16MultiArray()
        command.layout.dim = self._layout
        command.data = list(out.command.pwm_us)
        self.command_pub.publish(command)

    def _publish_state(self) -> None:
        self.state_pub.publish(String(data=self.guidance.state.value))

    def diagnostics(self) -> DiagnosticStatus:
        """State and why; ERROR in ABORT, WARN while input is refused."""
        state = self.guidance.state
        now = self.get_clock().now().nanoseconds * 1e-9
        telemetry_age = now - self._attitude.stamp_s if self._attitude is not None else math.inf
        level, message = (DiagnosticStatus.ERROR, f"ABORT ({self._last_transition})") if state is State.ABORT \
            else (DiagnosticStatus.OK, state.value)
        if level == DiagnosticStatus.OK and self.problems.recent():
            level, message = DiagnosticStatus.WARN, f"{state.value}; refusing input: {self.problems.last_reason}"
        return diagnostic_status("guidance", "guidance", level, message, {
            "state": state.value, "last_transition": self._last_transition,
            "telemetry_age_s": f"{telemetry_age:.3f}", "clock_steps_back": self.guidance.clock_steps_back,
            # matched writers: 0 with a bridge or detector running means this process does not hear them
            "imu_publishers": self._imu_sub.get_publisher_count(),
            "target_publishers": self._target_sub.get_publisher_count(),
            **self.problems.values(),
        })


POSE_PREFERRED_S = 1.0  # dock/target is ignored this long after a dock/pose


def dock_axis_optical(msg: PoseWithCovarianceStamped) -> tuple[np.ndarray | None, float | None]:
    """The dock's axis (out of the entrance, towards the camera) in the optical frame and the standard
    deviation of its tilt, if dock/pose observed it (guidance weighs, and leaves out, uncertain ones)."""
    q = msg.pose.pose.orientation
    x, y, z, w = q.x, q.y, q.z, q.w
    axis = np.array([1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + z * w), 2.0 * (x * z - y * w)])
    if not np.all(np.isfinite(axis)) or np.linalg.norm(axis) < 0.5:
        return None, None
    axis /= np.linalg.norm(axis)
    across = np.cross(axis, [0.0, 0.0, 1.0] if abs(axis[2]) < 0.9 else [1.0, 0.0, 0.0])
    across /= np.linalg.norm(across)
    rotation = np.asarray(msg.pose.covariance, dtype=float).reshape(6, 6)[3:, 3:]
    tilt_variance = float(across @ rotation @ across)
    if not (math.isfinite(tilt_variance) and tilt_variance < UNKNOWN_VARIANCE):
        return None, None
    return axis, math.sqrt(max(tilt_variance, 0.0))


def position_covariance_optical(msg: PoseWithCovarianceStamped) -> np.ndarray | None:
    """dock/pose's position covariance (optical frame), if it is a usable one: the tracker adds it to
    its own noise, so a detection the detector doubts moves the track less."""
    covariance = np.asarray(msg.pose.covariance, dtype=float).reshape(6, 6)[:3, :3]
    if not np.all(np.isfinite(covariance)) or np.any(np.diag(covariance) < 0.0) \
            or np.any(np.diag(covariance) >= UNKNOWN_VARIANCE):
        return None
    return covariance


def main(args: list[str] | None = None) -> int:
    return run_node(GuidanceNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
