import math

import numpy as np
import pytest

from auv_dock_guidance.geometry.pose import Ellipse
from auv_dock_guidance.vision.outline import (
    arc_degrees,
    circle_through,
    ellipse_through,
    longest_inner_run,
    on_border,
    radial_residual,
)


def test_ellipse_through_points_of_a_known_ellipse():
    truth = Ellipse(200.0, 150.0, 80.0, 40.0, math.radians(30))
    fitted = ellipse_through(truth.points(64))
    assert fitted.center_x == pytest.approx(200.0, abs=0.1)
    assert fitted.semi_major == pytest.approx(80.0, abs=0.2)
    assert fitted.semi_minor == pytest.approx(40.0, abs=0.2)
    assert math.cos(fitted.angle_rad - truth.angle_rad) ** 2 == pytest.approx(1.0, abs=1e-4)


def test_circle_through_a_short_arc_finds_its_centre():
    t = np.linspace(0.2, 1.4, 30)
    xy = np.column_stack([10 + 50 * np.cos(t), -5 + 50 * np.sin(t)])
    circle = circle_through(xy)
    assert (circle.center_x, circle.center_y, circle.semi_major) == pytest.approx((10, -5, 50), abs=1e-6)
    assert arc_degrees(xy) == pytest.approx(math.degrees(1.2), abs=0.5)


def test_radial_residual_is_zero_on_the_ellipse_and_grows_off_it():
    e = Ellipse(0.0, 0.0, 10.0, 5.0, 0.3)
    assert np.allclose(radial_residual(e, e.points(12)), 0.0, atol=1e-9)
    assert (radial_residual(e, e.points(12) * 1.2) > 0).all()


def test_the_longest_run_off_the_border_is_the_outer_arc_of_a_cut_strip():
    frame = (100, 100)
    outer = [(x, 0) for x in range(10, 90)] + [(99, y) for y in range(0, 40)]  # along the border
    arc = [(99 - i, 40 + i // 2) for i in range(2, 60)]  # inside: the longest stretch
    back = [(40, y) for y in range(70, 2, -20)]  # a shorter one, after a visit to the border
    outline = np.array(outer + arc + [(40, 99)] + back, dtype=np.float64)
    run = longest_inner_run(outline, frame)
    assert not on_border(run, frame).any()
    assert len(run) == len(arc)
