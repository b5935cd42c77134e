"""Where the dock is, from the marker's image: the paper's equations 7-8 and a tilt-aware fit.

All inputs are on the ideal normalized plane (undistorted, z = 1), so the focal length
is already divided out: the paper's z = f R / r becomes z = R / r_n with r_n = r / f.
Frames: camera optical frame, x right, y down, z forward (REP 103).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Ellipse:
    """An ellipse on the normalized plane: centre, semi-axes (major >= minor), angle of the major axis."""

    center_x: float
    center_y: float
    semi_major: float
    semi_minor: float
    angle_rad: float

    def conic(self) -> np.ndarray:
        """3x3 symmetric matrix C with [x y 1] C [x y 1]^T = 0 on the ellipse."""
        c, s = math.cos(self.angle_rad), math.sin(self.angle_rad)
        a2, b2 = self.semi_major**2, self.semi_minor**2
        # Quadratic form of ((R^T (p - c))_x / a)^2 + ((R^T (p - c))_y / b)^2 - 1
        q = np.array(
            [[c * c / a2 + s * s / b2, c * s * (1 / a2 - 1 / b2)], [c * s * (1 / a2 - 1 / b2), s * s / a2 + c * c / b2]]
        )
        center = np.array([self.center_x, self.center_y])
        m = np.zeros((3, 3))
        m[:2, :2] = q
        m[:2, 2] = m[2, :2] = -q @ center
        m[2, 2] = center @ q @ center - 1.0
        return m

    def points(self, count: int = 16) -> np.ndarray:
        """Points on the ellipse, (count, 2)."""
        t = np.linspace(0.0, 2.0 * math.pi, count, endpoint=False)
        c, s = math.cos(self.angle_rad), math.sin(self.angle_rad)
        x = self.semi_major * np.cos(t)
        y = self.semi_minor * np.sin(t)
        return np.stack([self.center_x + c * x - s * y, self.center_y + s * x + c * y], -1)


@dataclass(frozen=True)
class MarkerPose:
    """The marker centre in the camera optical frame and the bearing angles to it."""

    range_m: float  # z: forward distance (paper eq. 7)
    offset_x_m: float  # e_x: right of the optical axis
    offset_y_m: float  # e_y: below the optical axis
    yaw_rad: float  # atan(e_x / z): positive = marker to the right
    pitch_rad: float  # atan(e_y / z): positive = marker below

    @property
    def yaw_deg(self) -> float:
        return math.degrees(self.yaw_rad)

    @property
    def pitch_deg(self) -> float:
        return math.degrees(self.pitch_rad)


def pose_from_circle(center_xy: tuple[float, float], radius_norm: float, marker_radius_m: float) -> MarkerPose:
    """The paper's equations 7-8 on the normalized plane."""
    if radius_norm <= 0 or not math.isfinite(radius_norm):
        raise ValueError(f"marker image radius {radius_norm} must be positive")
    if marker_radius_m <= 0:
        raise ValueError(f"marker radius {marker_radius_m} m must be positive")
    z = marker_radius_m / radius_norm
    x, y = center_xy
    return MarkerPose(
        range_m=z,
        offset_x_m=x * z,
        offset_y_m=y * z,
        yaw_rad=math.atan(x),
        pitch_rad=math.atan(y),
    )


@dataclass(frozen=True)
class CircleSolution:
    """One of the two 3-D circles of known radius that project onto an ellipse."""

    center_m: np.ndarray  # (3,) in the camera optical frame
    normal: np.ndarray  # (3,) unit, pointing towards the camera


def circles_from_ellipse(ellipse: Ellipse, marker_radius_m: float) -> list[CircleSolution]:
    """Both 3-D circles of radius R whose perspective image is the given ellipse.

    The ellipse and the camera centre define an elliptic cone X^T C X = 0. With C's
    eigenvalues ordered l1 >= l2 > 0 > l3, the planes cutting the cone in circles have
    normals V [+-sqrt((l1-l2)/(l1-l3)), 0, sqrt((l2-l3)/(l1-l3))]. The circle centre
    projects to the pole of the plane's vanishing line, C^-1 n, and the known radius fixes
    the scale. The two solutions coincide for a ring seen head-on; otherwise a prior
    (the expected dock axis) or motion must choose between them.
    """
    conic = ellipse.conic()
    eigvals, eigvecs = np.linalg.eigh(conic)
    if np.sum(eigvals > 0) == 1:  # make two eigenvalues positive
        eigvals, conic = -eigvals, -conic
    order = np.argsort(eigvals)[::-1]
    l1, l2, l3 = eigvals[order]
    vecs = eigvecs[:, order]
    if not (l1 >= l2 > 0 > l3):
        return []
    conic_inv = np.linalg.inv(conic)
    samples = ellipse.points(12)
    solutions = []
    for sign in (1.0, -1.0):
        normal_local = np.array(
            [sign * math.sqrt((l1 - l2) / (l1 - l3)), 0.0, math.sqrt((l2 - l3) / (l1 - l3))]
        )
        normal = vecs @ normal_local
        if normal[2] > 0:  # point towards the camera (negative z)
            normal = -normal
        center_dir = conic_inv @ normal
        center_dir = center_dir / center_dir[2]
        # Plane n.X = -1 (a plane in front of the camera, unit distance), scale by radius.
        center_unit = center_dir * (-1.0 / float(normal @ center_dir))
        rays = np.column_stack([samples, np.ones(len(samples))])
        on_plane = rays * (-1.0 / (rays @ normal))[:, None]
        radius_unit = float(np.mean(np.linalg.norm(on_plane - center_unit, axis=1)))
        if not math.isfinite(radius_unit) or radius_unit <= 0:
            continue
        solutions.append(CircleSolution(center_m=center_unit * (marker_radius_m / radius_unit), normal=normal))
    return solutions


