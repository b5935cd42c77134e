"""A constant-velocity Kalman filter on the dock's position in the camera frame.

Beyond the paper: it smooths detection noise, rejects outliers (a detection that jumps
further than the innovation gate allows, such as one frame on a lamp), and predicts
through short dropouts (``max_coast_s``) so guidance is not starved by a missed frame.
State: position (x right, y down, z forward, metres) and its rate of change.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from auv_dock_guidance.control.cascade import Target


@dataclass(frozen=True)
class TrackerConfig:
    accel_noise: float = 0.3  # m/s^2, how fast the relative position may change course
    lateral_noise_per_m: float = 0.004  # measurement noise across the line of sight, per metre of range
    range_noise_rel: float = 0.02  # measurement noise along it, relative to range
    gate_chi2: float = 16.0  # innovation gate (3 dof): larger jumps are rejected
    max_coast_s: float = 1.0  # predict through dropouts up to this long
    max_rejections: int = 3  # this many rejections in a row restart the track on the new detection


class TargetTracker:
    def __init__(self, config: TrackerConfig = TrackerConfig()) -> None:
        self.config = config
        self.reset()

    def reset(self) -> None:
        self._x: np.ndarray | None = None
        self._p = np.eye(6)
        self._time: float | None = None
        self._last_update: float | None = None
        self._rejections = 0
        self.rejected = 0

    def update(self, time_s: float, measurement: Target | None) -> Target | None:
        """The filtered target for this frame, a prediction through a dropout, or None."""
        if self._x is None or self._time is None:
            if measurement is not None:
                self._start(measurement)
                return measurement
            return None
        self._predict(time_s - self._time)
        self._time = time_s
        if measurement is not None:
            z = np.array([measurement.offset_x_m, measurement.offset_y_m, measurement.range_m])
            if self._correct(z, measurement.range_m):
                self._last_update = time_s
                self._rejections = 0
            else:
                self.rejected += 1
                self._rejections += 1
                if self._rejections >= self.config.max_rejections:
                    self._start(measurement)
                    return measurement
        if self._last_update is None or time_s - self._last_update > self.config.max_coast_s:
            return None
        x = self._x
        return Target(time_s, float(x[2]), float(x[0]), float(x[1])) if x[2] > 0.05 else None

    def _start(self, m: Target) -> None:
        self._x = np.array([m.offset_x_m, m.offset_y_m, m.range_m, 0.0, 0.0, 0.0])
        r = self._measurement_noise(m.range_m)
        self._p = np.diag([r[0, 0], r[1, 1], r[2, 2], 1.0, 1.0, 1.0])
        self._time = self._last_update = m.stamp_s
        self._rejections = 0

    def _predict(self, dt: float) -> None:
        assert self._x is not None  # called only once a track has started
        if dt <= 0:
            return
        f = np.eye(6)
        f[0:3, 3:6] = dt * np.eye(3)
        q = self.config.accel_noise**2
        g = np.vstack([0.5 * dt * dt * np.eye(3), dt * np.eye(3)])
        self._x = f @ self._x
        self._p = f @ self._p @ f.T + q * (g @ g.T)

    def _correct(self, z: np.ndarray, range_m: float) -> bool:
        assert self._x is not None  # called only once a track has started
        h = np.hstack([np.eye(3), np.zeros((3, 3))])
        s = h @ self._p @ h.T + self._measurement_noise(range_m)
        innovation = z - h @ self._x
        distance = float(innovation @ np.linalg.solve(s, innovation))
        if not math.isfinite(distance) or distance > self.config.gate_chi2:
            return False
        k = self._p @ h.T @ np.linalg.inv(s)
        self._x = self._x + k @ innovation
        self._p = (np.eye(6) - k @ h) @ self._p
        return True

    def _measurement_noise(self, range_m: float) -> np.ndarray:
        c = self.config
        lateral = (c.lateral_noise_per_m * max(range_m, 0.5)) ** 2
        return np.diag([lateral, lateral, (c.range_noise_rel * max(range_m, 0.5)) ** 2])



