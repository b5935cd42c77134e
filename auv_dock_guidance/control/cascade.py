"""The paper's cascaded position-attitude controller (section 3.3, Fig. 7).

Outer loop (at the camera's rate): the dock's lateral and vertical offsets from the
detector become yaw and pitch setpoints. The setpoint is the attitude the vehicle had
when the frame was taken, turned by the bearing to the dock plus a PID on the metric
offset, limited to safe angles.

Inner loop (at the control rate): the setpoints against the attitude measured by the
main controller's navigation become yaw and pitch moments. Surge follows a speed
schedule by range (the paper approached at 0.41 m/s), slowing for the terminal phase;
a negative speed backs off in reverse. Beyond the paper, the approach path
(``approach.py``) may set the heading and pitch goals instead of the bearing (``steer``).

Conventions: attitude as the navigation reports it (aerospace: pitch positive nose up,
yaw positive turning to starboard), radians. Camera bearings: yaw positive = dock to the
right (turn to starboard), pitch positive = dock below (pitch nose down).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from auv_dock_guidance.control.pid import Pid, PidGains, wrap_angle
from auv_dock_guidance.errors import ConfigError


@dataclass(frozen=True)
class Target:
    """The dock as the detector saw it, in the camera optical frame."""

    stamp_s: float
    range_m: float
    offset_x_m: float  # right
    offset_y_m: float  # down
    axis_optical: tuple[float, float, float] | None = None  # the dock's axis (ring normal, towards the camera)
    axis_sigma_rad: float | None = None  # the detector's standard deviation of that axis's tilt; None: not reported
    position_covariance: tuple[float, ...] | None = None  # m^2, 3x3 row-major, axes as offset_x, offset_y, range

    @property
    def bearing_yaw_rad(self) -> float:
        return math.atan2(self.offset_x_m, self.range_m)

    @property
    def bearing_pitch_rad(self) -> float:
        return math.atan2(self.offset_y_m, self.range_m)

    def is_valid(self) -> bool:
        values = (self.stamp_s, self.range_m, self.offset_x_m, self.offset_y_m, *(self.axis_optical or ()))
        return all(math.isfinite(v) for v in values) and self.range_m > 0


@dataclass(frozen=True)
class Attitude:
    """The vehicle's attitude and depth from the main controller's navigation."""

    stamp_s: float
    roll_rad: float
    pitch_rad: float
    yaw_rad: float
    depth_m: float = 0.0
    yaw_rate_rad_s: float = 0.0  # turning to starboard +; 0 where the navigation does not report it

    def is_valid(self) -> bool:
        return all(math.isfinite(v) for v in (self.stamp_s, self.roll_rad, self.pitch_rad, self.yaw_rad, self.depth_m,
                                              self.yaw_rate_rad_s))


@dataclass(frozen=True)
class CascadeConfig:
    outer_yaw: PidGains = PidGains(kp=0.12, ki=0.01, kd=0.0, output_limit=math.radians(25))
    outer_pitch: PidGains = PidGains(kp=0.12, ki=0.01, kd=0.0, output_limit=math.radians(20))
    bearing_gain: float = 1.0  # share of the camera bearing added to the setpoint
    inner_yaw: PidGains = PidGains(kp=1.5, ki=0.1, kd=0.6, output_limit=0.6)
    # The pitch integrator trims the righting moment, which each pitch goal changes: trimmed at 0.1 it held
    # the nose 2-3 deg above the last metres' gentle descent after a climb (3-4 cm high at the entrance).
    inner_pitch: PidGains = PidGains(kp=1.5, ki=0.6, kd=0.6, output_limit=0.6)
    max_pitch_setpoint_rad: float = math.radians(25)  # absolute pitch setpoint limit
    setpoint_rate_rad_s: float = math.radians(20)  # no abrupt turns
    integrate_within_rad: float = math.radians(5)  # the inner integrators trim only within this of the goal
    cruise_speed_mps: float = 0.41
    terminal_speed_mps: float = 0.25
    slow_down_range_m: float = 5.0  # speed falls linearly from cruise to terminal below this
    full_thrust_speed_mps: float = 1.0  # steady speed at full surge thrust

    def __post_init__(self) -> None:
        positive = (self.setpoint_rate_rad_s, self.max_pitch_setpoint_rad, self.full_thrust_speed_mps,
                    self.slow_down_range_m)
        if not all(math.isfinite(v) and v > 0 for v in positive):
            raise ConfigError("setpoint rate, pitch limit, full-thrust speed and slow-down range must be positive")
        if not 0 <= self.terminal_speed_mps <= self.cruise_speed_mps <= self.full_thrust_speed_mps:
            raise ConfigError(
                f"need 0 <= terminal_speed_mps ({self.terminal_speed_mps}) <= cruise_speed_mps "
                f"({self.cruise_speed_mps}) <= full_thrust_speed_mps ({self.full_thrust_speed_mps})"
            )


@dataclass(frozen=True)
class Demands:
    """Normalized demands for the mixer and the setpoints behind them."""

    surge: float
    yaw: float
    pitch: float
    yaw_setpoint_rad: float
    pitch_setpoint_rad: float
    speed_setpoint_mps: float


@dataclass
class CascadeController:
    config: CascadeConfig = field(default_factory=CascadeConfig)

    def __post_init__(self) -> None:
        c = self.config
        self._outer_yaw, self._outer_pitch = Pid(c.outer_yaw), Pid(c.outer_pitch)
        self._inner_yaw, self._inner_pitch = Pid(c.inner_yaw), Pid(c.inner_pitch)
        self._goal: tuple[float, float] | None = None  # (yaw, pitch) the outer loop asks for
        self._setpoint: tuple[float, float] | None = None  # rate-limited towards the goal
        self._last_time: float | None = None

    def reset(self) -> None:
        for pid in (self._outer_yaw, self._outer_pitch, self._inner_yaw, self._inner_pitch):
            pid.reset()
        self._goal = self._setpoint = None
        self._last_time = None

    @property
    def setpoint(self) -> tuple[float, float] | None:
        return self._setpoint

    def on_target(self, target: Target, attitude_at_frame: Attitude) -> None:
        """Outer loop: a new detection sets the attitude goal (held until the next one)."""
        c = self.config
        t = target.stamp_s
        yaw_turn = c.bearing_gain * target.bearing_yaw_rad + self._outer_yaw.update(0.0, -target.offset_x_m, t)
        dive = c.bearing_gain * target.bearing_pitch_rad + self._outer_pitch.update(0.0, -target.offset_y_m, t)
        yaw_turn = max(-c.outer_yaw.output_limit, min(c.outer_yaw.output_limit, yaw_turn))
        dive = max(-c.outer_pitch.output_limit, min(c.outer_pitch.output_limit, dive))
        pitch_goal = max(-c.max_pitch_setpoint_rad, min(c.max_pitch_setpoint_rad, attitude_at_frame.pitch_rad - dive))
        self._goal = (wrap_angle(attitude_at_frame.yaw_rad + yaw_turn), pitch_goal)

    def steer(self, yaw_rad: float, pitch_rad: float | None) -> None:
        """Heading (and pitch, unless None: then the bearing's) goals from the approach path instead of the bearing."""
        c = self.config
        if pitch_rad is None:
            pitch_rad = 0.0 if self._goal is None else self._goal[1]
        self._goal = (wrap_angle(yaw_rad), max(-c.max_pitch_setpoint_rad, min(c.max_pitch_setpoint_rad, pitch_rad)))

    def hold(self, yaw_rad: float, pitch_rad: float) -> None:
        """Keep a fixed attitude goal (search: current heading, level)."""
        self._goal = (wrap_angle(yaw_rad), pitch_rad)

    def speed_for_range(self, range_m: float | None) -> float:
        c = self.config
        if range_m is None:
            return c.terminal_speed_mps
        share = max(0.0, min(1.0, range_m / c.slow_down_range_m))
        return c.terminal_speed_mps + share * (c.cruise_speed_mps - c.terminal_speed_mps)

    def update(self, attitude: Attitude, now_s: float, speed_mps: float) -> Demands:
        """Inner loop at the control rate."""
        c = self.config
        if self._goal is None:
            self.hold(attitude.yaw_rad, 0.0)
        assert self._goal is not None
        yaw_slewing = pitch_slewing = False
        if self._setpoint is None or self._last_time is None:
            self._setpoint = self._goal
        else:
            step = c.setpoint_rate_rad_s * max(0.0, min(now_s - self._last_time, 0.5))
            yaw_delta = wrap_angle(self._goal[0] - self._setpoint[0])
            pitch_delta = self._goal[1] - self._setpoint[1]
            behind = max(step, c.integrate_within_rad)
            yaw_slewing, pitch_slewing = abs(yaw_delta) > behind, abs(pitch_delta) > behind
            self._setpoint = (
                wrap_angle(self._setpoint[0] + max(-step, min(step, yaw_delta))),
                self._setpoint[1] + max(-step, min(step, pitch_delta)),
            )
        self._last_time = now_s
        yaw_sp, pitch_sp = self._setpoint
        yaw_error = wrap_angle(yaw_sp - attitude.yaw_rad)
        # While the setpoint slews to a goal far off the error is the turn's lag, not a steady moment to
        # trim: integrated, a 20 s turn-round wound up half the yaw authority against the turn back
        # (seed 73). The goal's jitter on an approach (a degree a frame) is still trimmed.
        yaw_moment = self._inner_yaw.update(yaw_sp, attitude.yaw_rad, now_s, error=yaw_error,
                                            integrate=not yaw_slewing)
        # Nor is a pitch the vehicle cannot hold: the righting moment keeps the nose degrees short of a steep
        # climb's goal for as long as the climb lasts, and integrated, that error held the nose up past the
        # dock's depth (open water, seed 35: 10 cm high at the entrance).
        pitch_error = pitch_sp - attitude.pitch_rad
        pitch_moment = self._inner_pitch.update(pitch_sp, attitude.pitch_rad, now_s, integrate=not pitch_slewing
                                                and abs(pitch_error) <= c.integrate_within_rad)
        surge = math.copysign((speed_mps / c.full_thrust_speed_mps) ** 2, speed_mps)  # drag grows with speed squared
        return Demands(surge, yaw_moment, pitch_moment, yaw_sp, pitch_sp, speed_mps)
