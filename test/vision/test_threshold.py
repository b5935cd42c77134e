import itertools

import pytest

from auv_dock_guidance.errors import ConfigError
from auv_dock_guidance.vision.threshold import AdaptiveThreshold, ThresholdConfig


def test_far_small_marker_gets_a_lower_share_than_a_near_large_one():
    t = AdaptiveThreshold()
    far, reference, near = t.target_fraction(20), t.target_fraction(80), t.target_fraction(320)
    assert far < reference < near
    assert far >= t.config.fraction_far and near <= t.config.fraction_near


def test_share_moves_at_most_one_step_per_frame():
    t = AdaptiveThreshold(ThresholdConfig(max_step=0.05))
    t.update(80.0)
    start = t.fraction
    t.update(1000.0)  # suddenly huge
    assert t.fraction == pytest.approx(start + 0.05)


def test_lost_marker_lowers_the_share_step_by_step_down_to_the_far_share():
    t = AdaptiveThreshold()
    t.update(300.0)
    values = []
    for _ in range(30):
        t.update(None)
        values.append(t.fraction)
    assert all(b <= a for a, b in itertools.pairwise(values))
    assert values[-1] == pytest.approx(t.config.fraction_far)


def test_floor_keeps_the_threshold_above_noise():
    t = AdaptiveThreshold(ThresholdConfig(floor_grey=8, floor_noise_sigmas=5))
    assert t.level(background=50, peak=60, noise_sigma=3, fraction=0.2) == pytest.approx(65)
    assert t.level(background=50, peak=250, noise_sigma=1, fraction=0.5) == pytest.approx(150)


def test_floor_stands_above_the_brightest_side_of_a_window():
    """Light falling off across a window: the floor follows its bright side, the share its median."""
    t = AdaptiveThreshold(ThresholdConfig(floor_grey=8, floor_noise_sigmas=5))
    assert t.level(background=50, peak=90, noise_sigma=3, fraction=0.2, floor_above=80) == pytest.approx(95)
    assert t.level(background=50, peak=250, noise_sigma=3, fraction=0.5, floor_above=80) == pytest.approx(150)
    assert t.level(background=50, peak=60, noise_sigma=3, fraction=0.2, floor_above=40) == pytest.approx(65)


def test_inconsistent_shares_are_rejected():
    with pytest.raises(ConfigError, match="fraction_far"):
        ThresholdConfig(fraction_far=0.7, fraction_near=0.6)
