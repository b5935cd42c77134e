import math

import cv2
import numpy as np
import pytest

from auv_dock_guidance.errors import ConfigError, ImageInputError
from auv_dock_guidance.geometry.camera import paper_camera
from auv_dock_guidance.geometry.uncertainty import dock_pose, observation_of
from auv_dock_guidance.sim.closed_loop import EpisodeConfig, episode_world
from auv_dock_guidance.sim.evaluate import judge, population, run_frames, summarize
from auv_dock_guidance.sim.scenarios import ScenarioMix
from auv_dock_guidance.sim.scene import Lamp, SceneSpec, render
from auv_dock_guidance.sim.world import VehiclePose
from auv_dock_guidance.vision.detector import Detector, DetectorConfig


def _detect(camera, spec, detector=None):
    image, truth = render(camera, spec)
    detection = (detector or Detector(camera)).detect(image)
    return detection, truth


@pytest.mark.parametrize("range_m", [2.5, 5.0, 9.0, 15.0])
@pytest.mark.parametrize("led_count", [0, 32])
def test_marker_found_with_accurate_centre_and_range(camera, range_m, led_count):
    spec = SceneSpec(marker_center_m=(0.4, -0.2, range_m), led_count=led_count, brightness=3.0,
                     attenuation_per_m=0.08, seed=3)
    detection, truth = _detect(camera, spec)
    assert detection.found, detection.reason
    assert math.hypot(detection.u - truth.center_px[0], detection.v - truth.center_px[1]) < 2.0
    assert detection.pose.range_m == pytest.approx(range_m, rel=0.03)
    assert detection.pose.yaw_deg == pytest.approx(math.degrees(math.atan2(0.4, range_m)), abs=0.1)
    assert detection.is_ring


def test_tilted_ring_at_close_range_is_centred_better_than_the_papers_circle(camera):
    spec = SceneSpec(marker_center_m=(0.5, 0.3, 2.5), marker_normal=(0.3, 0.0, -1.0), brightness=3.0, seed=4)
    detection, truth = _detect(camera, spec)
    ours = math.hypot(detection.u - truth.center_px[0], detection.v - truth.center_px[1])
    paper = math.hypot(detection.mec_u - truth.center_px[0], detection.mec_v - truth.center_px[1])
    assert ours < 1.5 and paper > 4.0
    assert detection.ring_normal is not None


def test_surface_reflection_of_similar_size_above_is_not_chosen(camera):
    spec = SceneSpec(marker_center_m=(0.0, 0.8, 8.0), surface_height_m=1.2, reflection_gain=1.0, seed=6)
    detection, truth = _detect(camera, spec)
    assert detection.found
    assert abs(detection.v - truth.center_px[1]) < 3.0
    assert detection.v > truth.reflection_center_px[1] + 100


def test_bright_lamps_do_not_win_over_the_ring(camera):
    lamps = (Lamp(300, 300, 9, 4.0), Lamp(1600, 900, 6, 4.0), Lamp(900, 950, 3, 2.0))
    spec = SceneSpec(marker_center_m=(0.3, 0.0, 12.0), lamps=lamps, seed=7)
    detection, truth = _detect(camera, spec)
    assert detection.found
    assert math.hypot(detection.u - truth.center_px[0], detection.v - truth.center_px[1]) < 2.0


def test_empty_water_and_glints_give_no_detection(camera):
    glints = tuple(Lamp(100 + 170 * i, 80 + 90 * i, 1.5, 1.0) for i in range(10))
    detection, _ = _detect(camera, SceneSpec(marker_center_m=None, lamps=glints, seed=8))
    assert not detection.found
    assert detection.reason


def test_marker_cut_by_the_frame_edge_is_still_centred(camera):
    # Centre ~100 px from the right edge, ring radius ~200 px there: part of it is out of view.
    spec = SceneSpec(marker_center_m=(1.3, 0.0, 2.5), brightness=3.0, seed=9)
    detection, truth = _detect(camera, spec)
    assert truth.center_px[0] + truth.radius_px > camera.width
    assert detection.found
    assert math.hypot(detection.u - truth.center_px[0], detection.v - truth.center_px[1]) < 5.0


