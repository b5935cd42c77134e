"""A PID controller with what a real vehicle needs.

* output limits with anti-windup by back-calculation: when the output saturates, the
  integrator is bled back at ``1 / tracking_time`` so it never winds up;
* derivative on the measurement (no kick when the setpoint jumps), low-pass filtered;
* the time step from real timestamps: a repeated or backwards stamp (dt <= 0) changes
  nothing and returns the previous output; a long gap is clamped to ``max_dt``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from auv_dock_guidance.errors import ConfigError


@dataclass(frozen=True)
class PidGains:
    kp: float
    ki: float = 0.0
    kd: float = 0.0
    output_limit: float = 1.0  # |output| <= this
    derivative_tau_s: float = 0.1  # low-pass time constant of the derivative
    tracking_time_s: float = 1.0  # anti-windup back-calculation time constant
    max_dt_s: float = 0.5  # longer gaps count as this (a stall must not kick the integrator)

    def __post_init__(self) -> None:
        values = (self.kp, self.ki, self.kd, self.output_limit, self.derivative_tau_s, self.tracking_time_s,
                  self.max_dt_s)
        if not all(math.isfinite(v) for v in values):
            raise ConfigError(f"PID gains must be finite numbers, got {values}")
        if min(self.kp, self.ki, self.kd) < 0:
            raise ConfigError(f"PID gains must not be negative (kp {self.kp}, ki {self.ki}, kd {self.kd})")
        if self.output_limit <= 0 or self.derivative_tau_s < 0 or self.tracking_time_s <= 0 or self.max_dt_s <= 0:
            raise ConfigError("output_limit, tracking_time_s and max_dt_s must be positive, derivative_tau_s >= 0")


class Pid:
    def __init__(self, gains: PidGains) -> None:
        self.gains = gains
        self.reset()

    def reset(self) -> None:
        self._integral = 0.0
        self._derivative = 0.0
        self._last_measurement: float | None = None
        self._last_time: float | None = None
        self._output = 0.0

    @property
    def output(self) -> float:
        return self._output

    def update(self, setpoint: float, measurement: float, time_s: float, error: float | None = None,
               integrate: bool = True) -> float:
        """New output for a measurement taken at ``time_s``.

        ``error`` overrides ``setpoint - measurement`` (e.g. an angle difference wrapped to
        [-pi, pi)); the derivative still acts on the measurement. ``integrate`` False holds the
        integral: the error is a setpoint's ramp that the output is following, not a disturbance.
        """
        g = self.gains
        if not (math.isfinite(setpoint) and math.isfinite(measurement) and math.isfinite(time_s)):
            return self._output
        e = setpoint - measurement if error is None else error
        if self._last_time is None:
            self._last_time, self._last_measurement = time_s, measurement
            self._output = _clamp(g.kp * e + g.ki * self._integral, g.output_limit)
            return self._output
        dt = time_s - self._last_time
        if dt <= 0:
            return self._output
        dt = min(dt, g.max_dt_s)
        assert self._last_measurement is not None
        slope = -(measurement - self._last_measurement) / dt
        if error is not None:  # measurement is an angle: take the wrapped step
            slope = -wrap_angle(measurement - self._last_measurement) / dt
        alpha = dt / (g.derivative_tau_s + dt)
        self._derivative += alpha * (slope - self._derivative)
        unsaturated = g.kp * e + g.ki * self._integral + g.kd * self._derivative
        output = _clamp(unsaturated, g.output_limit)
        if g.ki > 0 and integrate:
            self._integral += dt * (e + (output - unsaturated) / (g.ki * g.tracking_time_s))
        self._last_time, self._last_measurement = time_s, measurement
        self._output = output
        return output


def _clamp(value: float, limit: float) -> float:
    return max(-limit, min(limit, value))


def wrap_angle(angle: float) -> float:
    """An angle in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi
