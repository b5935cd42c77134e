"""The dock's pose with a covariance, propagated from what the detector measured.

Frames and convention (what ``dock/pose`` publishes):

* The pose is in the camera optical frame (x right, y down, z forward, REP 103).
* Position: the ring's 3-D centre.
* Orientation: the dock frame's x axis is the dock's axis, pointing out of the entrance
  towards the approaching vehicle (the ring normal of the tilt-aware fit). A circle has no
  roll about its axis: the frame's z axis is chosen as close to the camera's "up" (-y) as
  the axis allows, and the variance of the rotation about the axis is marked unknown.
* Covariance: 6x6, row-major, (x, y, z, rotation about x, y, z), rotations about the
  optical frame's axes. Quantities that were not observed get ``UNKNOWN_VARIANCE``
  (the ROS convention for a PoseWithCovariance: a variance so large that a filter such as
  robot_localization takes nothing from it; better still, leave those fields out of its
  ``pose0_config``).

The measurement: the ring's image centre (x_n, y_n) on the normalized plane and its
radius r_n = R / z. Both come from a fit to the outline whose points scatter about the
fitted ellipse; the detector reports the centre's standard error ``fit_sigma`` (each
coordinate), and the radius's follows from it (``MeasurementNoise.radius_share``). Then
sigma_z = z * sigma_r / r_n = z^2 sigma_r / R: the range's standard deviation grows as z^2
for a fixed outline error in pixels (its variance as z^2 / r_n^2, with r_n = R / z), and
faster still far away, where fewer outline pixels share the error.
Then (x, y, z) = (x_n z, y_n z, z) carries the covariance through its Jacobian. Terms
added on top: a pixel-noise floor, floors for the centre's lean and the radius's scale that
the scatter does not show (``MeasurementNoise``; a solid blob's outline is the ring's outer edge
plus its halo, as are the LEDs of a ring bloomed into one glow, so its range floor is wider),
the two-fold ambiguity of a tilted ring when the fit could not tell which pose is true (the
midpoint was used: half the distance to either solution), the short arc of a ring cut by the
frame (a circle through part of its outline is loose along the arc's bisector), and an
approximate camera (a guessed focal length scales the range; a guessed principal point shifts
the offsets).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from auv_dock_guidance.geometry.pose import CircleSolution, Ellipse, MarkerPose, circles_from_ellipse
from auv_dock_guidance.geometry.rotations import quaternion_from_matrix

UNKNOWN_VARIANCE = 1.0e3  # m^2 or rad^2: nothing known (the convention of PoseWithCovariance producers)
OUTLINE_PX_PER_SAMPLE = 8.0  # outline errors are correlated over a few pixels: one independent sample each


@dataclass(frozen=True)
class MeasurementNoise:
    """What the fit's own scatter does not show."""

    pixel_sigma_px: float = 0.1  # floor on the outline's error per independent sample (px)
    # Radius variance over the centre's (a least-squares circle: 1/2). 1/4: measured on renders at
    # 3-14 m, the fit's own error estimate (one independent outline sample per 8 px) overstates
    # the radius's error about twice, while the centre's extra error comes from the tilt.
    radius_share: float = 0.25
    # What the outline's scatter does not show, measured on the evaluation populations (real-world
    # effects: halo, bloom, glare, lamps, LED rings round a lit funnel), where the scatter alone
    # understated the errors 2-3x at the median and 7-17x at the 95th percentile: the halo, the
    # threshold and an LED lost to a bloom lean the centre by a share of the ring's image radius
    # (each axis; 68 % of whole rings within 3-7 %, of LED rings 3 %)...
    centre_share_floor: float = 0.03
    # ...and scale the radius, so the range, by a share (68 % of whole rings within 0.8-1 %; clean
    # renders of a strip: 0.05 % at 3 m). Both grow for a ring the frame cuts, as the scatter's do.
    range_share_floor: float = 0.008
    # A solid blob (no hole resolved, no LEDs: a bloom or a lit funnel filled the ring) has only its
    # outer outline, which lies outside the ring by the glow round it: about half a degree of view
    # whatever the range (measured on open-water renders: 5-10 px at 867 px focal, from 1.7 to 21 m),
    # so the range reads short by that over the ring's image radius (25 % at 21 m, 7 % at 5 m). On the
    # evaluation populations 68 % of blobs read within 3-15 %; whole rings within 0.8-1 % (above).
    # LEDs bloomed into one glow (``Detection.bloomed``) lie on its outline too: 68 % within 0.0075 of
    # the ring's image radius (normalized), 95 % within 0.022, on 2000 renders of the open-water docks.
    solid_halo: float = 0.008  # normalized units
    unknown_fit_px: float = 1.0  # centre error assumed when the fit reports none (px)
    approximate_focal_share: float = 0.05  # standard error of a guessed focal length (share)
    approximate_principal_share: float = 0.02  # standard error of a guessed principal point (share of width)


