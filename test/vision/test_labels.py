import json
import math

import pytest

from auv_dock_guidance.vision.labels import FrameLabel, LabelError, blocks, load_labels, parse_entry, score, summary


def _label(index=1, cls="visible", box=(100.0, 100.0, 200.0, 100.0), disk=True):
    entry = {"file": f"f{index}.jpg", "index": index, "class": cls}
    if box is not None:
        entry["box"] = list(box)
    if disk:
        entry["disk"] = {"cx": 200.0, "cy": 150.0, "axes": [200.0, 100.0], "angle_deg": 0.0}
    return parse_entry(entry)


def test_a_detection_in_the_box_grown_by_a_quarter_is_on_the_dock():
    label = _label()
    assert score(label, True, 100 - 0.25 * 200 + 1, 150).on_dock  # just inside the grown box
    assert not score(label, True, 100 - 0.25 * 200 - 1, 150).on_dock
    assert not score(label, True, 200, 100 + 100 + 0.25 * 100 + 1).on_dock


def test_centre_error_is_over_the_disks_mean_radius():
    result = score(_label(), True, 200 + 15, 150)
    assert result.center_error == pytest.approx(15 / 75)


def test_a_detection_in_a_frame_without_a_box_is_a_wrong_object():
    result = score(_label(cls="corner", box=None, disk=False), True, 10, 10)
    assert result.found and not result.on_dock


def test_summary_counts_rates_per_class_and_wrong_objects():
    visible, corner = _label(1), _label(2, "corner", disk=False)
    scores = [score(visible, True, 200, 150), score(visible, False), score(corner, True, 5000, 5000)]
    report = summary(scores)
    assert report["visible_rate"] == 0.5 and report["corner_rate"] == 0.0
    assert report["wrong_objects"] == 1 and report["wrong_object_rate"] == pytest.approx(1 / 3)
    assert report["center_error_p50"] == pytest.approx(0.0)


def test_consecutive_indices_form_one_block():
    labels = [FrameLabel(f"{i}.jpg", i, "visible") for i in (5, 3, 4, 9, 10, 20)]
    assert [[label.index for label in block] for block in blocks(labels)] == [[3, 4, 5], [9, 10], [20]]


@pytest.mark.parametrize("entry, message", [
    ({"index": 1, "class": "visible"}, "file"),
    ({"file": "a.jpg", "index": -1, "class": "visible"}, "index -1"),
    ({"file": "a.jpg", "index": 1, "class": "maybe"}, "class 'maybe'"),
    ({"file": "a.jpg", "index": 1, "class": "visible", "box": [1, 2, 3]}, "box"),
    ({"file": "a.jpg", "index": 1, "class": "visible", "box": [1, 2, 0, 3]}, "positive width"),
    ({"file": "a.jpg", "index": 1, "class": "visible", "disk": {"cx": 1, "cy": 2, "axes": [0, 1]}}, "axes"),
])
def test_a_malformed_entry_is_refused_with_what_is_wrong(entry, message):
    with pytest.raises(LabelError, match=message):
        parse_entry(entry)


def test_load_keeps_good_entries_and_names_the_bad_ones(tmp_path):
    path = tmp_path / "labels.json"
    path.write_text(json.dumps({"frames": [
        {"file": "a.jpg", "index": 1, "class": "visible", "box": [0, 0, 10, 10]},
        {"file": "b.jpg", "index": 2, "class": "nope"},
        {"file": "c.jpg", "index": 1, "class": "corner"},
    ]}))
    labels, problems = load_labels(path)
    assert [label.file for label in labels] == ["a.jpg"]
    assert "entry 1 (b.jpg)" in problems[0] and "class 'nope'" in problems[0]
    assert "entry 2 (c.jpg)" in problems[1] and "twice" in problems[1]


@pytest.mark.parametrize("text, message", [("{", "not JSON"), ('{"frames": 3}', "list of labelled frames")])
def test_a_file_that_is_not_a_labels_file_is_refused(tmp_path, text, message):
    path = tmp_path / "labels.json"
    path.write_text(text)
    with pytest.raises(LabelError, match=message):
        load_labels(path)


def test_no_frames_means_no_rates():
    report = summary([])
    assert report["visible_rate"] is None and report["center_error_p95"] is None
    assert not math.isnan(report["frames"])
