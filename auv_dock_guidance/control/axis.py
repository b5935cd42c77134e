"""The dock's axis in the level navigation frame, from the ring normals the detector reports.

The tilt-aware fit gives the ring's axis in the camera frame, but a circle's image fits
two circles whose axes are mirror images about the line of sight, and far out the
detector can only guess which (``Detection.ring_normal`` is then its guess). The dock
does not move, so its true axis is the same direction from every viewpoint while the
mirror image swings with the line of sight. Each observation therefore contributes both
candidates; the estimate is the direction that explains most observations (each by the
nearer of its two candidates), and it counts as known only once the mirror about the
present line of sight explains them clearly worse (the vehicle has seen the dock from
more than one direction), or when the two coincide (the vehicle is on the axis).

Each observation is weighed by the detector's own standard deviation of the tilt
(``Target.axis_sigma_rad``, from the outline's scatter; inflated by ``reported_sigma_scale``
for what the scatter does not show, such as the halo rounding a far ring), not by a fixed
model of range: near head-on the tilt comes from the square root of the ellipse's flattening,
so a dock seen from 5-10 m can scatter by 10 deg while another is good to 1 deg. A fixed
model took such scatter for signal and settled on an axis 10-20 deg off.

Views from much farther than the present one are left out of the estimate (``superseded_ratio``):
far out the halo rounds the ring's image, so a tilted dock looks head-on again and again,
and a hundred such views, wrong the same way, outvoted the few close ones that see the tilt
(their errors are not independent, so their number is no evidence).

Some dock looks bias every view in the same way their scatter does not show (the outline of a
strip round a shaded, lit funnel: errors 4-5 times the reported sigma, measured in the loop).
When the views scatter about the first choice more than their sigmas allow, all sigmas are
scaled by that excess (the Birge ratio, taken from the upper quartile) and the choice is made
again: clusters a few sigmas apart merge instead of taking turns as the estimate, and the
mirror needs a larger margin to be ruled out.

Noise only ever adds tilt: a dock seen head-on reads several degrees tilted in some direction, and
both mirror images lie that far either side of the line of sight. Each view's tilt is therefore
taken less what its noise adds on average before the mirrors are formed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from auv_dock_guidance.control.cascade import Attitude, Target
from auv_dock_guidance.control.pid import wrap_angle
from auv_dock_guidance.control.tracker import dock_from_camera, optical_to_level

_UPPER_QUARTILE_CHI2_1 = 1.323  # upper quartile of the square of a standard normal variable


@dataclass(frozen=True)
class AxisConfig:
    noise_deg_at_zero: float = 0.5  # least angle noise of one observation close in...
    noise_deg_per_m2: float = 0.01  # ...growing with the square of the range (used alone when none is reported)
    reported_sigma_scale: float = 1.5  # the detector's tilt sigma times this (measured errors: median 1, p90 2.4)
    max_sigma_deg: float = 15.0  # observations less certain than this are left out (10 deg as reported)
    superseded_ratio: float = 2.0  # views from farther than this times the present range are left out...
    kept_within_m: float = 5.0  # ...unless from within this (close in, twice the range is a metre of approach)
    outlier_sigmas: float = 3.0  # an observation further than this from both candidates counts as an outlier
    min_observations: int = 5
    min_margin: float = 16.0  # cost (squared sigmas) by which the mirror must explain the observations worse
    min_view_change_deg: float = 4.0  # ...after the line of sight has swung at least this much among them
    coincide_deg: float = 3.0  # candidates closer than this to the line of sight: no mirror ambiguity
    memory: int = 300  # observations kept (when full, the farthest goes)
    candidates: int = 60  # the most recent observations' directions are tried as the estimate
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
        # candidate a, its mirror b, sigma, line of sight (rad), range (m)
        self._observations: list[tuple[float, float, float, float, float]] = []
        self._line_of_sight_rad: float | None = None  # direction from the vehicle to the dock
        self._present_range_m = 0.0  # views from farther than superseded_ratio times this are left out
        self._chosen: float | None = None  # the last estimate: kept over its mirror until the mirror is clearly better
        self._estimate: AxisEstimate | None = None

    def observe(self, target: Target, ring_normal_optical: tuple[float, float, float], attitude: Attitude,
                present_range_m: float | None = None) -> None:
        """Add one view. ``present_range_m``: the tracked range, if any, to cut the views against; a
        detection's own range can alternate between two readings of one dock (its LED ring at 7.5 m, its
        outline at 5 m), and the kept views swung with it between 90 and 190."""
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
        normal = _debiased(normal, sight, sigma)
        mirror = 2.0 * float(normal @ sight) * sight - normal
        self._line_of_sight_rad = math.atan2(dock[1], dock[0])
        self._present_range_m = distance if present_range_m is None else present_range_m
        self._observations.append((math.atan2(-normal[1], -normal[0]), math.atan2(-mirror[1], -mirror[0]), sigma,
                                   self._line_of_sight_rad, distance))
        if len(self._observations) > c.memory:
            # The farthest goes, not the oldest: the dock does not move, and a retry's minute of vague views
            # from 7 m must not push out the few close ones that saw the tilt. Nor the least certain: close
            # views scatter more (sigma 5-7 deg at 3 m against 2-3 at 9 m), yet only they see the tilt.
            del self._observations[max(range(len(self._observations)), key=lambda i: self._observations[i][4])]
        self._estimate = self._estimated()

    def estimate(self) -> AxisEstimate | None:
        """The estimate as of the last observation."""
        return self._estimate

    def _estimated(self) -> AxisEstimate | None:
        c = self.config
        obs = np.array(self._observations)  # called after each observation: never empty
        obs = obs[obs[:, 4] <= max(c.superseded_ratio * self._present_range_m, c.kept_within_m)]
        if len(obs) < c.min_observations or self._line_of_sight_rad is None:
            return self._estimate  # too few views from about here yet: the last estimate stands
        recent = obs[-c.candidates:]
        trial = np.concatenate([recent[:, 0], recent[:, 1]])
        best = self._refined(obs, float(trial[int(np.argmin(self._costs(obs, trial)))]))
        obs = obs.copy()
        obs[:, 2] *= self._excess_scatter(obs, best)
        best = self._refined(obs, float(trial[int(np.argmin(self._costs(obs, trial)))]))
        sight = self._line_of_sight_rad
        if abs(wrap_angle(best - sight)) < math.radians(c.coincide_deg):
            known = True
        else:
            mirror = wrap_angle(2 * sight - best)
            best_cost, mirror_cost = self._costs(obs, np.array([best, mirror]))
            swing = _wrapped(obs[:, 3] - sight)
            viewed_from_apart = float(np.max(swing) - np.min(swing)) >= math.radians(c.min_view_change_deg)
            known = viewed_from_apart and mirror_cost - best_cost >= c.min_margin
            if not known and self._chosen is not None and \
                    abs(wrap_angle(mirror - self._chosen)) < abs(wrap_angle(best - self._chosen)):
                best = mirror  # as good as undecided: stay on the side chosen before (no flip-flopping)
        self._chosen = best
        weights = 1.0 / obs[:, 2] ** 2
        sigma = 1.0 / math.sqrt(float(np.sum(weights)))
        return AxisEstimate(best, sigma, known)

    @staticmethod
    def _excess_scatter(obs: np.ndarray, around: float) -> float:
        """How much farther the views scatter about ``around`` than their sigmas say (at least 1): the
        root of the upper quartile of the squared normalized residuals over its value for a normal
        error (a quarter of the views may be outliers without scaling the rest)."""
        da = _wrapped(obs[:, 0] - around)
        db = _wrapped(obs[:, 1] - around)
        squared = np.minimum(da**2, db**2) / obs[:, 2] ** 2
        return max(1.0, math.sqrt(float(np.quantile(squared, 0.75)) / _UPPER_QUARTILE_CHI2_1))

    def _costs(self, obs: np.ndarray, trial: np.ndarray) -> np.ndarray:
        """Robust cost of each trial direction: every observation explained by its nearer candidate."""
        limit = self.config.outlier_sigmas**2
        da = _wrapped(trial[:, None] - obs[None, :, 0])
        db = _wrapped(trial[:, None] - obs[None, :, 1])
        nearest = np.minimum(da**2, db**2) / obs[None, :, 2] ** 2
        return np.sum(np.minimum(nearest, limit), axis=1)

    def _refined(self, obs: np.ndarray, around: float) -> float:
        """Weighted mean of the candidates that agree with ``around``."""
        da = _wrapped(obs[:, 0] - around)
        db = _wrapped(obs[:, 1] - around)
        nearer = np.where(np.abs(da) <= np.abs(db), da, db)
        inlier = np.abs(nearer) <= self.config.outlier_sigmas * obs[:, 2]
        if not np.any(inlier):
            return around
        weights = 1.0 / obs[inlier, 2] ** 2
        return wrap_angle(around + float(np.sum(weights * nearer[inlier]) / np.sum(weights)))


def _debiased(normal: np.ndarray, sight: np.ndarray, sigma: float) -> np.ndarray:
    """The normal turned towards the line of sight by the tilt that noise alone adds: a tilt measured with
    noise ``sigma`` in each direction is ``sqrt(tilt^2 + 2 sigma^2)`` on average, never less than that
    noise, so a dock seen head-on read 7-12 deg tilted and its axis (one of the two mirror images) as far
    off the line of sight (seeds 71, 97: 0.2 m/s across, 9-11 deg off, entered 15-17 deg off)."""
    cosine = float(np.clip(normal @ sight, -1.0, 1.0))
    tilt = math.acos(cosine)
    across = normal - cosine * sight
    if tilt < 1e-9:
        return normal
    kept = math.sqrt(max(0.0, tilt * tilt - 2.0 * sigma * sigma))
    return math.cos(kept) * sight + math.sin(kept) * across / float(np.linalg.norm(across))


def _wrapped(angles: np.ndarray) -> np.ndarray:
    return (angles + math.pi) % (2 * math.pi) - math.pi