@dataclass(frozen=True)
class RingObservation:
    """What the detector measured of the ring in one frame."""

    center_m: tuple[float, float, float]  # ring centre, camera optical frame
    marker_radius_m: float
    focal_px: float
    fit_sigma: float  # standard error of the fitted centre on the normalized plane, each coordinate
    ellipse: Ellipse | None = None  # the ring's centre line on the normalized plane (tilt-aware fit)
    ring_normal: tuple[float, float, float] | None = None  # dock axis towards the camera, when resolved
    visible_arc_deg: float = 360.0  # less when the frame cuts the ring
    approximate_camera: bool = False  # focal length and principal point guessed, not calibrated
    image_width_px: int = 0  # for the principal point's uncertainty of an approximate camera
    tilt_disputed: bool = False  # no tilt to trust (LEDs assembled with the wrong count, or bloomed)
    solid: bool = False  # read by its outer outline alone (a blob with no hole, or LEDs bloomed into one): loose range


class RingFit(Protocol):
    """The fields of a detection this module reads (vision's Detection has them)."""

    @property
    def pose(self) -> MarkerPose | None: ...
    @property
    def ellipse(self) -> Ellipse | None: ...
    @property
    def ring_normal(self) -> tuple[float, float, float] | None: ...
    @property
    def fit_sigma(self) -> float: ...
    @property
    def visible_arc_deg(self) -> float: ...
    @property
    def range_approximate(self) -> bool: ...
    @property
    def count_disputed(self) -> bool: ...
    @property
    def bloomed(self) -> bool: ...
    @property
    def is_ring(self) -> bool: ...
    @property
    def led_count(self) -> int: ...


def observation_of(fit: RingFit, marker_radius_m: float, focal_px: float,
                   image_width_px: int) -> RingObservation | None:
    """The observation behind a detection, or None when it has no pose; a detection through an
    approximate camera (``range_approximate``) is less certain."""
    if fit.pose is None:
        return None
    pose = fit.pose
    return RingObservation(
        center_m=(pose.offset_x_m, pose.offset_y_m, pose.range_m), marker_radius_m=marker_radius_m,
        focal_px=focal_px, fit_sigma=fit.fit_sigma, ellipse=fit.ellipse, ring_normal=fit.ring_normal,
        visible_arc_deg=fit.visible_arc_deg, approximate_camera=fit.range_approximate, image_width_px=image_width_px,
        tilt_disputed=fit.count_disputed or fit.bloomed,
        solid=(fit.bloomed or not (fit.is_ring or fit.led_count)) and fit.visible_arc_deg >= 360.0,
    )


@dataclass(frozen=True)
class DockPose:
    """The dock in the camera optical frame, with its covariance (see the module's docstring)."""

    position_m: tuple[float, float, float]
    orientation_xyzw: tuple[float, float, float, float]
    covariance: tuple[float, ...]  # 36, row-major (x, y, z, rot x, rot y, rot z)
    axis_observed: bool

    def matrix(self) -> np.ndarray:
        return np.array(self.covariance).reshape(6, 6)

    @property
    def range_sigma_m(self) -> float:
        return math.sqrt(self.matrix()[2, 2])

    def bearing_sigmas_rad(self) -> tuple[float, float]:
        """Standard deviations of yaw = atan2(x, z) and pitch = atan2(y, z)."""
        x, y, z = self.position_m
        cov = self.matrix()[:3, :3]
        sigmas = []
        for lateral, index in ((x, 0), (y, 1)):
            gradient = np.zeros(3)
            gradient[index], gradient[2] = z, -lateral
            gradient /= lateral * lateral + z * z
            sigmas.append(math.sqrt(float(gradient @ cov @ gradient)))
        return sigmas[0], sigmas[1]


