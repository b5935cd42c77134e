"""Circles in 3-D: the LED ring, the funnel's rim and hub, and their mirror images in the surface."""

from __future__ import annotations

import math

import numpy as np


def plane_basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit axes spanning the plane with this normal; every circle on the dock shares them."""
    normal = normal / np.linalg.norm(normal)
    helper = np.array([0.0, 1.0, 0.0]) if abs(normal[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = _cross(normal, helper)
    e1 /= np.linalg.norm(e1)
    return e1, _cross(normal, e1)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b for two 3-vectors (np.cross costs more than the rest of a ring for one pair)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def ring_points(center: np.ndarray, normal: np.ndarray, radius: float, count: int) -> np.ndarray:
    """Points on a 3-D circle, (count, 3), the first on the plane's first axis."""
    e1, e2 = plane_basis(normal)
    t = np.linspace(0.0, 2.0 * math.pi, count, endpoint=False)
    return center + radius * (np.outer(np.cos(t), e1) + np.outer(np.sin(t), e2))


def mirror_in_surface(points: np.ndarray, up: np.ndarray, height: float) -> np.ndarray:
    """Reflect points in the plane up . X = height (the water surface seen from below)."""
    up = up / np.linalg.norm(up)
    return points + 2.0 * (height - points @ up)[:, None] * up
