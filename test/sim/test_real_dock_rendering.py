"""What real docks show on real video, rendered: blooming LEDs, a lit funnel, cut rings, walls, PAL video."""

from dataclasses import replace

import cv2
import numpy as np
import pytest

from auv_dock_guidance.geometry.camera import CameraModel
from auv_dock_guidance.sim.background import PoolWalls
from auv_dock_guidance.sim.dock_body import Funnel
from auv_dock_guidance.sim.glare import Glare
from auv_dock_guidance.sim.scenarios import dock_look
from auv_dock_guidance.sim.scene import SceneSpec, render
from auv_dock_guidance.sim.video import VideoRecording, record
from auv_dock_guidance.sim.world import PoolWorld, VehiclePose

# Half of a PAL frame, focal length for a 58 deg field of view: small renders keep the tests quick.
SMALL_PAL = CameraModel(360, 288, 325.0, 325.0, 179.5, 143.5)
BLUE_LED = (1.0, 0.18, 0.03)
BLOOMING = SceneSpec(marker_center_m=(0.0, 0.0, 2.0), marker_radius_m=0.4, led_count=8, led_bgr=BLUE_LED,
                     strip_width_m=0.02, brightness=800.0, attenuation_per_m=0.15, halo_fraction_per_m=0.0,
                     backscatter=0.2, ambient_top=0.15, ambient_bottom=0.1, water_bgr=(0.3, 0.9, 0.85),
                     led_psf_tail=0.3, led_psf_tail_rad=0.02, read_noise=0.0, shot_noise=0.0, seed=2)


def _first_led(truth):
    """The LED on the ring's first in-plane axis: for a frontal ring, straight right of the centre."""
    return int(round(truth.center_px[0] + truth.radius_px)), int(round(truth.center_px[1]))


def test_blooming_led_has_a_white_core_and_a_halo_of_its_colour_that_fades_into_the_water():
    image, truth = render(SMALL_PAL, BLOOMING)
    u, v = _first_led(truth)
    assert image[v, u].min() == 255  # every channel clips in the core: white
    ray = image[v, u:u + 40].astype(int)  # outwards, away from the ring
    halo = ray[(ray[:, 0] == 255) & (ray[:, 2] < 200)]  # blue clipped, red not: a blue halo
    assert len(halo) >= 4  # several pixels wide
    assert ray[-1, 0] < 200  # and it fades into the water
    assert np.all(np.diff(ray.sum(axis=1)) <= 3)  # falling all the way: no seam where the tail's parts meet


def test_halos_grow_with_the_led_brightness_and_merge_between_close_leds():
    def halo_width(spec):
        image, truth = render(SMALL_PAL, spec)
        u, v = _first_led(truth)
        return int((image[v, u:u + 60, 0] == 255).sum())

    assert halo_width(replace(BLOOMING, brightness=3000.0)) > halo_width(BLOOMING) > halo_width(
        replace(BLOOMING, brightness=200.0))
    twelve, truth = render(SMALL_PAL, replace(BLOOMING, led_count=12, brightness=3000.0))
    angles = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    u0, v0 = truth.center_px
    ring = twelve[np.round(v0 + truth.radius_px * np.sin(angles)).astype(int),
                  np.round(u0 + truth.radius_px * np.cos(angles)).astype(int)]
    assert ring[:, 0].min() == 255  # blue saturated all the way round: the halos merged into a ring


def test_glare_tail_holds_its_share_of_the_light():
    light = np.zeros((800, 800), np.float32)
    glare = Glare(light.shape, tail_share=0.2, tail_px=6.0, max_radius_px=400.0)
    glare.add(light, 400.3, 399.6, flux=5e5)
    glare.finish(light)
    # What lies beyond 400 px (about tail_px / 400 of it) and below a fraction of a grey level is left out.
    assert light.sum() == pytest.approx(0.2 * 5e5, rel=0.05)
    ys, xs = np.nonzero(light > 0)
    weights = light[ys, xs]
    assert np.average(xs, weights=weights) == pytest.approx(400.3, abs=0.1)  # centred where the light is
    assert np.average(ys, weights=weights) == pytest.approx(399.6, abs=0.1)


