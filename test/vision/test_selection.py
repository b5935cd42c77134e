import pytest

from auv_dock_guidance.vision.selection import CandidateShape, SelectionConfig, choose, rejection_reason


def shape(area: float, v: float, hole: float = 0.8, radius: float = 50.0, axis: float = 1.0, edge: float = 1.0,
          contrast: float = 150.0, residual: float = 0.01):
    return CandidateShape(area, v, radius, axis, hole, edge, contrast, residual)


def test_largest_region_wins():
    assert choose([shape(1000, 500), shape(3000, 100)], SelectionConfig()) == 1


def test_lowest_of_equally_large_regions_wins_because_reflections_are_above():
    marker, reflection = shape(2900, 700), shape(3000, 200)
    assert choose([reflection, marker], SelectionConfig()) == 1


def test_a_ring_beats_a_larger_solid_lamp():
    lamp, ring = shape(9000, 800, hole=0.0), shape(3000, 300)
    assert choose([lamp, ring], SelectionConfig()) == 1


def test_a_much_dimmer_loop_is_light_the_water_made_not_the_leds():
    leds, caustic_loop = shape(3000, 300, contrast=160.0), shape(3000, 900, contrast=18.0)
    assert choose([leds, caustic_loop], SelectionConfig()) == 0  # lower and as large, but no LED


def test_a_reflection_nearly_as_bright_as_the_ring_still_meets_the_tie_rule():
    reflection, marker = shape(3000, 200, contrast=170.0), shape(2900, 700, contrast=120.0)
    assert choose([reflection, marker], SelectionConfig()) == 1


@pytest.mark.parametrize("contrast", [-5.0, float("nan")])
def test_regions_no_brighter_than_the_water_still_give_an_answer(contrast):
    assert choose([shape(1000, 500, contrast=contrast), shape(3000, 100, contrast=contrast)], SelectionConfig()) == 1


def test_nothing_to_choose_from():
    assert choose([], SelectionConfig()) is None


def test_gates_name_the_reason():
    config = SelectionConfig()
    assert "radius" in rejection_reason(shape(10, 0, radius=2.0), config, 0.0)
    assert "radius" in rejection_reason(shape(10, 0, radius=10.0), config, min_radius_px=15.0)
    assert "elongated" in rejection_reason(shape(10, 0, axis=0.1), config, 0.0)
    assert "outline" in rejection_reason(shape(10, 0, edge=0.1), config, 0.0)
    assert "not an ellipse (outline off by 12 %" in rejection_reason(shape(10, 0, residual=0.12), config, 0.0)
    assert rejection_reason(shape(10, 0), config, 0.0) is None