@pytest.mark.parametrize("led_count", [0, 32])
@pytest.mark.parametrize("edge_px", [(1910.0, 540.0), (960.0, 8.0)])
def test_a_ring_half_out_of_the_frame_still_gives_its_bearing(camera, led_count, edge_px):
    # Centre on the frame's edge: half the ring is out of view, and what is left is open.
    xy, _ = camera.pixels_to_normalized(np.array([edge_px]))
    spec = SceneSpec(marker_center_m=(8.0 * xy[0, 0], 8.0 * xy[0, 1], 8.0), marker_normal=(0.3, 0.0, -1.0),
                     led_count=led_count, brightness=3.0, attenuation_per_m=0.08, seed=5)
    detection, _ = _detect(camera, spec)
    assert detection.found, detection.reason
    # Half a ring of separate LEDs bears 0.2-0.9 deg off over noise draws (12 seeds), a strip 0.1-0.3.
    tolerance = math.radians(1.0 if led_count else 0.3)
    assert detection.pose.yaw_rad == pytest.approx(math.atan(xy[0, 0]), abs=tolerance)
    assert detection.pose.pitch_rad == pytest.approx(math.atan(xy[0, 1]), abs=tolerance)
    assert detection.pose.range_m == pytest.approx(8.0, rel=0.5)


@pytest.mark.parametrize("ends", [((1600, 1079), (1919, 900)), ((0, 200), (300, 0)), ((1919, 500), (1750, 560))])
def test_a_streak_the_frame_cuts_is_not_taken_for_a_cut_ring(camera, ends):
    image = np.full((camera.height, camera.width, 3), 20, np.uint8)
    cv2.line(image, *ends, (255, 255, 255), 14)
    detection = Detector(camera).detect(cv2.GaussianBlur(image, (5, 5), 0))
    assert not detection.found
    assert "open arc" in detection.reason or "elongated" in detection.reason


def test_threshold_state_carries_over_a_sequence(camera):
    detector = Detector(camera)
    assert detector.threshold.fraction is None
    _detect(camera, SceneSpec(marker_center_m=(0.0, 0.0, 3.0), seed=1), detector)
    near_share = detector.threshold.fraction
    for _ in range(3):
        _detect(camera, SceneSpec(marker_center_m=None, seed=2), detector)
    assert detector.threshold.fraction < near_share
    detector.reset()
    assert detector.threshold.fraction is None


def test_grayscale_and_four_channel_images_are_accepted(camera):
    image, truth = render(camera, SceneSpec(marker_center_m=(0.0, 0.0, 6.0), seed=1))
    gray = image.max(axis=2)
    bgra = np.dstack([image, np.full(image.shape[:2], 255, np.uint8)])
    for variant in (gray, bgra, image.astype(np.uint16) * 257):
        detection = Detector(camera).detect(variant)
        assert detection.found
        assert abs(detection.u - truth.center_px[0]) < 2.0


@pytest.mark.parametrize(
    "image, message",
    [
        (np.zeros((0, 0, 3), np.uint8), "empty"),
        (np.zeros((1080, 1920, 3), np.float32), "pixel type"),
        (np.zeros((1080, 1920, 2), np.uint8), "2 channels"),
    ],
)
def test_unusable_images_are_refused_with_a_reason(camera, image, message):
    with pytest.raises(ImageInputError, match=message):
        Detector(camera).detect(image)


def test_image_size_must_match_the_camera(camera):
    with pytest.raises(ConfigError, match="640x480"):
        Detector(camera).detect(np.zeros((480, 640, 3), np.uint8))


def test_bad_detector_configuration_is_refused():
    with pytest.raises(ConfigError, match="marker_radius_m"):
        DetectorConfig(marker_radius_m=-0.35)


def test_population_meets_the_foundation_targets(camera):
    """A small slice of `auv-dock evaluate` on the plain population the targets were set on."""
    specs = population(camera, 40, seed=21, mix=ScenarioMix(real_world=False))
    report = summarize(run_frames(camera, DetectorConfig(), specs))
    assert report["false_positives"] == 0
    assert report["reflection_chosen"] == 0
    assert report["detection_rate"] >= 0.9
    assert report["yaw_error_deg_p95"] < 0.3
    assert report["range_error_rel_p95"] < 0.05


def test_real_world_effects_rarely_make_another_light_win(camera):
    """Uneven and dead LEDs, funnel glow, structure, caustics, particles, vignetting, JPEG."""
    specs = population(camera, 40, seed=21, mix=ScenarioMix(real_world=True))
    report = summarize(run_frames(camera, DetectorConfig(), specs))
    assert report["detection_rate"] >= 0.85
    assert report["false_positives"] == 0
    assert report["wrong_object"] <= 2  # measured: 2 of these 34 (the detector before the real-world rules: 3)
    assert report["range_error_rel_p95"] < 0.05


