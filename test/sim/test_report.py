"""Pictures of a run: the moments that matter, the strip, the animation."""

import cv2
import numpy as np
import pytest
from PIL import Image

from auv_dock_guidance.sim.closed_loop import EpisodeConfig, EpisodeResult, run_episode
from auv_dock_guidance.sim.report import (
    FIRST_DETECTION,
    LAST,
    LAST_SIGHTING,
    TERMINAL,
    TRACKING,
    OverlayFrame,
    distance_to_entrance,
    episode_pictures,
    key_moments,
    state_at,
    worst_episode,
    write_run_pictures,
)

STATES = [(0.5, "SEARCH"), (4.0, "TRACK"), (30.0, "TERMINAL")]


def _frames(count: int = 80, rate_hz: float = 2.0) -> list[OverlayFrame]:
    frames = []
    for i in range(count):
        image = np.full((60, 100, 3), 20, np.uint8)
        cv2.circle(image, (50, 30), 5 + i % 20, (0, 255, 0), 1)
        frames.append(OverlayFrame(i / rate_hz, cv2.imencode(".jpg", image)[1].tobytes()))
    return frames


def test_the_moments_that_matter_are_picked_once_in_time_order():
    frames = _frames()
    moments = key_moments(frames, (3.2, 36.0), STATES)
    assert [m.label for m in moments] == [FIRST_DETECTION, TRACKING, TERMINAL, LAST_SIGHTING, LAST]
    times = [m.frame.t_s for m in moments]
    assert times == [3.5, 17.0, 30.0, 36.0, 39.5]  # first after, middle of TRACK, first after, last before, last
    # Without a detection or a terminal phase, only what happened is shown.
    assert [m.label for m in key_moments(frames, None, STATES[:1])] == [LAST]
    assert key_moments([], (1.0, 2.0), STATES) == []


def test_state_at_a_time():
    assert state_at(STATES, 0.1) == ""
    assert state_at(STATES, 4.0) == "TRACK"
    assert state_at(STATES, 99.0) == "TERMINAL"


def test_a_run_gives_a_strip_and_an_animation(tmp_path):
    trajectory = [(t, -12.0 + 0.3 * t, 0.0, 0.0, 0.0) for t in np.arange(0.0, 41.0, 0.5)]
    to_go = distance_to_entrance(trajectory)
    assert to_go(10.0) == pytest.approx(9.0)
    strip, animation = write_run_pictures(tmp_path, _frames(), STATES, (3.2, 36.0), to_go, True, title="test")
    assert strip.name == "camera_strip.png" and cv2.imread(str(strip)) is not None
    with Image.open(animation) as gif:
        assert gif.format == "GIF" and gif.n_frames > 40
        assert gif.size[0] == 480
    assert write_run_pictures(tmp_path / "none", [], STATES, None, to_go, False) == []


def test_the_worst_episode_is_the_first_failure_else_the_widest_entry():
    def result(seed, success, lateral):
        return EpisodeResult(seed, success, "docked" if success else "missed", 30.0, lateral, 5.0, 10.0, [], [], [])

    assert worst_episode([result(1, True, 0.02), result(2, False, 0.3), result(3, False, 0.4)]).seed == 2
    assert worst_episode([result(1, True, 0.02), result(2, True, 0.05)]).seed == 2
    assert worst_episode([]) is None


def test_an_episode_is_run_again_for_its_pictures(tmp_path):
    config = EpisodeConfig(max_time_s=4.0)  # the start of an approach: the dock found, tracking begins
    first = run_episode(config, 5)
    pictures = episode_pictures(config, first, tmp_path)
    assert [p.name for p in pictures] == ["worst_seed5_camera_strip.png", "worst_seed5_approach.gif"]
    with Image.open(pictures[1]) as gif:
        assert gif.n_frames >= 7  # two a second of a 4 s run
    again = run_episode(config, 5, on_frame=lambda *frame: None)
    assert again.trajectory == first.trajectory  # watching a run does not change it
