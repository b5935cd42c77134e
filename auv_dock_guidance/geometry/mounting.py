"""Where the camera sits on the vehicle: base_link -> camera optical frame.

base_link is the vehicle's body frame (REP 103: x forward, y left, z up). The camera is
given as ROS describes a camera on a robot: the position of its optical centre in
base_link, and the orientation of its "camera link" (x along the view, y left, z up) as
roll, pitch and yaw about base_link's axes (REP 103 signs: pitch positive nose down, yaw
positive to the left). The optical frame (x right, y down, z forward) is that link turned
by the fixed (-90, 0, -90) deg every ROS camera driver uses.

Why guidance needs it: the detector measures the dock from the camera. A camera off the
vehicle's centre line (beside a sonar, under a fairing) sees a dock dead ahead of the
vehicle off to one side; centring the dock in that image would bring the camera, not the
vehicle, onto the dock's axis. ``target_about_vehicle`` re-expresses the dock as seen from
the point of the centre line level with the camera, looking along the vehicle's axis: for
a camera on the nose looking forward (the default) it changes nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from auv_dock_guidance.errors import ConfigError
from auv_dock_guidance.geometry.rotations import (
    euler_from_quaternion,
    matrix_from_quaternion,
    quaternion_from_euler,
    quaternion_from_matrix,
)

# Columns: the optical frame's axes (x right, y down, z forward) in the camera link (x forward, y left, z up).
LINK_FROM_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
# Rows: the vehicle's right, down and forward in base_link (x forward, y left, z up).
_VEHICLE_FROM_BASE = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])


@dataclass(frozen=True)
class CameraMounting:
    """The camera's optical centre in base_link (m) and its link's orientation (rad, REP 103)."""

    x_m: float = 0.9
    y_m: float = 0.0
    z_m: float = 0.0
    roll_rad: float = 0.0
    pitch_rad: float = 0.0
    yaw_rad: float = 0.0
    parent_frame: str = "base_link"
    optical_frame: str = "camera_optical_frame"

    def __post_init__(self) -> None:
        values = (self.x_m, self.y_m, self.z_m, self.roll_rad, self.pitch_rad, self.yaw_rad)
        if not all(math.isfinite(v) for v in values):
            raise ConfigError(f"camera mounting {values} must be finite numbers")
        if not self.parent_frame or not self.optical_frame or self.parent_frame == self.optical_frame:
            raise ConfigError(f"camera mounting frames {self.parent_frame!r} -> {self.optical_frame!r} must be two "
                              "different names")

    @property
    def translation_m(self) -> np.ndarray:
        return np.array([self.x_m, self.y_m, self.z_m])

    def base_from_optical(self) -> np.ndarray:
        """Rotation taking optical-frame vectors into base_link."""
        link = matrix_from_quaternion(*quaternion_from_euler(self.roll_rad, self.pitch_rad, self.yaw_rad))
        return link @ LINK_FROM_OPTICAL

    def optical_to_base(self, point_optical_m: np.ndarray) -> np.ndarray:
        return self.base_from_optical() @ np.asarray(point_optical_m, dtype=float) + self.translation_m

    def vehicle_from_optical(self) -> np.ndarray:
        """Rotation taking optical-frame vectors into the vehicle's own optical-like axes (right, down,
        forward): those of guidance's Target, whatever way the camera is mounted."""
        return _VEHICLE_FROM_BASE @ self.base_from_optical()

    def target_about_vehicle(self, point_optical_m: np.ndarray) -> tuple[float, float, float]:
        """(forward, right, down) of a point seen by the camera, from the point of the vehicle's
        centre line level with the camera: what guidance steers on."""
        base = self.optical_to_base(point_optical_m)
        return float(base[0] - self.x_m), float(-base[1]), float(-base[2])

    def transform_xyz_rpy(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """base_link -> optical frame as a static transform: translation (m) and roll, pitch,
        yaw (rad, fixed axes), as tf2's static_transform_publisher takes them."""
        rotation = self.base_from_optical()
        return (self.x_m, self.y_m, self.z_m), euler_from_quaternion(*quaternion_from_matrix(rotation))

    def transform_quaternion(self) -> tuple[float, float, float, float]:
        """The rotation of the static transform as (x, y, z, w)."""
        return quaternion_from_matrix(self.base_from_optical())

    def static_transform_command(self) -> str:
        """The command that publishes this mounting on a ROS install."""
        (x, y, z), (roll, pitch, yaw) = self.transform_xyz_rpy()
        return (f"ros2 run tf2_ros static_transform_publisher --x {x:.4g} --y {y:.4g} --z {z:.4g} "
                f"--roll {roll:.6g} --pitch {pitch:.6g} --yaw {yaw:.6g} "
                f"--frame-id {self.parent_frame} --child-frame-id {self.optical_frame}")