@pytest.mark.parametrize("seed", [2, 3])
def test_arcs_of_a_ring_with_dead_leds_are_fitted_as_one_ring(camera, seed):
    spec = SceneSpec(marker_center_m=(0.2, 0.5, 6.0), brightness=3.0, attenuation_per_m=0.08, dead_share=0.1,
                     led_spread=0.3, surface_height_m=1.5, reflection_gain=0.9, seed=seed)
    detection, truth = _detect(camera, spec)
    assert detection.found and detection.is_ring
    assert math.hypot(detection.u - truth.center_px[0], detection.v - truth.center_px[1]) < 1.5


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_ring_is_found_among_caustics_that_touch_it(camera, seed):
    spec = SceneSpec(marker_center_m=(0.5, 0.3, 10.0), caustics=0.1, brightness=2.0, seed=seed)
    detection, truth = _detect(camera, spec)
    assert detection.found
    assert math.hypot(detection.u - truth.center_px[0], detection.v - truth.center_px[1]) < 1.0


def test_a_close_ring_broken_by_dim_leds_beats_its_intact_reflection(camera):
    """Ring and reflection almost touch. Over 16 noise draws 14 were centred within 2 px, one
    was 9.5 px off where their halos merged, one chose the reflection; of these 8 draws, 7
    within 2 px and the 9.5 px one."""
    errors = []
    for seed in range(8):
        spec = SceneSpec(marker_center_m=(0.1, 0.03, 4.2), brightness=7.0, attenuation_per_m=0.19, dead_share=0.08,
                         led_spread=0.24, surface_height_m=0.42, reflection_gain=0.53, seed=seed)
        detection, truth = _detect(camera, spec)
        assert detection.found
        errors.append(math.hypot(detection.u - truth.center_px[0], detection.v - truth.center_px[1]))
    assert max(errors) < 0.2 * truth.radius_px, errors  # never the reflection, which lies two radii above
    assert sum(e < 2.0 for e in errors) >= 7, errors


def test_judge_flags_a_detection_on_the_reflection(camera):
    spec = SceneSpec(marker_center_m=(0.0, 0.8, 8.0), surface_height_m=1.2, seed=6)
    _, truth = render(camera, spec)
    from auv_dock_guidance.vision.detector import Detection

    on_reflection = Detection(found=True, u=truth.reflection_center_px[0], v=truth.reflection_center_px[1])
    outcome = judge(on_reflection, truth, "reflection")
    assert outcome.chose_reflection and not outcome.correct


def test_the_threshold_follows_the_range_whatever_the_lens(camera):
    """A near ring gets the near share through a short lens too (its pixel radius is a third)."""
    spec = SceneSpec(marker_center_m=(0.1, 0.1, 3.0), brightness=3.0, seed=1)
    shares = []
    for lens in (camera, camera.scaled(1 / 3)):
        detector = Detector(lens)
        frame, _ = render(lens, spec)
        for _ in range(8):  # the share moves one step a frame
            assert detector.detect(frame).found
        shares.append(detector.threshold.fraction)
    assert shares[1] == pytest.approx(shares[0], abs=0.02)



LOOP_CAMERA = paper_camera().scaled(0.5)  # the closed loop's camera (960x540)


def _open_water_world(seed):
    """The dock, water and light of closed-loop open-water episode ``seed``."""
    return episode_world(EpisodeConfig(scenario="open-water"), np.random.default_rng(seed))


def _facing_the_dock(world, distance_m, off_axis_deg=0.0, turned_deg=0.0):
    """The vehicle ``distance_m`` out from the dock's centre on a line ``off_axis_deg`` off its axis,
    the nose along that line turned by ``turned_deg``."""
    line_yaw = math.atan2(world.dock_axis[1], world.dock_axis[0]) + math.radians(off_axis_deg)
    p = world.dock_center - distance_m * np.array([math.cos(line_yaw), math.sin(line_yaw), 0.0])
    return VehiclePose(float(p[0]), float(p[1]), float(p[2]), yaw=-line_yaw - math.radians(turned_deg))


def _detect_in_open_water(world, pose, noise):
    """One frame of the loop's camera from ``pose`` (``noise``: the draw of the camera noise), detected afresh."""
    image, truth = render(LOOP_CAMERA, world.scene_for(pose, seed=noise))
    return Detector(LOOP_CAMERA, DetectorConfig(marker_radius_m=world.entrance_radius_m)).detect(image), truth


