"""The refine stage on windows the search can hand it."""

import numpy as np
import pytest

from auv_dock_guidance.geometry.camera import paper_camera
from auv_dock_guidance.vision.config import DetectorConfig
from auv_dock_guidance.vision.refine import Refiner
from auv_dock_guidance.vision.threshold import AdaptiveThreshold


@pytest.mark.parametrize("box", [(0, 500, 3, 700), (900, 1078, 1200, 1080)], ids=["column", "row"])
def test_a_sliver_window_of_a_near_ring_is_no_region_not_a_crash(box):
    """A ring so near that the window is scaled down, cut to a few pixels by the frame's edge: scaled, the
    sliver was 0 px wide and cv2.resize raised (an open-water episode crashed on it)."""
    image = np.full((1080, 1920, 3), 40, np.uint8)
    image[:, :6] = 250
    refiner = Refiner(DetectorConfig(), AdaptiveThreshold(), paper_camera())
    assert refiner.refine(image, box, radius_estimate=900.0, rejected=[]) == []
