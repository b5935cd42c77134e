"""The dock's LED count learned from the frames, and rings of another count kept from the axis."""

from dock_frames import PAL, Dock, render_dock

from auv_dock_guidance.geometry.uncertainty import dock_pose, observation_of
from auv_dock_guidance.vision.detector import Detector, DetectorConfig
from auv_dock_guidance.vision.led_count import LedCountVote


def test_the_dock_count_is_the_largest_seen_in_a_fair_share_of_the_rings():
    vote = LedCountVote()
    for count in [6] * 5:
        vote.add(count)
    assert vote.count is None and not vote.disputes(6)  # too few rings yet
    for count in [6] * 20 + [7] * 5 + [8]:  # LEDs lost in blooms read as 6; 8 once is a misreading
        vote.add(count)
    assert vote.count == 7
    assert vote.disputes(6) and vote.disputes(8) and not vote.disputes(7)
    vote.reset()
    assert vote.count is None


def _pose_of(detection):
    return dock_pose(observation_of(detection, DetectorConfig().marker_radius_m, PAL.focal_px, PAL.width))


def test_a_ring_of_another_count_than_the_docks_gives_no_axis():
    frame = render_dock(Dock(center_m=(0.3, 0.2, 2.0), normal=(0.3, -0.2, -1.0)))  # eight LEDs
    agreeing, other = Detector(PAL), Detector(PAL)  # the count not given: learned
    for _ in range(10):
        agreeing.led_counts.add(8)
        other.led_counts.add(9)  # as if earlier frames showed a ring of nine
    seen = agreeing.detect(frame)
    assert seen.led_count == 8 and not seen.count_disputed and _pose_of(seen).axis_observed
    disputed = other.detect(frame)
    assert disputed.led_count == 8 and disputed.count_disputed
    assert not _pose_of(disputed).axis_observed
    assert disputed.pose == seen.pose  # the position stands


def test_with_the_count_given_nothing_is_voted_or_disputed():
    detector = Detector(PAL, DetectorConfig(led_count=8))
    detection = detector.detect(render_dock(Dock(center_m=(0.3, 0.2, 2.0), normal=(0.3, -0.2, -1.0))))
    assert detection.led_count == 8 and not detection.count_disputed and detector.led_counts.count is None


def test_a_count_settled_on_a_misreading_gives_way_to_the_docks():
    """Far out, a ring of eleven can read as six (every other LED): the vote settles there before
    the ring is resolved, and the frames assembled at that count read the dock wrongly too (this
    ring of eight as six). The frames that try every count vote for the dock's own, and win."""
    frame = render_dock(Dock(center_m=(0.3, 0.2, 2.0), normal=(0.3, -0.2, -1.0)))  # eight LEDs
    detector = Detector(PAL)
    for _ in range(10):
        detector.led_counts.add(5)
    for _ in range(2 * detector.config.all_counts_every):
        detector.detect(frame)
    assert detector.led_counts.count == 8
    assert detector.led_counts.rings == 12  # only the frames that tried every count voted
    seen = detector.detect(frame)
    assert seen.led_count == 8 and len(seen.leds) == 8 and not seen.count_disputed