def test_lamps_bloom_like_leds_when_the_camera_has_glare():
    from auv_dock_guidance.sim.scene import Lamp

    lamp = Lamp(120.0, 100.0, 2.0, 300.0)
    plain, _ = render(SMALL_PAL, replace(BLOOMING, marker_center_m=None, lamps=(lamp,), led_psf_tail=0.0))
    glowing, _ = render(SMALL_PAL, replace(BLOOMING, marker_center_m=None, lamps=(lamp,)))
    assert (glowing[100, 100:140, 0] == 255).sum() > (plain[100, 100:140, 0] == 255).sum() + 4


def test_lit_funnel_is_bright_with_dark_vanes_and_hub_and_hides_the_wall():
    funnel = Funnel(brightness=2.0, shading=0.0, vanes=3, vane_angle_rad=0.0, hub_share=0.25, depth_share=0.0)
    walls = PoolWalls(tile_contrast=0.2, stain_contrast=0.0, fixtures=0)
    image, truth = render(SMALL_PAL, replace(BLOOMING, funnel=funnel, walls=walls))
    bare, _ = render(SMALL_PAL, replace(BLOOMING, walls=walls))
    u, v = (int(round(c)) for c in truth.center_px)
    rim = 0.9 * truth.radius_px
    grey = image.min(axis=2).astype(int)
    assert grey[v, u] < 80  # the hub is dark
    lit = grey[v - int(0.6 * rim), u]  # straight up: between the vanes at 0, 120 and 240 deg
    assert lit == 255  # as bright as the LEDs' cores
    vane = grey[v, u + int(0.6 * rim)]  # the first vane points along the ring's first axis: right
    assert vane < lit - 100
    inside = np.s_[v - int(0.5 * rim):v - int(0.3 * rim), u - 5:u + 5]
    assert image[inside].std() < 0.5 * bare[inside].std()  # the funnel hides the tiles behind it


def test_tilted_funnel_shows_its_hub_off_the_ring_centre():
    funnel = Funnel(brightness=2.0, shading=0.0, vanes=0, hub_share=0.2, depth_share=1.0)
    spec = replace(BLOOMING, funnel=funnel, marker_normal=(0.5, 0.0, -1.0), brightness=50.0)
    image, truth = render(SMALL_PAL, spec)
    u, v = truth.center_px
    dark = image.max(axis=2) < 120
    ys, xs = np.nonzero(dark[int(v) - 40:int(v) + 40, int(u) - 60:int(u) + 60])
    assert abs(xs.mean() - 60 - (u - int(u))) > 3  # the deep hub shifts sideways in a tilted view
    assert abs(ys.mean() - 40) < 3


@pytest.mark.parametrize(("centre", "view", "share"), [
    ((0.0, 0.0, 2.0), "whole", (1.0, 1.0)),
    ((1.1, 0.0, 2.0), "cut", (0.5, 0.6)),  # centre just inside the right edge
    ((1.2, -0.9, 2.0), "corner", (0.1, 0.35)),  # beyond the top right corner
    ((3.0, 0.0, 2.0), "none", (0.0, 0.0)),
])
def test_ground_truth_tells_whole_cut_and_corner_views_apart(centre, view, share):
    _, truth = render(SMALL_PAL, replace(BLOOMING, marker_center_m=centre))
    assert truth.view == view
    assert share[0] <= truth.share_in_view <= share[1]
    if view == "none":
        assert truth.center_px is None
        return
    x, y, z = centre
    assert truth.center_px == pytest.approx((179.5 + 325.0 * x / z, 143.5 + 325.0 * y / z))  # also off the frame
    assert truth.radius_px == pytest.approx(325.0 * 0.4 / 2.0)
    assert abs(truth.leds_in_view - 8 * truth.share_in_view) <= 1


