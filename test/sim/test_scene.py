import numpy as np

from auv_dock_guidance.sim.scenarios import ScenarioMix, random_scene
from auv_dock_guidance.sim.scene import SceneSpec, render


def test_render_is_deterministic_for_a_spec(camera):
    spec = SceneSpec(marker_center_m=(0.2, 0.1, 6.0), seed=5)
    a, _ = render(camera, spec)
    b, _ = render(camera, spec)
    assert np.array_equal(a, b)


def test_ground_truth_is_where_the_ring_is_brightest(camera):
    image, truth = render(camera, SceneSpec(marker_center_m=(0.5, -0.3, 5.0), read_noise=0.0, shot_noise=0.0))
    u, v = truth.center_px
    r = truth.radius_px
    gray = image.max(axis=2).astype(float)
    ring_top = gray[int(v - r), int(u)]
    centre = gray[int(v), int(u)]
    far_away = gray[int(v), int(u + 3 * r)]
    assert ring_top > centre + 40 and ring_top > far_away + 40
    assert truth.radius_px == camera.focal_px * 0.35 / 5.0


def test_reflection_appears_above_the_marker(camera):
    spec = SceneSpec(marker_center_m=(0.0, 0.5, 10.0), surface_height_m=1.0, read_noise=0, shot_noise=0)
    image, truth = render(camera, spec)
    assert truth.reflection_center_px[1] < truth.center_px[1]
    ru, rv = (int(x) for x in truth.reflection_center_px)
    rr = int(truth.radius_px)
    assert image[max(0, rv - rr - 3): rv - rr + 4, ru - 3: ru + 4].max() > image[5, 5].max() + 20


def test_empty_scene_has_no_marker(camera):
    rng = np.random.default_rng(1)
    spec = random_scene(camera, rng, kind="empty")
    _, truth = render(camera, spec)
    assert not truth.marker_visible and truth.center_px is None


def test_population_mixes_every_kind(camera):
    rng = np.random.default_rng(2)
    specs = [random_scene(camera, rng, ScenarioMix()) for _ in range(80)]
    assert any(s.marker_center_m is None for s in specs)
    assert any(s.surface_height_m is not None for s in specs)
    assert any(s.lamps and s.marker_center_m is not None for s in specs)
    assert any(s.led_count > 0 for s in specs) and any(s.led_count == 0 for s in specs)