def dock_pose(observation: RingObservation, noise: MeasurementNoise = MeasurementNoise()) -> DockPose:
    """The dock's pose and covariance from one observation of its ring."""
    center = np.asarray(observation.center_m, dtype=float)
    z = float(center[2])
    if not (z > 0 and np.all(np.isfinite(center))):
        raise ValueError(f"ring centre {observation.center_m} must be finite and in front of the camera")
    radius_n = observation.marker_radius_m / z
    position_cov = _position_covariance(observation, noise, center, radius_n)
    axis, axis_variance, position_cov = _axis(observation, position_cov, radius_n)
    covariance = np.zeros((6, 6))
    covariance[:3, :3] = position_cov
    if axis is None:
        covariance[3:, 3:] = UNKNOWN_VARIANCE * np.eye(3)
        orientation = quaternion_from_matrix(_dock_frame(-center / np.linalg.norm(center)))
    else:
        across = np.eye(3) - np.outer(axis, axis)  # tilts of the axis; the roll about it is unknown
        covariance[3:, 3:] = axis_variance * across + UNKNOWN_VARIANCE * np.outer(axis, axis)
        orientation = quaternion_from_matrix(_dock_frame(axis))
    return DockPose(
        position_m=(float(center[0]), float(center[1]), z),
        orientation_xyzw=orientation,
        covariance=tuple(float(v) for v in covariance.ravel()),
        axis_observed=axis is not None,
    )


def _position_covariance(
    observation: RingObservation, noise: MeasurementNoise, center: np.ndarray, radius_n: float
) -> np.ndarray:
    """Centre and radius errors on the normalized plane, carried to (x, y, z)."""
    z = float(center[2])
    x_n, y_n = float(center[0]) / z, float(center[1]) / z
    samples = max(4.0, 2.0 * math.pi * radius_n * observation.focal_px / OUTLINE_PX_PER_SAMPLE)
    floor = noise.pixel_sigma_px / observation.focal_px * math.sqrt(2.0 / samples)
    # A fit that could not tell its own error: assume the centre is known to a pixel, no better.
    fit_sigma = observation.fit_sigma if math.isfinite(observation.fit_sigma) \
        else noise.unknown_fit_px / observation.focal_px
    point_variance = 0.5 * (fit_sigma**2 + floor**2)  # one outline point's variance / samples
    center_factor, radius_factor = arc_factors(observation.visible_arc_deg)
    center_variance = (point_variance + 0.5 * (noise.centre_share_floor * radius_n) ** 2) * center_factor
    radius_variance = point_variance * radius_factor
    range_variance = (z / radius_n) ** 2 * radius_variance * (2.0 * noise.radius_share) \
        + (noise.range_share_floor * z) ** 2 * radius_factor
    if observation.solid:
        range_variance += (z * noise.solid_halo / radius_n) ** 2
    normalized = np.diag([center_variance, center_variance, range_variance])
    jacobian = np.array([[z, 0.0, x_n], [0.0, z, y_n], [0.0, 0.0, 1.0]])
    cov = jacobian @ normalized @ jacobian.T
    if observation.approximate_camera:
        # z = f R / r_px scales with the focal length; x = (u - cx) R / r_px does not, but
        # moves with the principal point.
        principal_px = noise.approximate_principal_share * max(observation.image_width_px, 1)
        lateral = (principal_px * z / observation.focal_px) ** 2
        cov = cov + np.diag([lateral, lateral, (noise.approximate_focal_share * z) ** 2])
    return cov


@functools.lru_cache(maxsize=64)
def _arc_factors_at(arc_deg: int) -> tuple[float, float]:
    arc = math.radians(arc_deg)
    angles = arc * ((np.arange(180) + 0.5) / 180 - 0.5)
    jacobian = np.column_stack([np.cos(angles), np.sin(angles), np.ones_like(angles)])
    inverse = np.linalg.inv(jacobian.T @ jacobian / len(angles))
    return float(max(inverse[0, 0], inverse[1, 1])), float(inverse[2, 2])


def arc_factors(visible_arc_deg: float) -> tuple[float, float]:
    """(centre, radius) variance of a least-squares circle through points evenly spread on an
    arc, per unit point variance and point: 2 and 1 for the whole circle, growing fast as
    the arc shortens. The centre's is the worse of its two directions (towards the arc's
    middle, where it trades off against the radius)."""
    return _arc_factors_at(int(round(min(360.0, max(30.0, visible_arc_deg)))))  # to the degree: cached


def _ratio_sigma(observation: RingObservation, radius_n: float) -> float:
    """Standard error of the ellipse's axis ratio b / a (its second harmonic, like the centre's first);
    inf when there is no error to give (no fit scatter, or a pose not in front of the camera)."""
    if not (math.isfinite(observation.fit_sigma) and observation.fit_sigma >= 0.0 and radius_n > 0.0):
        return math.inf
    return 2.0 * observation.fit_sigma / radius_n


def _ambiguity(solutions: list[CircleSolution]) -> tuple[np.ndarray, float]:
    """Half the distance between the two poses that project onto one ellipse (m), and half
    the angle between their axes (rad); zero where there is one."""
    if len(solutions) != 2:
        return np.zeros(3), 0.0
    cosine = float(np.clip(solutions[0].normal @ solutions[1].normal, -1.0, 1.0))
    return 0.5 * (solutions[0].center_m - solutions[1].center_m), 0.5 * math.acos(cosine)


