"""Outlines on the normalized image plane, where a circle seen from any angle is an ellipse.

Without a camera model the pixel plane stands in for it (focal length 1).
"""

from __future__ import annotations

import math

import numpy as np

from auv_dock_guidance.geometry.camera import CameraModel
from auv_dock_guidance.geometry.pose import Ellipse
from auv_dock_guidance.vision.outline import (
    arc_degrees,
    circle_through,
    ellipse_through,
    longest_inner_run,
    on_border,
    radial_residual,
)


def undistorted(camera: CameraModel | None, points_px: np.ndarray, samples: int) -> np.ndarray:
    """About ``samples`` of the points on the normalized plane, in focal-length pixels."""
    points = points_px[:: max(1, len(points_px) // samples)]
    if camera is None:
        return points.astype(np.float64)
    xy, valid = camera.pixels_to_normalized(points)
    return xy[valid] * camera.focal_px


def outline_residual(camera: CameraModel | None, points_px: np.ndarray, frame_size: tuple[int, int],
                     samples: int = 96) -> float:
    """How far an outline is from an ellipse: rms radial distance / mean radius (0 when unknown).

    On the undistorted plane, where a circle seen from any angle is an ellipse (the lens
    bends a large ring near the frame's edge away from one). Points on the frame's
    border are left out, and of a strip the frame cuts open only its longer (outer) edge
    counts: a ring cut by the edge is still an ellipse.
    """
    points = undistorted(camera, longest_inner_run(points_px, frame_size), samples)
    if len(points) < 8:
        return 0.0
    ellipse = ellipse_through(points)
    if ellipse is None:
        return 0.0
    size = math.sqrt(ellipse.semi_major * ellipse.semi_minor)
    residual = radial_residual(ellipse, points.astype(np.float64)) / size
    return float(np.sqrt(np.mean(residual * residual)))


def cut_shape(camera: CameraModel | None, points_px: np.ndarray, frame_size: tuple[int, int],
              samples: int = 96) -> tuple[float, float]:
    """(axis ratio of its ellipse, degrees of a circle it covers) of the longest stretch of
    an outline off the frame's border: the shape of what the frame left of a ring."""
    points = undistorted(camera, longest_inner_run(points_px, frame_size), samples)
    if len(points) < 8:
        return 0.0, 0.0
    ellipse = ellipse_through(points)
    ratio = ellipse.semi_minor / ellipse.semi_major if ellipse is not None else 0.0
    return ratio, arc_degrees(points)


def normalized_points(camera: CameraModel | None, points_px: np.ndarray | None) -> np.ndarray | None:
    """Image points on the normalized plane (those that undistort validly)."""
    if points_px is None or camera is None:
        return None
    xy, valid = camera.pixels_to_normalized(points_px)
    return xy[valid]


def plane_points(camera: CameraModel | None, points_px: np.ndarray) -> np.ndarray:
    """Points on the plane `fit_ellipse` fits on: normalized with a camera, pixels without."""
    if camera is None:
        return points_px.astype(np.float64)
    xy, valid = camera.pixels_to_normalized(points_px)
    return xy[valid]


def center_pixels(camera: CameraModel | None, x: float, y: float) -> tuple[float, float, float]:
    """A normalized point as distorted image pixels, and the focal length used."""
    if camera is None:
        return x, y, 1.0
    uv = camera.normalized_to_pixels(np.array([x, y]))
    return float(uv[0]), float(uv[1]), camera.focal_px


def fit_ellipse(camera: CameraModel | None, points_px: np.ndarray | None,
                circle: bool = False) -> tuple[Ellipse, float] | None:
    """Ellipse through outline points on the normalized plane (pixel plane without a camera),
    and the standard error of its centre (normalized units).

    ``circle``: fit a circle instead, for an arc the frame cut; five ellipse parameters
    from half an outline wander (the radius, hence the range, by tens of percent).

    Outline errors are correlated along the outline (scallops of separate LEDs, pixel
    steps), so the points count as one independent sample per few pixels of outline.
    """
    if points_px is None:
        return None
    if camera is not None:
        inside = ~on_border(points_px, (camera.height, camera.width))
        xy, valid = camera.pixels_to_normalized(points_px[inside])
        xy = xy[valid]
        focal = camera.focal_px
    else:
        xy, focal = points_px.astype(float), 1.0
    if len(xy) < (5 if circle else 8):
        return None
    if circle:
        ellipse: Ellipse | None = circle_through(xy)
    else:
        fitted = ellipse_through(xy * focal)  # fitted in pixel units, where cv2's tolerances are set
        ellipse = None if fitted is None else Ellipse(
            fitted.center_x / focal, fitted.center_y / focal, fitted.semi_major / focal,
            fitted.semi_minor / focal, fitted.angle_rad)
    if ellipse is None or not (math.isfinite(ellipse.semi_major) and ellipse.semi_minor > 0):
        return None
    residual = radial_residual(ellipse, xy)
    rms = float(np.sqrt(np.mean(residual * residual)))
    independent = max(4.0, len(xy) / 8.0)
    return ellipse, rms * math.sqrt(2.0 / independent)
