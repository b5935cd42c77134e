"""`auv-dock evaluate --labels` and `auv-dock detect --overlay` on synthetic recorded frames."""

import json
import sys
from pathlib import Path

import cv2
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "vision"))
from dock_frames import Dock, led_pixels, render_dock, ring_center_px

from auv_dock_guidance.cli.main import main

DOCKS = {10: Dock(center_m=(0.3, 0.2, 2.0), seed=1), 11: Dock(center_m=(0.32, 0.2, 2.0), seed=2),
         30: Dock(center_m=None, seed=3)}


@pytest.fixture(scope="module")
def labelled(tmp_path_factory):
    folder = tmp_path_factory.mktemp("footage")
    (folder / "frames").mkdir()
    entries = []
    for index, dock in DOCKS.items():
        name = f"frame_{index}.jpg"
        cv2.imwrite(str(folder / "frames" / name), render_dock(dock))
        if dock.center_m is None:
            entries.append({"file": name, "index": index, "class": "none"})
            continue
        leds = led_pixels(dock)
        x0, y0 = leds.min(axis=0)
        x1, y1 = leds.max(axis=0)
        u, v = ring_center_px(dock)
        entries.append({"file": name, "index": index, "class": "visible", "box": [x0, y0, x1 - x0, y1 - y0],
                        "disk": {"cx": u, "cy": v, "axes": [x1 - x0, y1 - y0], "angle_deg": 0.0}})
    labels = folder / "labels.json"
    labels.write_text(json.dumps({"frames": entries}))
    return folder, labels


def test_labels_are_scored_per_block_and_overall(labelled, capsys):
    _, labels = labelled
    assert main(["evaluate", "--labels", str(labels), "--focal-px", "650", "--led-count", "8", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    overall = report["overall"]
    assert overall["visible_frames"] == 2 and overall["visible_rate"] == 1.0
    assert overall["empty_frames"] == 1 and overall["empty_detections"] == 0 and overall["wrong_objects"] == 0
    assert overall["center_error_p95"] < 0.02
    assert [(b["first_index"], b["last_index"]) for b in report["blocks"]] == [(10, 11), (30, 30)]


def test_a_missing_frame_and_a_bad_entry_are_named_and_the_batch_goes_on(labelled, tmp_path, capsys):
    folder, labels = labelled
    data = json.loads(labels.read_text())
    data["frames"].append({"file": "gone.jpg", "index": 12, "class": "visible"})
    data["frames"].append({"file": "odd.jpg", "index": 13, "class": "visible", "box": [1, 2]})
    broken = folder / "broken.json"
    broken.write_text(json.dumps(data))
    assert main(["evaluate", "--labels", str(broken), "--focal-px", "650", "--json"]) == 1
    captured = capsys.readouterr()
    assert "frame 12 (gone.jpg): not found" in captured.err
    assert "entry 4 (odd.jpg): box [1, 2] is not 4 finite numbers" in captured.err
    assert json.loads(captured.out)["overall"]["visible_frames"] == 2


def test_a_labels_file_that_is_not_json_stops_with_its_name(tmp_path, capsys):
    bad = tmp_path / "labels.json"
    bad.write_text("frames:")
    with pytest.raises(SystemExit) as info:
        main(["evaluate", "--labels", str(bad)])
    assert info.value.code == 2 and f"{bad}: not JSON" in capsys.readouterr().err


def test_detect_overlay_writes_annotated_frames_and_a_contact_sheet_without_overwriting(labelled, tmp_path, capsys):
    folder, _ = labelled
    frames = sorted(str(p) for p in (folder / "frames").glob("*.jpg"))
    out = tmp_path / "overlay"
    out.mkdir()
    (out / "contact_sheet.png").write_text("the user's own file")
    assert main(["detect", "--hfov", "58", "--led-count", "8", "--overlay", str(out), "--json", *frames]) == 0
    records = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["found"] for r in records] == [True, True, False]
    assert records[0]["range_approximate"] is True and records[0]["leds"] == 8
    assert (out / "contact_sheet.png").read_text() == "the user's own file"
    sheet = cv2.imread(str(out / "contact_sheet-1.png"))
    assert sheet is not None and sheet.shape[1] > 320
    assert len(list(out.glob("*_overlay.png"))) == 3
