"""Euler angles <-> quaternions (x, y, z, w), and the navigation <-> REP 103 attitude convention.

The navigation reports pitch positive nose up and yaw positive turning to starboard;
REP 103 (x forward, y left, z up) has both the other way round; roll is the same.
"""

from __future__ import annotations

import math


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
