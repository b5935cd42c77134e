import cv2
import numpy as np

from auv_dock_guidance.vision.config import DetectorConfig, lens_scale
from auv_dock_guidance.vision.search import search


def _frame_with_ring_and_lamp(camera):
    image = np.full((camera.height, camera.width, 3), 25, np.uint8)
    cv2.circle(image, (1200, 600), 120, (255, 200, 90), 10)
    cv2.circle(image, (300, 200), 8, (255, 255, 255), -1)
    return cv2.GaussianBlur(image, (5, 5), 0)


def test_search_finds_a_window_around_the_ring_and_one_around_the_lamp(camera):
    windows = search(_frame_with_ring_and_lamp(camera), DetectorConfig(), lens_scale(camera), 10.0)
    def holds(point):
        return any(x0 <= point[0] <= x1 and y0 <= point[1] <= y1 for (x0, y0, x1, y1), _ in windows)
    assert holds((1200 - 125, 600)) and holds((1200 + 125, 600))
    assert holds((300, 200))
    ring = [r for (x0, y0, x1, y1), r in windows if x0 <= 1075 and x1 >= 1325]
    assert any(100 < r < 160 for r in ring)


def test_search_in_empty_water_finds_nothing(camera):
    rng = np.random.default_rng(1)
    image = np.clip(rng.normal(30, 2, (camera.height, camera.width, 3)), 0, 255).astype(np.uint8)
    assert search(image, DetectorConfig(), lens_scale(camera), 10.0) == []
