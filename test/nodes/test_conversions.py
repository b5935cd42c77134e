"""Navigation attitude to and from REP 103 Imu messages (no node, only the message types)."""

import math

import pytest

from auv_dock_guidance.control.cascade import Attitude
from auv_dock_guidance.nodes.conversions import attitude_to_imu, imu_to_attitude


def test_an_attitude_and_its_turn_rate_come_back_from_the_imu_message_they_were_sent_in():
    sent = Attitude(12.5, math.radians(3.0), math.radians(-10.0), math.radians(135.0), 4.0, math.radians(6.0))
    received = imu_to_attitude(attitude_to_imu(sent, (0.01, 0.02, sent.yaw_rate_rad_s), "base_link"), 4.0)
    assert received.stamp_s == pytest.approx(sent.stamp_s)
    for name in ("roll_rad", "pitch_rad", "yaw_rad", "yaw_rate_rad_s"):
        assert getattr(received, name) == pytest.approx(getattr(sent, name), abs=1e-9), name


@pytest.mark.parametrize("rate_z, covariance_xx", [(0.3, -1.0), (math.nan, 0.0)])
def test_an_imu_without_a_turn_rate_still_gives_a_valid_attitude_turning_at_zero(rate_z, covariance_xx):
    """An IMU that reports no rates (covariance -1, REP 145) or a NaN one: guidance keeps its attitude."""
    msg = attitude_to_imu(Attitude(3.0, 0.0, 0.0, math.radians(40.0), 2.0), (0.0, 0.0, 0.0), "base_link")
    msg.angular_velocity.z = rate_z
    msg.angular_velocity_covariance[0] = covariance_xx
    received = imu_to_attitude(msg, 2.0)
    assert received.is_valid() and received.yaw_rate_rad_s == 0.0
    assert received.yaw_rad == pytest.approx(math.radians(40.0))
