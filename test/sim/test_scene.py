from dataclasses import replace

import cv2
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


def test_real_world_effects_show_where_they_should(camera):
    base = SceneSpec(marker_center_m=(0.0, 0.0, 5.0), brightness=3.0, attenuation_per_m=0.05, seed=4)
    plain, truth = render(camera, base)
    u, v = (int(round(c)) for c in truth.center_px)
    r = truth.radius_px
    angles = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    on_ring = (np.round(v + r * np.sin(angles)).astype(int), np.round(u + r * np.cos(angles)).astype(int))

    def grey(image):
        return image.max(axis=2).astype(float)

    dead, _ = render(camera, replace(base, dead_share=0.25))
    dark = grey(dead)[on_ring] < 0.5 * grey(plain)[on_ring]
    assert 0.15 < dark.mean() < 0.35  # about a quarter of the strip is dark
    glow, _ = render(camera, replace(base, funnel_glow=0.2))
    inside = np.s_[v - int(r / 2):v + int(r / 2), u - int(r / 2):u + int(r / 2)]
    assert grey(glow)[inside].mean() > grey(plain)[inside].mean() + 5  # the funnel inside the ring is lit
    vignetted, _ = render(camera, replace(base, vignetting=0.5))
    corner, middle = np.s_[:60, :60], np.s_[500:560, 400:460]
    assert grey(vignetted)[corner].mean() < 0.7 * grey(plain)[corner].mean()
    assert abs(grey(vignetted)[middle].mean() - grey(plain)[middle].mean()) < 0.2 * grey(plain)[middle].mean()
    for effect in (dict(caustics=0.1), dict(clutter=0.1)):  # light on the floor and walls, away from the ring
        busy, _ = render(camera, replace(base, **effect))
        added = cv2.blur(grey(busy), (9, 9)) - cv2.blur(grey(plain), (9, 9))  # structure, not pixel noise
        assert np.percentile(np.abs(added[700:, :600]), 99) > 5.0
    recorded, _ = render(camera, replace(base, jpeg_quality=60))
    assert 0 < np.abs(recorded.astype(int) - plain.astype(int)).mean() < 3  # JPEG loses a little, everywhere
