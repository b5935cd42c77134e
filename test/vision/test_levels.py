import numpy as np
import pytest

from auv_dock_guidance.vision.levels import median_and_mad


@pytest.mark.parametrize("seed", range(20))
def test_median_and_mad_are_those_of_numpy(seed):
    rng = np.random.default_rng(seed)
    values = rng.integers(0, int(rng.integers(1, 256)), int(rng.integers(1, 400))).astype(np.uint8)
    median, mad = median_and_mad(values)
    assert median == np.median(values)
    assert mad == np.median(np.abs(values.astype(np.float64) - np.median(values)))
