import numpy as np
import pytest

from auv_dock_guidance.vision.levels import detrended_deviation, median_and_mad


@pytest.mark.parametrize("seed", range(20))
def test_median_and_mad_are_those_of_numpy(seed):
    rng = np.random.default_rng(seed)
    values = rng.integers(0, int(rng.integers(1, 256)), int(rng.integers(1, 400))).astype(np.uint8)
    median, mad = median_and_mad(values)
    assert median == np.median(values)
    assert mad == np.median(np.abs(values.astype(np.float64) - np.median(values)))


def test_light_falling_off_along_a_windows_border_is_not_noise_but_texture_is():
    rows = np.linspace(130, 78, 300)  # the water darkening down a near ring's window
    sides = [np.full(400, 130, np.uint8), np.full(400, 78, np.uint8), rows.astype(np.uint8), rows.astype(np.uint8)]
    assert detrended_deviation(sides) <= 0.5
    rng = np.random.default_rng(1)
    noisy = [np.clip(side + rng.normal(0, 4, len(side)), 0, 255).astype(np.uint8) for side in sides]
    assert 1.4826 * detrended_deviation(noisy) == pytest.approx(4.0, rel=0.15)
