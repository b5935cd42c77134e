"""The failure modes of recorded pool footage, on synthetic frames that reproduce them (dock_frames.py)."""

import math

import numpy as np
import pytest
from dock_frames import PAL, Dock, render_dock, ring_center_px

from auv_dock_guidance.vision.detector import Detector, DetectorConfig


def _detect(dock: Dock, led_count: int | None = 8):
    return Detector(PAL, DetectorConfig(led_count=led_count)).detect(render_dock(dock))


def _bearing_error_deg(detection, dock: Dock) -> float:
    xy, _ = PAL.pixels_to_normalized(np.array([[detection.u, detection.v], ring_center_px(dock)]))
    a, b = np.append(xy[0], 1.0), np.append(xy[1], 1.0)
    return math.degrees(math.acos(min(1.0, float(a @ b / np.linalg.norm(a) / np.linalg.norm(b)))))


@pytest.mark.parametrize("led_count", [8, None])
def test_a_blooming_eight_led_ring_beside_a_bright_funnel_is_found_with_its_centre(led_count):
    dock = Dock(center_m=(0.3, 0.2, 2.0), normal=(0.3, -0.2, -1.0))
    detection = _detect(dock, led_count)
    assert detection.found and len(detection.leds) == 8 and detection.led_count == 8
    u, v = ring_center_px(dock)
    assert math.hypot(detection.u - u, detection.v - v) < 2.0
    assert detection.pose.range_m == pytest.approx(2.0, rel=0.02)
    assert detection.range_approximate and not detection.partial


@pytest.mark.parametrize("dock", [Dock(center_m=(-0.55, -0.25, 1.5), seed=2),
                                  Dock(center_m=(0.1, 0.45, 1.3), normal=(0.0, 0.2, -1.0), seed=4)])
def test_a_ring_the_frame_cuts_with_half_or_more_in_view_gives_its_true_centre_and_range(dock):
    detection = _detect(dock)
    assert detection.found and not detection.partial
    assert detection.visible_arc_deg < 360.0
    assert _bearing_error_deg(detection, dock) < 0.5
    assert detection.pose.range_m == pytest.approx(dock.center_m[2], rel=0.05)


@pytest.mark.parametrize("led_count", [9, None])
@pytest.mark.parametrize("range_m", [5.0, 7.0])
def test_leds_merged_with_a_funnel_brighter_than_the_sensor_takes_are_found_on_its_outline(led_count, range_m):
    """White saturated funnel, LEDs on its rim blooming into it: only their bumps on its outline show."""
    dock = Dock(center_m=(0.2, 0.1, range_m), normal=(0.2, -0.1, -1.0), led_count=9, led_bgr=(0.2, 1.0, 0.25),
                funnel_gain=3.0, rim_m=0.325, fixture=False)
    detection = _detect(dock, led_count)
    assert detection.found and len(detection.leds) == 9
    assert _bearing_error_deg(detection, dock) < 0.2
    assert detection.pose.range_m == pytest.approx(range_m, rel=0.08)  # bumps lie a little outside the LEDs


def test_a_corner_with_three_leds_gives_a_bearing_towards_the_rings_centre_outside_the_frame():
    dock = Dock(center_m=(-0.9, -0.4, 1.6), seed=5)
    assert ring_center_px(dock)[0] < 0  # the centre is out of view
    detection = _detect(dock)
    assert detection.found and detection.partial and len(detection.leds) == 3
    assert _bearing_error_deg(detection, dock) < 1.0


@pytest.mark.parametrize("lit", [(2,), (2, 3)])
def test_a_single_blooming_led_or_a_pair_is_not_taken_for_the_ring(lit):
    detection = _detect(Dock(center_m=(0.2, 0.1, 2.0), lit_leds=lit, funnel=False, seed=6))
    assert not detection.found


def test_a_ring_shaped_pool_fixture_is_not_the_ring():
    assert not _detect(Dock(center_m=None, seed=7)).found


def test_the_ring_is_chosen_over_its_reflection_in_the_surface_above():
    dock = Dock(center_m=(0.1, 0.5, 3.0), reflection_height_m=0.9, seed=8)
    detection = _detect(dock)
    u, v = ring_center_px(dock)
    assert detection.found and math.hypot(detection.u - u, detection.v - v) < 2.0
