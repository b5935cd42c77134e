"""Plane geometry of outlines and point sets: ellipses and circles through them, the frame's border."""

from __future__ import annotations

import math

import cv2
import numpy as np

from auv_dock_guidance.geometry.pose import Ellipse


def on_border(points: np.ndarray, frame_size: tuple[int, int]) -> np.ndarray:
    """Which full-resolution points lie on the frame's outermost pixels."""
    h, w = frame_size
    return (points[:, 0] <= 1.0) | (points[:, 0] >= w - 2.0) | (points[:, 1] <= 1.0) | (points[:, 1] >= h - 2.0)


def longest_inner_run(outline: np.ndarray, frame_size: tuple[int, int]) -> np.ndarray:
    """The longest stretch of a closed outline between visits to the frame's border.

    A strip the frame cuts is outlined by its outer edge, the border, its inner edge and
    the border again: two concentric arcs no single ellipse fits. The outer one is the
    longer. An outline that never touches the border is returned whole.
    """
    inside = ~on_border(outline, frame_size)
    if inside.all() or not inside.any():
        return outline[inside]
    start = int(np.argmin(inside))  # roll so the outline begins on the border: runs do not wrap
    rolled, flags = np.roll(outline, -start, axis=0), np.roll(inside, -start)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], flags.astype(np.int8), [0]))))
    starts, ends = edges[0::2], edges[1::2]
    longest = int(np.argmax(ends - starts))
    return rolled[starts[longest]:ends[longest]]


def ellipse_through(points: np.ndarray) -> Ellipse | None:
    """cv2.fitEllipse as an Ellipse (semi-axes, angle of the major axis); None when degenerate."""
    (cx, cy), (d1, d2), angle = cv2.fitEllipse(points.astype(np.float32))
    if not (min(d1, d2) > 0 and math.isfinite(d1 + d2)):
        return None
    return Ellipse(cx, cy, max(d1, d2) / 2.0, min(d1, d2) / 2.0,
                   math.radians(angle) if d1 >= d2 else math.radians(angle + 90.0))


def circle_through(xy: np.ndarray) -> Ellipse:
    """Least-squares circle (Kasa's algebraic fit) as an ellipse with equal axes."""
    a = np.column_stack([2.0 * xy, np.ones(len(xy))])
    b = (xy * xy).sum(axis=1)
    (cx, cy, c), *_ = np.linalg.lstsq(a, b, rcond=None)
    radius = math.sqrt(max(0.0, c + cx * cx + cy * cy))
    return Ellipse(float(cx), float(cy), radius, radius, 0.0)


def arc_degrees(xy: np.ndarray) -> float:
    """How much of its least-squares circle an open outline covers, in degrees."""
    circle = circle_through(xy)
    angles = np.sort(np.arctan2(xy[:, 1] - circle.center_y, xy[:, 0] - circle.center_x))
    gaps = np.diff(np.concatenate((angles, [angles[0] + 2.0 * math.pi])))
    return math.degrees(2.0 * math.pi - float(gaps.max()))


def radial_residual(ellipse: Ellipse, xy: np.ndarray) -> np.ndarray:
    """Approximate distance of points from an ellipse, in the ellipse's units."""
    c, s = math.cos(ellipse.angle_rad), math.sin(ellipse.angle_rad)
    rel = xy - (ellipse.center_x, ellipse.center_y)
    xr = (rel[:, 0] * c + rel[:, 1] * s) / ellipse.semi_major
    yr = (-rel[:, 0] * s + rel[:, 1] * c) / ellipse.semi_minor
    rho = np.hypot(xr, yr)
    return (rho - 1.0) * np.sqrt(ellipse.semi_major * ellipse.semi_minor)


def pixel_area(contour: np.ndarray) -> float:
    """Pixels inside an outline, counted so that a one-pixel blob has area 1, not 0."""
    return cv2.contourArea(contour) + 0.5 * cv2.arcLength(contour, True) + 1.0


def to_full(points: np.ndarray, scale: float, x0: int, y0: int) -> np.ndarray:
    """Window pixel indices at ``scale`` -> full-resolution pixel coordinates (pixel centres)."""
    pts = points.astype(np.float64)
    return (pts + 0.5) / scale - 0.5 + np.array([x0, y0], dtype=np.float64)
