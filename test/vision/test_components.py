import cv2
import numpy as np
import pytest

from auv_dock_guidance.vision.components import components


@pytest.mark.parametrize("seed", range(20))
def test_components_are_those_of_opencv(seed):
    rng = np.random.default_rng(seed)
    shape = (int(rng.integers(1, 80)), int(rng.integers(1, 80)))
    mask = (rng.random(shape) < rng.random() * 0.6).astype(np.uint8) * int(rng.choice([1, 255]))
    count, labels, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    ours, our_stats, our_centroids = components(mask)
    assert np.array_equal(ours, labels) and len(our_stats) == count - 1
    assert our_stats.dtype == stats.dtype and np.array_equal(our_stats, stats[1:])
    assert np.array_equal(our_centroids, centroids[1:])  # to the bit


def test_components_of_an_empty_mask():
    labels, stats, centroids = components(np.zeros((4, 6), np.uint8))
    assert not labels.any() and stats.shape == (0, 5) and centroids.shape == (0, 2)
