"""Where the vehicle is relative to the dock, and which way the water carries it.

A Kalman filter in the level navigation frame (x along yaw 0, y to starboard; the
navigation's heading is the only absolute reference it needs). State: the vehicle's
reference point relative to the dock's entrance centre (m), the water current (m/s) and
the error of the vehicle's own speed model (a share: thrust gives the speed only
approximately; once the heading has changed it is told apart from the current).
Between detections the vehicle's own motion through the water (its heading from the
navigation and its speed from its own thrust) plus the current moves the position; each
detection, turned into the level frame with the attitude at the frame, corrects it. The
difference between where the vehicle went and where its own motion took it is the drift:
the current estimate that lets guidance crab into it. Beyond the paper: it also smooths
detection noise, rejects outliers (a gate on the innovation) and predicts through
dropouts and the blind last metre. When the track itself is wrong (a blind leg's dead
reckoning drifted), the detections it rejects agree with each other: a few of those in a
row restart the position. Rejected detections that disagree (partial rings close in, each
wild in its own way) restart nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from auv_dock_guidance.control.cascade import Attitude, Target

# Body (forward, starboard, down) from the camera optical frame (right, down, forward).
_BODY_FROM_OPTICAL = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def level_from_body(attitude: Attitude) -> np.ndarray:
    """Rotation of body axes (forward, starboard, down) into the level navigation frame (x, y, down)."""
    cr, sr = math.cos(attitude.roll_rad), math.sin(attitude.roll_rad)
    cp, sp = math.cos(attitude.pitch_rad), math.sin(attitude.pitch_rad)
    cy, sy = math.cos(attitude.yaw_rad), math.sin(attitude.yaw_rad)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return rz @ ry @ rx


def level_from_optical(attitude: Attitude) -> np.ndarray:
    """Rotation of the camera's optical axes into the level navigation frame."""
    return level_from_body(attitude) @ _BODY_FROM_OPTICAL


def optical_to_level(vector_optical: tuple[float, float, float] | np.ndarray, attitude: Attitude) -> np.ndarray:
    """A direction or offset seen by the camera, in the level navigation frame."""
    return level_from_optical(attitude) @ np.asarray(vector_optical, dtype=float)


def dock_from_camera(target: Target, attitude: Attitude) -> np.ndarray:
    """The dock's entrance centre relative to the camera, level navigation frame (x, y, down)."""
    return optical_to_level((target.offset_x_m, target.offset_y_m, target.range_m), attitude)


@dataclass(frozen=True)
class TrackerConfig:
    camera_ahead_m: float = 0.9  # camera ahead of the vehicle's reference point (the point the filter tracks)
    motion_noise_mps: float = 0.08  # error of the vehicle's own motion model (speed, sideslip), white
    current_noise_mps2: float = 0.03  # how fast the current may change (random walk; tidal gusts and eddies)
    initial_current_sigma_mps: float = 0.3
    initial_speed_error_sigma: float = 0.08  # own speed model's error, share of the speed
    speed_error_noise_per_s: float = 0.002  # how fast that error may drift (random walk)
    lateral_noise_per_m: float = 0.009  # measurement noise across the line of sight (detector + attitude), per m
    range_noise_rel: float = 0.02  # measurement noise along it, relative to range
    gate_chi2: float = 13.8  # innovation gate (2 dof, 99.9 %): larger jumps are rejected
    max_rejections: int = 3  # this many rejected detections that agree with each other restart the position...
    max_relative_speed_mps: float = 1.5  # ...if nearer, or farther by no more than the vehicle could have gone since
    far_off_factor: float = 2.0  # a rejected detection this many times nearer or farther than the track: another light
    estimate_current: bool = True  # False: the position follows each detection, no drift estimate


@dataclass(frozen=True)
class DockFix:
    """The tracked geometry, level navigation frame."""

    position_m: tuple[float, float]  # vehicle reference point relative to the dock's entrance centre
    current_mps: tuple[float, float]
    position_sigma_m: float
    current_sigma_mps: float


