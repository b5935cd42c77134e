import math

import numpy as np
import pytest

from auv_dock_guidance.vision.led_ring import assemble_rings
from auv_dock_guidance.vision.leds import LedBlob


def _blobs(points, radius=4.0, peak=100.0):
    return [LedBlob(float(x), float(y), radius, peak, 20.0) for x, y in points]


def _ring(count=8, center=(300.0, 250.0), a=(120.0, 0.0), b=(0.0, 90.0), phase=0.2, slots=None):
    angles = phase + 2 * math.pi * np.arange(count) / count
    points = np.array(center) + np.outer(np.cos(angles), a) + np.outer(np.sin(angles), b)
    return points if slots is None else points[list(slots)]


@pytest.mark.parametrize("count", [8, None])
def test_eight_leds_among_lit_corners_of_the_funnel_are_assembled(count):
    leds = _ring()
    corners = _ring(count=5, a=(80.0, 0.0), b=(0.0, 55.0), phase=0.9)  # inside the ring, dimmer
    points = np.concatenate([leds, corners])
    blobs = _blobs(leds) + _blobs(corners, peak=60.0)
    ring = assemble_rings(points, blobs, None, count)[0]
    assert sorted(ring.members) == list(range(8)) and ring.count == 8
    assert ring.center == pytest.approx((300.0, 250.0), abs=0.5)


def test_three_neighbouring_leds_of_a_known_count_fix_the_centre_outside_the_frame():
    points = _ring(center=(-60.0, 100.0), slots=(0, 1, 2))
    def in_view(xy):
        return xy[:, 0] >= 0

    rings = assemble_rings(points, _blobs(points), in_view, 8)
    assert rings and rings[0].center == pytest.approx((-60.0, 100.0), abs=0.5)
    assert rings[0].expected <= 4


def test_the_count_is_found_when_not_given():
    points = _ring(count=12, slots=range(12))
    ring = assemble_rings(points, _blobs(points), None, None)[0]
    assert ring.count == 12 and len(ring.members) == 12


def test_single_lights_pairs_and_scattered_lights_make_no_ring():
    rng = np.random.default_rng(4)
    scattered = rng.uniform(0, 600, (12, 2))
    assert assemble_rings(scattered, _blobs(scattered), None, 8) == []
    pair = _ring(slots=(0, 1))
    assert assemble_rings(pair, _blobs(pair), None, 8) == []


def test_a_ring_missing_leds_in_view_is_refused_when_too_few_are_there():
    points = _ring(slots=(0, 1, 2, 4, 6))  # 5 of 8, all slots in view
    assert assemble_rings(points, _blobs(points), None, 8) == []
