"""The dock's axis in the level navigation frame, from the ring normals the detector reports.

The tilt-aware fit gives the ring's axis in the camera frame, but a circle's image fits
two circles whose axes are mirror images about the line of sight, and far out the
detector can only guess which (``Detection.ring_normal`` is then its guess). The dock
does not move, so its true axis is the same direction from every viewpoint while the
mirror image swings with the line of sight. What a view measures without ambiguity is the
cosine of the tilt between the ring's axis and the line of sight (the ellipse's axis ratio);
the estimate is the level direction whose cosines with the lines of sight explain the most
views, and it counts as known only once the mirror about the present line of sight explains
them clearly worse (the vehicle has seen the dock from more than one direction), or when
the two coincide (the vehicle is on the axis).

The cosine, not the angle, is compared because the fit's error is in the axis ratio: near
head-on the tilt is its square root, so noise makes every view look tilted (a dock seen
head-on from 5-7 m through blooming LEDs measured 10-15 deg); angles took that for signal
and settled on an axis 10-20 deg off. Each view is weighed by the detector's own tilt
sigma (``Target.axis_sigma_rad``, from the outline's scatter; inflated by
``reported_sigma_scale`` for what the scatter does not show), turned into the ratio's. The
flattening 1 - b/a is the length of a 2-D quantity (its orientation is the tilt's
direction), so noise lengthens it on average: a view is expected to show
sqrt(f^2 + pi/2 sigma^2) for a true flattening f (the Rician mean, to within 10 %).

Views from much farther than the present one are left out of the estimate (``superseded_ratio``):
far out the halo rounds the ring's image, so a tilted dock looks head-on again and again,
and a hundred such views, wrong the same way, outvoted the few close ones that see the tilt
(their errors are not independent, so their number is no evidence).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from auv_dock_guidance.control.cascade import Attitude, Target
from auv_dock_guidance.control.pid import wrap_angle
from auv_dock_guidance.control.tracker import dock_from_camera, optical_to_level


@dataclass(frozen=True)
class AxisConfig:
    noise_deg_at_zero: float = 0.5  # least angle noise of one observation close in...
    noise_deg_per_m2: float = 0.01  # ...growing with the square of the range (used alone when none is reported)
    reported_sigma_scale: float = 1.5  # the detector's tilt sigma times this (measured errors: median 1, p90 2.4)
    max_sigma_deg: float = 15.0  # observations less certain than this are left out (10 deg as reported)
    superseded_ratio: float = 2.0  # views from farther than this times the present range are left out
    outlier_sigmas: float = 3.0  # a view further than this from a trial direction counts as an outlier
    min_observations: int = 5
    min_margin: float = 16.0  # cost (squared sigmas) by which the mirror must explain the observations worse
    min_view_change_deg: float = 4.0  # ...after the line of sight has swung at least this much among them
    coincide_deg: float = 3.0  # an estimate closer than this to the line of sight has no mirror ambiguity
    memory: int = 300  # observations kept
    max_tilt_deg: float = 75.0  # a normal further than this from the line of sight is not a ring's


@dataclass(frozen=True)
class AxisEstimate:
    yaw_rad: float  # direction of travel into the dock (level frame, yaw convention of the navigation)
    sigma_rad: float
    known: bool  # told apart from its mirror image (or on the axis, where there is none); else a guess


class AxisEstimator:
    def __init__(self, config: AxisConfig = AxisConfig()) -> None:
        self.config = config
        self.reset()

    def reset(self) -> None:
        # tilt sigma (rad), line of sight (rad), range (m), sight x, sight y (level, dock towards camera),
        # measured flattening 1 - cos(tilt), its sigma, what noise adds to its square on average
        self._observations: deque[tuple[float, ...]] = deque(maxlen=self.config.memory)
        self._line_of_sight_rad: float | None = None  # direction from the vehicle to the dock
        self._chosen: float | None = None  # the last estimate: kept over its mirror until the mirror is clearly better
        self._estimate: AxisEstimate | None = None

    def observe(self, target: Target, ring_normal_optical: tuple[float, float, float], attitude: Attitude) -> None:
        c = self.config
        dock = dock_from_camera(target, attitude)
        distance = float(np.linalg.norm(dock))
        if distance <= 0 or not all(math.isfinite(v) for v in ring_normal_optical):
            return
        normal = optical_to_level(ring_normal_optical, attitude)  # points out of the dock, towards the camera
        normal = normal / max(float(np.linalg.norm(normal)), 1e-12)
        sight = -dock / distance  # from the dock towards the camera
        if float(normal @ sight) < math.cos(math.radians(c.max_tilt_deg)):
            return
        sigma = math.radians(c.noise_deg_at_zero + c.noise_deg_per_m2 * distance**2)
        if target.axis_sigma_rad is not None:
            sigma = max(sigma, c.reported_sigma_scale * target.axis_sigma_rad)
        if not sigma <= math.radians(c.max_sigma_deg):  # also NaN
            return
        cosine = float(normal @ sight)
        sine = math.sqrt(max(0.0, 1.0 - cosine * cosine))
        ratio_sigma = sigma * max(sine, sigma)  # the tilt's sigma is ratio_sigma / max(sin(tilt), sqrt(ratio_sigma))
        reported = target.axis_sigma_rad or 0.0
        noise_lengthening = math.pi / 2 * (reported * max(sine, reported)) ** 2
        self._line_of_sight_rad = math.atan2(dock[1], dock[0])
        self._observations.append((sigma, self._line_of_sight_rad, distance, float(sight[0]), float(sight[1]),
                                   1.0 - cosine, ratio_sigma, noise_lengthening))
        self._estimate = self._estimated()

    def estimate(self) -> AxisEstimate | None:
        """The estimate as of the last observation."""
        return self._estimate

    def _estimated(self) -> AxisEstimate | None:
        c = self.config
        obs = np.array(self._observations)
        if len(obs):
            obs = obs[obs[:, 2] <= c.superseded_ratio * obs[-1, 2]]
        if len(obs) < c.min_observations or self._line_of_sight_rad is None:
            return self._estimate  # too few views from about here yet: the last estimate stands
        sight = self._line_of_sight_rad
        best = self._best(obs, sight + np.radians(np.arange(-c.max_tilt_deg, c.max_tilt_deg + 0.5, 1.0)))
        best = self._best(obs, best + np.radians(np.arange(-1.0, 1.01, 0.1)))
        if abs(wrap_angle(best - sight)) < math.radians(c.coincide_deg):
            known = True
        else:
            mirror = wrap_angle(2 * sight - best)
            best_cost, mirror_cost = self._costs(obs, np.array([best, mirror]))
            swing = _wrapped(obs[:, 1] - sight)
            viewed_from_apart = float(np.max(swing) - np.min(swing)) >= math.radians(c.min_view_change_deg)
            known = viewed_from_apart and mirror_cost - best_cost >= c.min_margin
            if not known and self._chosen is not None and \
                    abs(wrap_angle(mirror - self._chosen)) < abs(wrap_angle(best - self._chosen)):
                best = mirror  # as good as undecided: stay on the side chosen before (no flip-flopping)
        self._chosen = best
        weights = 1.0 / obs[:, 0] ** 2
        sigma = 1.0 / math.sqrt(float(np.sum(weights)))
        return AxisEstimate(best, sigma, known)

    def _best(self, obs: np.ndarray, trial: np.ndarray) -> float:
        return wrap_angle(float(trial[int(np.argmin(self._costs(obs, trial)))]))

    def _costs(self, obs: np.ndarray, trial: np.ndarray) -> np.ndarray:
        """Robust cost of each trial direction of travel into the dock: each view's measured flattening
        against what a level axis that way would show through the noise (outliers count as 3 sigma)."""
        limit = self.config.outlier_sigmas**2
        cosine = -(np.cos(trial)[:, None] * obs[None, :, 3] + np.sin(trial)[:, None] * obs[None, :, 4])
        expected = np.sqrt((1.0 - cosine) ** 2 + obs[None, :, 7])
        residual = (obs[None, :, 5] - expected) / obs[None, :, 6]
        return np.sum(np.minimum(residual**2, limit), axis=1)


def _wrapped(angles: np.ndarray) -> np.ndarray:
    return (angles + math.pi) % (2 * math.pi) - math.pi