@pytest.mark.parametrize("range_m", [3.0, 5.0])
def test_six_small_leds_round_a_lit_funnel_are_a_ring_when_the_user_gives_their_count(range_m):
    """The open-water dock of closed-loop episode 20 (six blue LEDs, 3 px across at 3 m, round a grey
    funnel with vanes), its count told as a user would. Six even steps are the evidence; the LEDs lie
    35 of their radii apart, which a gate against specks lining up once refused (found at 4 m only),
    and with the count given the funnel's outline is not taken instead."""
    world = _open_water_world(20)
    assert world.scene.led_count == 6
    pose = _facing_the_dock(world, range_m)
    for noise in range(1, 3):
        image, truth = render(LOOP_CAMERA, world.scene_for(pose, seed=noise))
        config = DetectorConfig(marker_radius_m=world.entrance_radius_m, led_count=6)
        detection = Detector(LOOP_CAMERA, config).detect(image)
        assert detection.found and detection.led_count == 6 and len(detection.leds) == 6, (noise, detection.reason)
        assert math.hypot(detection.u - truth.center_px[0], detection.v - truth.center_px[1]) < 0.02 * truth.radius_px


def test_a_sparse_ring_close_in_is_found_once_the_dock_has_shown_its_count():
    """The open-water dock of closed-loop episode 325 (six small blue LEDs round a grey funnel), its
    count not given. Close in the LEDs lie 40-70 of their radii apart, which the gate against specks
    lining up refuses without a count, and the episode flew from 5 m to 1.7 m blind on four approaches,
    drifted off in the current each time and aborted. Once the detector has learned the count from the
    dock farther out, six LEDs at that count's even steps are the evidence, as with a count given."""
    world = _open_water_world(325)
    detector = Detector(LOOP_CAMERA, DetectorConfig(marker_radius_m=world.entrance_radius_m, tracking=True))
    for frame in range(100):  # 10 s at 9 m: whole rings vote on one frame in ten
        image, _ = render(LOOP_CAMERA, world.scene_for(_facing_the_dock(world, 9.0), seed=frame + 1))
        detector.detect(image, 0.1 * frame)
    assert detector.led_counts.count == 6
    for range_m in (5.0, 4.0, 3.0):
        found = []
        for noise in range(1, 4):
            image, truth = render(LOOP_CAMERA, world.scene_for(_facing_the_dock(world, range_m + world.camera_offset_m),
                                                               seed=noise))
            detection = detector.detect(image)
            found.append(detection.found and detection.led_count == 6)
            if found[-1]:
                assert detection.pose.range_m == pytest.approx(truth.position_m[2], rel=0.05)
        assert sum(found) >= 2, (range_m, found)  # one frame in ten tries every count, with the gate


def test_a_distant_ring_whose_leds_bloom_into_one_glow_is_found_from_its_leds():
    """The open-water dock of closed-loop episode 22 (nine white LEDs round a lit hub) 11 m
    straight ahead, in six draws of the camera noise: the LEDs' halos merge into one glow
    with no sharp outline, and most LEDs do not stand clear of it. The few that do begin
    the ring and the lights in the glow complete it (before: found in none of the six)."""
    world = _open_water_world(22)
    pose = _facing_the_dock(world, 11.0)
    for noise in range(1, 7):
        detection, truth = _detect_in_open_water(world, pose, noise)
        assert detection.found and detection.led_count == 9 and len(detection.leds) >= 6, (noise, detection.reason)
        assert math.hypot(detection.u - truth.center_px[0], detection.v - truth.center_px[1]) < 0.1 * truth.radius_px


@pytest.mark.parametrize("range_m", [2.4, 1.6])
def test_a_near_strip_is_found_where_the_water_darkens_across_its_window(range_m):
    """The open-water dock of closed-loop episode 32 (a strip, no funnel) head-on: the water
    darkens by 50 grey from the top of the ring's window to its bottom. Taken for noise, that
    fall-off put the threshold's floor above white, and the ring went unseen from 2.4 m in."""
    world = _open_water_world(32)
    detection, truth = _detect_in_open_water(world, _facing_the_dock(world, range_m + world.camera_offset_m), 1)
    assert detection.found, detection.reason
    assert detection.pose.range_m == pytest.approx(truth.position_m[2], rel=0.05)