class DockTracker:
    def __init__(self, config: TrackerConfig = TrackerConfig()) -> None:
        self.config = config
        self.reset()

    def reset(self) -> None:
        self._x: np.ndarray | None = None  # rx, ry, cx, cy, speed model error (share)
        self._p = np.eye(5)
        self._rejected: list[tuple[np.ndarray, np.ndarray]] = []  # recent rejected positions and their noise
        self._confirmed_s = 0.0  # stamp of the last detection the track took
        self.rejected = 0

    @property
    def started(self) -> bool:
        return self._x is not None

    def fix(self) -> DockFix | None:
        if self._x is None:
            return None
        x, p = self._x, self._p
        return DockFix((float(x[0]), float(x[1])), (float(x[2]), float(x[3])),
                       math.sqrt(max(p[0, 0], p[1, 1])), math.sqrt(max(p[2, 2], p[3, 3])))

    def predict(self, dt: float, own_displacement_m: tuple[float, float]) -> None:
        """Move on by ``dt`` seconds in which the vehicle's own motion through the water covered this."""
        if self._x is None or dt <= 0:
            return
        c = self.config
        f = np.eye(5)
        if c.estimate_current:
            f[0, 2] = f[1, 3] = dt
            f[0, 4], f[1, 4] = own_displacement_m
        moved = f @ self._x + np.array([own_displacement_m[0], own_displacement_m[1], 0.0, 0.0, 0.0])
        motion = moved[:2] - self._x[:2]
        self._x = moved
        q = np.diag([c.motion_noise_mps**2 * dt] * 2 + [c.current_noise_mps2**2 * dt] * 2
                    + [c.speed_error_noise_per_s**2 * dt])
        self._p = f @ self._p @ f.T + q
        self._rejected = [(z + motion, r + q[:2, :2]) for z, r in self._rejected]  # carried on as the track is

    def update(self, target: Target, attitude: Attitude, may_restart: bool = True, learn_drift: bool = True) -> bool:
        """Correct with a detection; False if it was rejected as an outlier. With ``may_restart`` False (a ring
        the frame cuts close in: its bearing holds, its range may not) it neither starts nor restarts the track.
        With ``learn_drift`` False it corrects the position alone, not the current or the speed model."""
        c = self.config
        dock = dock_from_camera(target, attitude)
        z = self._position_from(dock, attitude)
        r = self._measurement_noise(dock)
        if target.position_covariance is not None:
            turn = level_from_optical(attitude)
            r = r + (turn @ np.array(target.position_covariance).reshape(3, 3) @ turn.T)[:2, :2]
        if self._x is None or not c.estimate_current:
            if may_restart:
                self._start(z, r, target.stamp_s)
            return may_restart
        h = np.hstack([np.eye(2), np.zeros((2, 3))])
        s = h @ self._p @ h.T + r
        innovation = z - h @ self._x
        distance = float(innovation @ np.linalg.solve(s, innovation))
        if not math.isfinite(distance) or distance > c.gate_chi2:
            self.rejected += 1
            if not may_restart:
                return False
            self._rejected = [(old, r_old) for old, r_old in self._rejected
                              if _agree(z - old, r + r_old, c.gate_chi2)] + [(z, r)]
            if len(self._rejected) >= c.max_rejections and self._may_restart(z, s, target.stamp_s):
                self._start(z, r, target.stamp_s)
            return False
        k = self._p @ h.T @ np.linalg.inv(s)
        if not learn_drift:
            k[2:] = 0.0
        self._x = self._x + k @ innovation
        keep = np.eye(5) - k @ h
        self._p = keep @ self._p @ keep.T + k @ r @ k.T  # Joseph form: right for any gain
        self._rejected = []
        self._confirmed_s = target.stamp_s
        return True

    def _may_restart(self, z: np.ndarray, covariance: np.ndarray, stamp_s: float) -> bool:
        """Nearer than the track: yes (a ring big in the frame is the stronger evidence, and believing the dock
        near slows the vehicle and checks the entry). Farther: only as far as the vehicle could have moved since
        the track was last confirmed. Seed 58: turned away from the dock 3 m off, the camera saw a lamp 25 m out
        in three frames and the track jumped there; the vehicle drove blind past the dock at full speed to a
        back-off point it thought was ahead."""
        assert self._x is not None  # only a running track rejects detections
        tracked = self._x[:2]
        if float(np.linalg.norm(z)) < float(np.linalg.norm(tracked)):
            return True
        spread = 3.0 * math.sqrt(float(np.max(np.linalg.eigvalsh(covariance))))
        reach = self.config.max_relative_speed_mps * (stamp_s - self._confirmed_s) + spread
        return float(np.linalg.norm(z - tracked)) <= reach

    def far_off(self, target: Target, attitude: Attitude) -> bool:
        """The detection puts the dock ``far_off_factor`` times nearer or farther than the track does:
        a lamp or a reflection, not the track lagging a gust (that moves the dock sideways, not by a factor)."""
        if self._x is None:
            return False
        seen = float(np.linalg.norm(self._position_from(dock_from_camera(target, attitude), attitude)))
        tracked = float(np.linalg.norm(self._x[:2]))
        factor = self.config.far_off_factor
        return not tracked / factor <= seen <= tracked * factor

    def _position_from(self, dock_level: np.ndarray, attitude: Attitude) -> np.ndarray:
        """The reference point relative to the dock, from the dock as the camera sees it."""
        lever = level_from_body(attitude) @ np.array([self.config.camera_ahead_m, 0.0, 0.0])
        return -(dock_level[:2] + lever[:2])

    def _start(self, z: np.ndarray, r: np.ndarray, stamp_s: float) -> None:
        """Position from this detection; the current and speed error estimates are kept if there are any."""
        c = self.config
        current = self._x[2:] if self._x is not None else np.zeros(3)
        current_p = self._p[2:, 2:] if self._x is not None else np.diag(
            [c.initial_current_sigma_mps**2] * 2 + [c.initial_speed_error_sigma**2])
        if not c.estimate_current:
            current, current_p = np.zeros(3), np.zeros((3, 3))
        self._x = np.concatenate([z, current])
        self._p = np.zeros((5, 5))
        self._p[:2, :2] = r
        self._p[2:, 2:] = current_p
        self._rejected = []
        self._confirmed_s = stamp_s

    def _measurement_noise(self, dock_level: np.ndarray) -> np.ndarray:
        c = self.config
        distance = max(float(np.linalg.norm(dock_level)), 0.5)
        along = dock_level[:2] / max(float(np.linalg.norm(dock_level[:2])), 1e-6)
        across = np.array([-along[1], along[0]])
        return ((c.range_noise_rel * distance) ** 2 * np.outer(along, along)
                + (c.lateral_noise_per_m * distance) ** 2 * np.outer(across, across) + 1e-6 * np.eye(2))


def _agree(difference: np.ndarray, covariance: np.ndarray, gate_chi2: float) -> bool:
    """Two positions the same within their noise (the innovation gate)."""
    distance = float(difference @ np.linalg.solve(covariance, difference))
    return math.isfinite(distance) and distance <= gate_chi2