def test_blanking_columns_are_black_and_out_of_view():
    video = VideoRecording(chroma_blur_px=0.0, letterbox_px=10, quality=0)
    spec = replace(BLOOMING, marker_center_m=(-0.75, 0.0, 2.0))
    image, truth = render(SMALL_PAL, replace(spec, video=video))
    _, without = render(SMALL_PAL, spec)
    assert image[:, :10].max() <= 2
    assert truth.share_in_view < without.share_in_view


def test_video_chain_bleeds_colour_combs_moving_edges_and_blocks_at_low_quality():
    frame = np.full((64, 96, 3), 60, np.uint8)
    frame[:, 48:] = (230, 60, 30)  # a blue area beside a grey one
    bled = record(frame, VideoRecording(chroma_blur_px=3.0, quality=0))
    luma = cv2.cvtColor(bled, cv2.COLOR_BGR2YCrCb)
    orig = cv2.cvtColor(frame, cv2.COLOR_BGR2YCrCb)
    assert np.abs(luma[32, :, 0].astype(int) - orig[32, :, 0]).max() < 25  # brightness stays sharp...
    cb = luma[32, :, 2].astype(int)
    assert ((cb > orig[32, 0, 2] + 5) & (cb < orig[32, 90, 2] - 5)).sum() >= 6  # ...colour spreads over pixels
    combed = record(frame, VideoRecording(chroma_blur_px=0.0, interlace_px=3.0, quality=0))
    assert combed[0, 48, 0] != combed[1, 48, 0]  # the odd field lags the even one at the edge
    assert np.array_equal(combed[0::2], frame[0::2])
    rng = np.random.default_rng(0)
    texture = cv2.GaussianBlur(rng.uniform(0, 255, (64, 96, 3)).astype(np.uint8), (0, 0), 2.0)
    blocky = record(texture, VideoRecording(chroma_blur_px=0.0, quality=15)).astype(float).mean(axis=2)
    steps = np.abs(np.diff(blocky, axis=1)).mean(axis=0)
    assert steps[7::8].mean() > 1.3 * np.delete(steps, np.s_[7::8]).mean()  # 8x8 block edges show


def test_walls_show_tiles_and_fixtures_and_haze_takes_their_contrast():
    base = replace(BLOOMING, marker_center_m=None, read_noise=0.0, shot_noise=0.0)
    plain, _ = render(SMALL_PAL, base)
    walls = PoolWalls(tile_contrast=0.08, stain_contrast=0.05, fixtures=2, fixture_contrast=0.1, cables=1)
    tiled, _ = render(SMALL_PAL, replace(base, walls=walls))
    hazy, _ = render(SMALL_PAL, replace(base, walls=replace(walls, haze=0.7)))

    def contrast(image):
        return float(image.astype(float).mean(axis=2).std())

    assert contrast(tiled) > 2 * contrast(plain)
    assert contrast(plain) < contrast(hazy) < 0.7 * contrast(tiled)


def test_dock_look_draws_blooming_led_docks_and_strips_that_the_pool_world_renders():
    rng = np.random.default_rng(4)
    looks = [dock_look(rng) for _ in range(40)]
    discrete = [s for s in looks if s.led_count > 0]
    assert discrete and len(discrete) < len(looks)
    assert all(6 <= s.led_count <= 12 and s.led_psf_tail > 0 and s.funnel is not None for s in discrete)
    assert any(s.funnel is not None for s in looks if s.led_count == 0)
    assert dock_look(np.random.default_rng(9)) == dock_look(np.random.default_rng(9))
    world = PoolWorld(scene=discrete[0])
    scene = world.scene_for(VehiclePose(x=world.dock_x_m - 4.0, y=0.2, z=-world.dock_depth_m), seed=3)
    image, truth = render(SMALL_PAL, scene)
    assert truth.view == "whole" and truth.leds_in_view == scene.led_count
    u, v = (int(round(c)) for c in truth.center_px)
    assert image[v - 3:v + 4, u - 3:u + 4].mean() != pytest.approx(image[5:12, 5:12].mean(), abs=3)
