import math

import numpy as np
import pytest
from dock_frames import PAL, Dock, render_dock, ring_center_px

from auv_dock_guidance.sim.scene import Lamp, SceneSpec, render
from auv_dock_guidance.vision import detector as detector_module
from auv_dock_guidance.vision.config import lens_scale
from auv_dock_guidance.vision.detection import Detection
from auv_dock_guidance.vision.detector import Detector, DetectorConfig
from auv_dock_guidance.vision.search import BANDS, search, search_steps
from auv_dock_guidance.vision.tracking import WindowTracker

FRAME = (1080, 1920)


def _seen(u, v, radius_px=50.0):
    return Detection(found=True, u=u, v=v, radius_px=radius_px)


def test_the_window_holds_the_last_ring_with_room_to_move():
    tracker = WindowTracker()
    tracker.update(_seen(60.0, 500.0), 0.0)
    (x0, y0, x1, y1), radius = tracker.window(FRAME, 1 / 30)
    assert radius == 50.0
    assert x0 == 0 and x1 >= 60 + 1.5 * 50 and y0 <= 500 - 75 and y1 >= 500 + 75


def test_the_window_moves_with_the_marker_and_allows_for_a_skipped_frame():
    tracker = WindowTracker()
    tracker.update(_seen(500.0, 500.0), 0.0)
    tracker.update(_seen(520.0, 490.0), 1 / 30)  # 20 px right, 10 up per frame
    centre = tracker.predict(2 / 30)
    assert (centre.u, centre.v) == pytest.approx((540.0, 480.0))
    after_a_skip = tracker.predict(3 / 30)
    assert (after_a_skip.u, after_a_skip.v) == pytest.approx((560.0, 470.0))
    (x0, y0, x1, y1), _ = tracker.window(FRAME, 3 / 30)
    assert x0 < 560 - 75 and x1 > 560 + 75 and y0 < 470 - 75 and y1 > 470 + 75


def test_a_window_size_can_be_chosen():
    tracker = WindowTracker()
    tracker.update(_seen(900.0, 500.0), 0.0)
    (x0, _, x1, _), _ = tracker.window(FRAME, 1 / 30, window_radii=3.0)
    assert x1 - x0 == pytest.approx(2 * (3.0 * 50 + 24), abs=2)


def test_a_lost_marker_or_a_stale_track_gives_no_velocity_to_follow():
    tracker = WindowTracker()
    tracker.update(_seen(500.0, 500.0), 0.0)
    tracker.update(_seen(520.0, 500.0), 1 / 30)
    far_ahead = tracker.predict(5.0)
    assert far_ahead.u < 520.0 + 20.0 * 0.5 * 30 + 1  # extrapolated half a second at most
    tracker.update(Detection(found=False), 2 / 30)
    assert tracker.window(FRAME, 3 / 30) is None


def _approach(camera, count, start=0):
    for i in range(start, start + count):
        spec = SceneSpec(marker_center_m=(0.6 - 0.02 * i, 0.2, 9.0 - 0.05 * i), brightness=3.0, seed=i)
        yield render(camera, spec)


def test_tracking_follows_the_marker_and_reacquires_it_after_a_loss(camera):
    detector = Detector(camera, DetectorConfig(tracking=True))
    frames = list(_approach(camera, 4))
    empty = np.full_like(frames[0][0], 20)
    for i, (image, truth) in enumerate(frames[:2]):
        detection = detector.detect(image, i / 30)
        assert detection.found and math.hypot(detection.u - truth.center_px[0], detection.v - truth.center_px[1]) < 2
    assert detector.tracker.tracking
    assert not detector.detect(empty, 2 / 30).found  # lost
    assert not detector.tracker.tracking
    for i, (image, truth) in enumerate(frames[2:], start=3):
        detection = detector.detect(image, i / 30)  # found again by the full search, then tracked
        assert detection.found and math.hypot(detection.u - truth.center_px[0], detection.v - truth.center_px[1]) < 2


def test_the_full_search_replaces_a_reflection_that_took_over_without_stalling_a_frame(camera, monkeypatch):
    image, truth = render(camera, SceneSpec(marker_center_m=(0.0, 0.3, 8.0), surface_height_m=0.6,
                                            reflection_gain=1.0, seed=6))
    every = 5
    detector = Detector(camera, DetectorConfig(tracking=True, full_search_every=every))
    detector.tracker.update(_seen(*truth.reflection_center_px, radius_px=70.0), 0.0)  # locked on the reflection
    first = detector.detect(image, 1 / 30)
    assert first.found and abs(first.v - truth.reflection_center_px[1]) < 3  # the window sees only it

    def whole_frame_at_once(*args):
        raise AssertionError("the whole frame was searched on one frame while tracking")

    monkeypatch.setattr(detector_module, "search", whole_frame_at_once)
    chosen = [detector.detect(image, i / 30) for i in range(2, 4 * every)]
    switched = next(i for i, d in enumerate(chosen) if abs(d.v - truth.center_px[1]) < 3)
    assert all(abs(d.v - truth.center_px[1]) < 3 for d in chosen[switched:])  # and it keeps the real ring


def test_a_search_spread_over_frames_finds_what_one_frame_search_finds(camera):
    image, _ = render(camera, SceneSpec(marker_center_m=(0.0, 0.3, 8.0), surface_height_m=0.6,
                                        reflection_gain=1.0, lamps=(Lamp(300.0, 900.0, 5.0, 2.0),), seed=6))
    config = DetectorConfig()
    steps = search_steps(config, lens_scale(camera), 10.0, bands=BANDS)
    next(steps)
    slices = 0
    with pytest.raises(StopIteration) as done:
        while True:
            steps.send(image)
            slices += 1
    assert done.value.value[0] == search(image, config, lens_scale(camera), 10.0)
    assert slices >= BANDS + len(config.search_gaps_px)


def test_a_ring_of_separate_leds_is_tracked_in_its_window_with_the_same_evidence(monkeypatch):
    docks = [Dock(center_m=(0.25 - 0.03 * i, 0.1, 2.2 - 0.04 * i), normal=(0.2, -0.1, -1.0), seed=i) for i in range(6)]
    detector = Detector(PAL, DetectorConfig(led_count=8, tracking=True, full_search_every=30))
    first = detector.detect(render_dock(docks[0]), 0.0)
    assert first.found and len(first.leds) == 8

    def whole_frame_at_once(*args):
        raise AssertionError("the whole frame was searched while the ring was in its window")

    monkeypatch.setattr(detector_module, "search", whole_frame_at_once)
    for i, dock in enumerate(docks[1:], start=1):
        detection = detector.detect(render_dock(dock), i / 30)
        assert detection.found and len(detection.leds) == 8
        assert math.hypot(detection.u - ring_center_px(dock)[0], detection.v - ring_center_px(dock)[1]) < 2.0