def _noise_ambiguity(ellipse: Ellipse, marker_radius_m: float, ratio_sigma: float) -> tuple[float, float]:
    """What outline noise alone makes of the squares of ``_ambiguity``'s distance and angle.

    Noise flattens a fitted circle by a two-component vector with ``ratio_sigma`` in each,
    and any flattening separates the two poses. Measured on a circle of the same size seen
    head-on, flattened by the noise's typical amount (its direction does not matter there).
    """
    radius = math.sqrt(ellipse.semi_major * ellipse.semi_minor)
    flattening = min(0.5, math.sqrt(2.0) * ratio_sigma)
    flat = Ellipse(0.0, 0.0, radius * (1 + flattening / 2), radius * (1 - flattening / 2), 0.0)
    half, angle = _ambiguity(circles_from_ellipse(flat, marker_radius_m))
    return float(half @ half), angle**2


def _axis(observation: RingObservation, position_cov: np.ndarray,
          radius_n: float) -> tuple[np.ndarray | None, float, np.ndarray]:
    """The dock axis (towards the camera), the variance of its tilt, and the position
    covariance with the pose ambiguity added; the axis is None when unobserved.

    The tilt comes from the ellipse's axis ratio cos(t) = b / a, whose error is about
    2 sigma_c / r; near head-on (t small) an error in b / a moves t by its square root.
    When the fit could not tell the two poses apart, the midpoint of their centres and the
    mean of their axes were reported: off the true pose by half the distance and half the
    angle between them, less what outline noise alone makes of that.
    """
    if observation.tilt_disputed:
        return None, UNKNOWN_VARIANCE, position_cov
    ellipse = observation.ellipse
    ratio_sigma = _ratio_sigma(observation, radius_n)
    whole = ellipse is not None and observation.visible_arc_deg >= 360.0 and math.isfinite(ratio_sigma)
    if observation.ring_normal is not None and whole:
        axis = np.asarray(observation.ring_normal, dtype=float)
        spread_variance = 0.0
    elif observation.ring_normal is None and whole:
        assert ellipse is not None
        solutions = circles_from_ellipse(ellipse, observation.marker_radius_m)
        if len(solutions) != 2:
            return None, UNKNOWN_VARIANCE, position_cov
        half, angle = _ambiguity(solutions)
        noise_distance, noise_angle = _noise_ambiguity(ellipse, observation.marker_radius_m, ratio_sigma)
        distance = float(half @ half)
        if distance > 0:
            position_cov = position_cov + np.outer(half, half) * max(0.0, distance - noise_distance) / distance
        axis = solutions[0].normal + solutions[1].normal
        spread_variance = max(0.0, angle**2 - noise_angle)
    else:
        return None, UNKNOWN_VARIANCE, position_cov
    axis = axis / np.linalg.norm(axis)
    return axis, min(UNKNOWN_VARIANCE, tilt_sigma_rad(observation, axis) ** 2 + spread_variance), position_cov


def tilt_sigma_rad(observation: RingObservation, axis: np.ndarray | tuple[float, float, float]) -> float:
    """Standard deviation of the tilt of ``axis`` (either of the ring's two poses) off the line of
    sight, from the outline's scatter: cos(tilt) = b / a, so near head-on an error in b / a moves
    the tilt by its square root (inf when the fit reports no error)."""
    center = np.asarray(observation.center_m, dtype=float)
    ratio_sigma = _ratio_sigma(observation, observation.marker_radius_m / float(center[2]))
    if not math.isfinite(ratio_sigma):
        return math.inf
    axis = np.asarray(axis, dtype=float)
    cosine = float(np.clip(-(axis @ center) / (np.linalg.norm(axis) * np.linalg.norm(center)), -1.0, 1.0))
    return ratio_sigma / max(math.sqrt(1.0 - cosine * cosine), math.sqrt(ratio_sigma))


def _dock_frame(axis: np.ndarray) -> np.ndarray:
    """Rotation whose columns are the dock frame's axes in the optical frame: x along the
    dock axis, z as near the camera's up (-y) as the axis allows."""
    x_axis = axis / np.linalg.norm(axis)
    up = np.array([0.0, -1.0, 0.0])
    if abs(float(up @ x_axis)) > 0.99:  # the axis is vertical in the image: any roll will do
        up = np.array([0.0, 0.0, -1.0])
    z_axis = up - (up @ x_axis) * x_axis
    z_axis /= np.linalg.norm(z_axis)
    return np.column_stack([x_axis, np.cross(z_axis, x_axis), z_axis])
