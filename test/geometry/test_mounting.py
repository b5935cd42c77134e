"""The camera's mounting on the vehicle: base_link -> camera optical frame."""

import math

import numpy as np
import pytest

from auv_dock_guidance.errors import ConfigError
from auv_dock_guidance.geometry.mounting import CameraMounting
from auv_dock_guidance.geometry.rotations import matrix_from_quaternion, quaternion_from_euler


def test_a_nose_camera_looking_forward_changes_nothing():
    mounting = CameraMounting()
    assert mounting.target_about_vehicle(np.array([0.4, -0.2, 6.0])) == pytest.approx((6.0, 0.4, -0.2))
    # The fixed turn of every ROS camera driver: rpy (-90, 0, -90) deg, quaternion (0.5, -0.5, 0.5, -0.5).
    assert mounting.transform_quaternion() == pytest.approx((0.5, -0.5, 0.5, -0.5))
    assert "--roll -1.5708 --pitch 0 --yaw -1.5708 --frame-id base_link --child-frame-id camera_optical_frame" \
        in mounting.static_transform_command()


def test_an_offset_camera_sees_a_dock_ahead_of_the_vehicle_off_to_one_side():
    # 0.3 m to starboard and 0.1 m below the centre line: a dock dead ahead of the camera
    # is 0.3 m right of and 0.1 m below the vehicle's axis.
    mounting = CameraMounting(x_m=0.5, y_m=-0.3, z_m=-0.1)
    forward, right, down = mounting.target_about_vehicle(np.array([0.0, 0.0, 5.0]))
    assert (forward, right, down) == pytest.approx((5.0, 0.3, 0.1))


def test_a_camera_looking_down_sees_the_dock_below_the_vehicle_axis():
    mounting = CameraMounting(pitch_rad=math.radians(10.0))  # REP 103: positive pitch looks down
    forward, right, down = mounting.target_about_vehicle(np.array([0.0, 0.0, 5.0]))
    assert (forward, right, down) == pytest.approx((5.0 * math.cos(0.1745329), 0.0, 5.0 * math.sin(0.1745329)))
    point = mounting.optical_to_base(np.array([0.0, 0.0, 1.0]))
    assert point - mounting.translation_m == pytest.approx([math.cos(0.1745329), 0.0, -math.sin(0.1745329)])


def test_directions_turn_into_the_vehicles_axes_as_points_do():
    """The dock's axis and its position covariance are turned with the rotation that turns its position."""
    mounting = CameraMounting(x_m=0.5, y_m=-0.3, z_m=-0.1, roll_rad=0.1, pitch_rad=0.2, yaw_rad=-0.3)
    turn = mounting.vehicle_from_optical()
    point = np.array([0.4, -0.2, 6.0])
    origin = np.array(mounting.target_about_vehicle(np.zeros(3)))
    forward, right, down = np.array(mounting.target_about_vehicle(point)) - origin
    assert turn @ point == pytest.approx([right, down, forward])
    assert CameraMounting().vehicle_from_optical() == pytest.approx(np.eye(3))


def test_the_static_transform_is_the_mounting():
    mounting = CameraMounting(x_m=0.7, y_m=0.1, z_m=-0.2, roll_rad=0.05, pitch_rad=0.2, yaw_rad=-0.3)
    translation, rpy = mounting.transform_xyz_rpy()
    assert translation == pytest.approx((0.7, 0.1, -0.2))
    rotation = matrix_from_quaternion(*quaternion_from_euler(*rpy))  # as tf2 builds it from the command line
    assert rotation == pytest.approx(mounting.base_from_optical(), abs=1e-9)
    assert matrix_from_quaternion(*mounting.transform_quaternion()) == pytest.approx(rotation, abs=1e-9)


@pytest.mark.parametrize("changes", [{"x_m": math.nan}, {"parent_frame": ""}, {"optical_frame": "base_link"}])
def test_a_bad_mounting_is_refused_with_its_values(changes):
    with pytest.raises(ConfigError, match="camera mounting"):
        CameraMounting(**changes)
