import math

import cv2
import numpy as np

from auv_dock_guidance.vision.segments import arc_ring, chains, dot_ring, dot_rings


def _dot(x: float, y: float, r: float = 4.0):
    t = np.linspace(0, 2 * math.pi, 16, endpoint=False)
    outline = np.column_stack([x + r * np.cos(t), y + r * np.sin(t)]).round().astype(np.int32)
    return outline, math.pi * r * r, 1.0


def _ring(cx, cy, radius, count, skip=()):
    return [_dot(cx + radius * math.cos(a), cy + 0.8 * radius * math.sin(a))
            for k, a in enumerate(np.linspace(0, 2 * math.pi, count, endpoint=False)) if k not in skip]


def test_leds_on_an_ellipse_make_a_ring_with_their_centres():
    ring = dot_ring(_ring(200, 150, 80, 12), min_dots=6)
    assert ring is not None and len(ring.members) == 12
    assert ring.axis_ratio == np.float64(ring.axis_ratio) and abs(ring.axis_ratio - 0.8) < 0.03
    assert abs(ring.center_row - 150) < 1.0


def test_a_few_leds_on_one_side_are_not_a_ring():
    assert dot_ring(_ring(200, 150, 80, 12, skip=range(5, 12)), min_dots=5) is None


def test_a_ring_and_a_far_lamp_cluster_chain_apart():
    dots = _ring(200, 150, 80, 12) + [_dot(900, 700 + 9 * k) for k in range(3)]
    groups = chains(dots)
    assert sorted(len(g) for g in groups) == [3, 12]
    assert len(dot_rings(dots)) == 1


def test_arcs_of_one_ring_are_fitted_as_one_ring():
    canvas = np.zeros((400, 400), np.uint8)
    for start in range(0, 360, 60):
        cv2.ellipse(canvas, (200, 200), (120, 100), 0, start, start + 45, 255, 6)
    contours, _ = cv2.findContours(canvas, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    dots = [(c[:, 0, :], cv2.contourArea(c), 1.0) for c in contours]
    ring = arc_ring(dots)
    assert ring is not None and ring.led_centers is None
    assert abs(ring.center_row - 200) < 2.0
