"""Euler angles <-> quaternions (x, y, z, w) <-> rotation matrices, and the navigation <-> REP 103 attitude convention.

The navigation reports pitch positive nose up and yaw positive turning to starboard;
REP 103 (x forward, y left, z up) has both the other way round; roll is the same.
"""

from __future__ import annotations

import math

import numpy as np


def quaternion_from_euler(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def euler_from_quaternion(x: float, y: float, z: float, w: float) -> tuple[float, float, float]:
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def rep103_quaternion(roll: float, pitch_nav: float, yaw_nav: float) -> tuple[float, float, float, float]:
    """A navigation attitude as a REP 103 orientation."""
    return quaternion_from_euler(roll, -pitch_nav, -yaw_nav)


def navigation_attitude(x: float, y: float, z: float, w: float) -> tuple[float, float, float]:
    """(roll, pitch nose up +, yaw to starboard +) of a REP 103 orientation."""
    roll, pitch, yaw = euler_from_quaternion(x, y, z, w)
    return roll, -pitch, -yaw


def navigation_yaw_rate(rate_z: float, covariance_xx: float = 0.0) -> float:
    """The turn rate (to starboard +) of a REP 103 body rate about z (up), as an Imu message carries it;
    0 where the message says it reports none (covariance -1, REP 145) or it is not a number."""
    return -float(rate_z) if covariance_xx != -1.0 and math.isfinite(rate_z) else 0.0


def matrix_from_quaternion(x: float, y: float, z: float, w: float) -> np.ndarray:
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def quaternion_from_matrix(rotation: np.ndarray) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation matrix (Shepperd's method, stable for every rotation)."""
    m = rotation
    trace = float(np.trace(m))
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * math.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        v = [0.0, 0.0, 0.0]
        v[i], v[j], v[k] = 0.25 * s, (m[j, i] + m[i, j]) / s, (m[k, i] + m[i, k]) / s
        q = v[0], v[1], v[2], (m[k, j] - m[j, k]) / s
    norm = math.sqrt(sum(c * c for c in q))
    return tuple(float(c / norm) for c in q)  # type: ignore[return-value]
