import math

import cv2
import numpy as np
import pytest

from auv_dock_guidance.geometry.pose import (
    Ellipse,
    circles_from_ellipse,
    pose_from_circle,
    ring_center_solution,
)
from auv_dock_guidance.sim.scene import ring_points


def test_paper_equations_7_and_8():
    # Marker 0.1 right and 0.05 below the axis on the normalized plane, image radius 0.035.
    pose = pose_from_circle((0.1, 0.05), 0.035, marker_radius_m=0.35)
    assert pose.range_m == pytest.approx(10.0)
    assert pose.offset_x_m == pytest.approx(1.0)
    assert pose.offset_y_m == pytest.approx(0.5)
    assert pose.yaw_deg == pytest.approx(math.degrees(math.atan(0.1)))
    assert pose.pitch_deg == pytest.approx(math.degrees(math.atan(0.05)))


def test_pose_rejects_non_positive_radius():
    with pytest.raises(ValueError):
        pose_from_circle((0.0, 0.0), 0.0, 0.35)
    with pytest.raises(ValueError):
        pose_from_circle((0.0, 0.0), 0.1, -0.35)


def _ellipse_of(points_cam: np.ndarray) -> Ellipse:
    xy = points_cam[:, :2] / points_cam[:, 2:3]
    (cx, cy), (d1, d2), angle = cv2.fitEllipse((xy * 1000).astype(np.float32))
    a = math.radians(angle) if d1 >= d2 else math.radians(angle + 90)
    return Ellipse(cx / 1000, cy / 1000, max(d1, d2) / 2000, min(d1, d2) / 2000, a)


@pytest.mark.parametrize(
    "center, normal",
    [((0.5, 0.3, 2.5), (0.2, 0.0, -1.0)), ((-0.3, 0.2, 3.0), (-0.1, 0.25, -1.0)), ((0.0, 0.0, 5.0), (0, 0, -1))],
)
def test_one_of_the_two_circle_solutions_is_the_true_ring(center, normal):
    c, n = np.array(center), np.array(normal, float) / np.linalg.norm(normal)
    ellipse = _ellipse_of(ring_points(c, n, 0.35, 720))
    solutions = circles_from_ellipse(ellipse, 0.35)
    assert len(solutions) == 2
    best = min(solutions, key=lambda s: np.linalg.norm(s.center_m - c))
    np.testing.assert_allclose(best.center_m, c, atol=2e-3)
    assert abs(abs(best.normal @ n) - 1.0) < 1e-4


def test_outer_and_inner_outlines_pick_the_true_solution():
    c, n = np.array([0.4, 0.2, 2.5]), np.array([0.3, 0.0, -1.0]) / np.hypot(0.3, 1.0)
    outer = _ellipse_of(ring_points(c, n, 0.365, 720))
    inner = _ellipse_of(ring_points(c, n, 0.335, 720))
    centre_line = _ellipse_of(ring_points(c, n, 0.35, 720))
    centre, axis = ring_center_solution(centre_line, 0.35, outer, inner)
    np.testing.assert_allclose(centre, c, atol=2e-3)
    assert axis is not None and axis @ n > 0.9999


def test_evenly_spaced_leds_pick_the_true_solution():
    c, n = np.array([-0.3, 0.1, 3.0]), np.array([-0.25, 0.1, -1.0]) / np.linalg.norm([-0.25, 0.1, -1.0])
    leds = ring_points(c, n, 0.35, 24)
    centre_line = _ellipse_of(ring_points(c, n, 0.35, 720))
    centre, axis = ring_center_solution(centre_line, 0.35, led_points=leds[:, :2] / leds[:, 2:3])
    np.testing.assert_allclose(centre, c, atol=2e-3)
    assert axis is not None


def test_without_a_cue_the_midpoint_is_returned_without_an_axis():
    c, n = np.array([0.0, 0.0, 2.5]), np.array([0.3, 0.0, -1.0]) / np.hypot(0.3, 1.0)
    centre_line = _ellipse_of(ring_points(c, n, 0.35, 720))
    centre, axis = ring_center_solution(centre_line, 0.35)
    assert axis is None
    solutions = circles_from_ellipse(centre_line, 0.35)
    np.testing.assert_allclose(centre, 0.5 * (solutions[0].center_m + solutions[1].center_m))