@pytest.mark.parametrize("off_axis_deg", [0.0, 25.0])
def test_a_lit_funnel_close_in_is_not_taken_for_a_small_ring_round_its_hub(off_axis_deg):
    """The open-water dock of closed-loop episode 108 (a strip round a funnel lit brighter than
    the sensor takes, four dark vanes and a hub) 3.8 m away: the funnel is one white disc, and
    the plateau's spots between the vanes round the hub looked like a ring of LEDs a seventh of
    the entrance's size (range 23 m instead of 3.8; the episode's tracker followed it)."""
    world = _open_water_world(108)
    pose = _facing_the_dock(world, 3.8, off_axis_deg=off_axis_deg)
    for noise in range(1, 4):
        detection, truth = _detect_in_open_water(world, pose, noise)
        assert detection.found, (noise, detection.reason)
        assert detection.radius_px == pytest.approx(truth.radius_px, rel=0.15), noise


@pytest.mark.parametrize("turned_deg", [18.0, 22.0])
def test_leds_on_a_lit_funnels_rim_near_the_frames_edge_are_found(turned_deg):
    """The open-water dock of closed-loop episode 73 (six blue LEDs blooming into a white funnel)
    5.5 m ahead, the nose turned away as when the vehicle crabs in a cross current. The LEDs are
    found as bumps on the funnel's outline, whose size is only their part outside the rim: six
    of them lie 35 of those sizes apart, and the ring was taken for specks that happen to line
    up (the episode lost the dock for 2.5 s at 5 m and drifted into it sideways)."""
    world = _open_water_world(73)
    pose = _facing_the_dock(world, 5.5, turned_deg=turned_deg)
    for noise in range(1, 4):
        detection, truth = _detect_in_open_water(world, pose, noise)
        assert truth.center_px[0] > 0.8 * LOOP_CAMERA.width
        assert detection.found and detection.led_count == 6, (noise, detection.reason)
        assert math.hypot(detection.u - truth.center_px[0], detection.v - truth.center_px[1]) < 0.1 * truth.radius_px


@pytest.mark.parametrize("range_m", [5.0, 4.6])
def test_leds_blooming_beside_a_lit_funnel_begin_the_ring(range_m):
    """The open-water dock of closed-loop episode 48 (nine blue LEDs blooming round a lit funnel
    with three dark vanes) straight ahead. The LEDs' cores are a pixel or two wide and their
    halos reach past the circle that size puts round them, so none stood clear and none could
    begin a ring; with no sharp outline round the glow the ring went unseen from 5.6 to 3.5 m
    (found in 5 of 70 frames from 6 to 3.4 m head-on before, 41 after)."""
    world = _open_water_world(48)
    pose = _facing_the_dock(world, range_m + world.camera_offset_m)
    for noise in range(1, 4):
        detection, truth = _detect_in_open_water(world, pose, noise)
        assert detection.found and detection.led_count == 9, (noise, detection.reason)
        assert math.hypot(detection.u - truth.center_px[0], detection.v - truth.center_px[1]) < 0.1 * truth.radius_px
        assert detection.pose.range_m == pytest.approx(truth.position_m[2], rel=0.05)
        assert not detection.bloomed  # the glow between its LEDs is below full scale


def test_leds_bloomed_into_one_white_glow_are_told_apart_and_their_range_and_tilt_held_loose():
    """The open-water dock of closed-loop episode 377 (twelve white LEDs as bright as the sensor
    takes, round a lit funnel) 5.5 m straight ahead: the LEDs and the gaps between them are one
    white glow, and the lights the search finds are bulges of its outline, outside the LEDs. The
    ring they make reads 15-30 % short and tilted 20-40 deg; its pose said 1 %, and the episode's
    axis estimate settled 17 deg off and entered 25 deg off. Such a ring is marked ``bloomed``:
    dock/pose gives it a blob's range deviation (9 % at 5.5 m) and no axis."""
    world = _open_water_world(377)
    pose = _facing_the_dock(world, 5.5 + world.camera_offset_m)
    for noise in range(1, 4):
        detection, truth = _detect_in_open_water(world, pose, noise)
        assert detection.found and detection.led_count and detection.bloomed, (noise, detection.reason)
        observation = observation_of(detection, world.entrance_radius_m, LOOP_CAMERA.focal_px, LOOP_CAMERA.width)
        assert observation.solid and observation.tilt_disputed
        published = dock_pose(observation)
        assert not published.axis_observed
        assert published.range_sigma_m > 0.05 * truth.position_m[2], noise  # a resolved ring's: about 1 %
