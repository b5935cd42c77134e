"""Parameters: declared with ranges, refused with a reason at start and at run time."""

import pytest
import rclpy
from geometry_msgs.msg import PointStamped
from rclpy.exceptions import InvalidParameterValueException
from rclpy.parameter import Parameter

from auv_dock_guidance.control.cascade import Attitude
from auv_dock_guidance.nodes.conversions import seconds_stamp
from auv_dock_guidance.nodes.detector import DetectorNode
from auv_dock_guidance.nodes.guidance import GuidanceNode


def test_detector_threshold_can_change_at_run_time_but_not_into_nonsense(ros):
    node = DetectorNode()
    try:
        ok = node.set_parameters([Parameter("threshold.fraction_near", value=0.5)])[0]
        assert ok.successful and node.detector.config.threshold.fraction_near == 0.5
        bad = node.set_parameters([Parameter("threshold.fraction_far", value=0.55)])[0]
        assert not bad.successful and "fraction_far" in bad.reason
        out_of_range = node.set_parameters([Parameter("marker_radius_m", value=-1.0)])[0]
        assert not out_of_range.successful
        nan = node.set_parameters([Parameter("threshold.floor_grey", value=float("nan"))])[0]
        assert not nan.successful and "nan" in nan.reason
    finally:
        node.destroy_node()


def test_guidance_gains_change_at_run_time(ros):
    node = GuidanceNode()
    try:
        assert node.set_parameters([Parameter("inner.kp", value=2.0)])[0].successful
        assert node.guidance.config.cascade.inner_yaw.kp == 2.0
        refused = node.set_parameters([Parameter("terminal_speed_mps", value=2.0)])[0]  # faster than cruise
        assert not refused.successful and "terminal_speed_mps" in refused.reason
    finally:
        node.destroy_node()


@pytest.mark.parametrize("value", ["-0.35", ".nan", ".inf"])
def test_out_of_range_or_non_finite_value_at_start_is_refused(domain_id, value):
    rclpy.init(domain_id=domain_id, args=["--ros-args", "-p", f"marker_radius_m:={value}"])
    try:
        with pytest.raises(InvalidParameterValueException, match="marker_radius_m out of range"):
            DetectorNode()
    finally:
        rclpy.try_shutdown()


def test_guidance_steers_the_vehicle_not_the_camera_onto_the_dock(domain_id):
    """A camera 0.3 m to starboard sees a dock dead ahead of the vehicle 0.3 m to its left."""
    rclpy.init(domain_id=domain_id, args=["--ros-args", "-p", "camera_mounting.y_m:=-0.3"])
    try:
        node = GuidanceNode()
        now = node.get_clock().now().nanoseconds * 1e-9
        node._attitude = Attitude(now, 0.0, 0.0, 0.0, 2.0)
        target = PointStamped()
        target.header.stamp = seconds_stamp(now)
        target.point.x, target.point.y, target.point.z = -0.3, 0.0, 6.0
        node._on_target(target)
        seen = node.guidance.last_target
        assert seen is not None
        assert (seen.range_m, seen.offset_x_m, seen.offset_y_m) == pytest.approx((6.0, 0.0, 0.0), abs=1e-9)
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