def pose_from_point(center_m: np.ndarray) -> MarkerPose:
    """Bearing and offsets of a 3-D marker centre in the optical frame."""
    x, y, z = (float(v) for v in center_m)
    return MarkerPose(range_m=z, offset_x_m=x, offset_y_m=y, yaw_rad=math.atan2(x, z), pitch_rad=math.atan2(y, z))


def ring_center_solution(
    centre_line: Ellipse,
    marker_radius_m: float,
    outer: Ellipse | None = None,
    inner: Ellipse | None = None,
    cue_noise: float = 0.0,
    led_points: np.ndarray | None = None,
    prior_margin_deg: float = 10.0,
) -> tuple[np.ndarray, np.ndarray | None] | None:
    """The ring's 3-D centre (and axis when it can be told) from its image.

    A tilted circle's image centre is displaced towards the ring's near side by an amount
    growing with the square of the circle's radius, so the outer outline's centre lies
    further towards the near side than the inner one's. When that cue is clear, the
    solution whose centre correction points away from the near side is returned with its
    axis. When it is not (no inner outline, a scalloped outline of discrete LEDs, a ring
    nearly head-on), the solution whose axis is nearer the optical axis is taken if the two
    differ in that by more than ``prior_margin_deg`` (a docking vehicle heads along the
    dock's axis); otherwise the midpoint of the two is returned without an axis: its error
    is half the worst case of a guess. ``cue_noise`` is the standard error of the
    outlines' centre offset (normalized units); the cue must stand 3 of them clear.
    For a ring of separate, evenly spaced LEDs, ``led_points`` (their image centres on the
    normalized plane) give a stronger cue: only on the true solution's plane are they
    evenly spaced around the centre.
    """
    solutions = circles_from_ellipse(centre_line, marker_radius_m)
    if not solutions:
        return None
    if len(solutions) == 1:
        return solutions[0].center_m, solutions[0].normal
    if led_points is not None and len(led_points) >= 8:
        irregularity = [_spacing_irregularity(sol, led_points) for sol in solutions]
        best = int(np.argmin(irregularity))
        if irregularity[best] < 0.6 * irregularity[1 - best]:
            return solutions[best].center_m, solutions[best].normal
    if outer is not None and inner is not None:
        # Each solution predicts the offset between the outlines' centres: its centre
        # correction, reversed, scaled by how much larger the outer circle is.
        ellipse_center = np.array([centre_line.center_x, centre_line.center_y])
        spread = (outer.semi_major**2 - inner.semi_major**2) / max(centre_line.semi_major**2, 1e-12)
        measured = np.array([outer.center_x - inner.center_x, outer.center_y - inner.center_y])
        predicted = [-(sol.center_m[:2] / sol.center_m[2] - ellipse_center) * spread for sol in solutions]
        misfit = [float(np.linalg.norm(measured - p)) for p in predicted]
        best = int(np.argmin(misfit))
        separation = float(np.linalg.norm(predicted[0] - predicted[1]))
        if misfit[best] <= 0.35 * separation and misfit[1 - best] - misfit[best] >= 3.0 * cue_noise:
            return solutions[best].center_m, solutions[best].normal
    # A docking vehicle heads along the dock's axis: the true axis is the one nearer the
    # optical axis, when the two differ clearly in that.
    off_axis = [math.acos(float(np.clip(-sol.normal[2], -1.0, 1.0))) for sol in solutions]
    if abs(off_axis[0] - off_axis[1]) > math.radians(prior_margin_deg):
        chosen = solutions[int(np.argmin(off_axis))]
        return chosen.center_m, chosen.normal
    return 0.5 * (solutions[0].center_m + solutions[1].center_m), None


def _spacing_irregularity(solution: CircleSolution, points: np.ndarray) -> float:
    """How far the LEDs, put back on the solution's plane, are from an even spacing.

    Consecutive gaps should all be whole multiples of one base gap (LEDs can be missing).
    """
    rays = np.column_stack([points, np.ones(len(points))])
    depth = float(solution.normal @ solution.center_m)
    on_plane = rays * (depth / (rays @ solution.normal))[:, None]
    rel = on_plane - solution.center_m
    e1 = rel[0] - (rel[0] @ solution.normal) * solution.normal
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(solution.normal, e1)
    angles = np.sort(np.arctan2(rel @ e2, rel @ e1))
    gaps = np.diff(np.concatenate([angles, angles[:1] + 2 * math.pi]))
    base = float(np.median(gaps))
    if base <= 0:
        return math.inf
    steps = gaps / base
    return float(np.sqrt(np.mean((steps - np.round(steps)) ** 2)))
