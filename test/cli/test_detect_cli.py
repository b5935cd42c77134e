import json

import cv2
import numpy as np
import pytest

from auv_dock_guidance.cli.main import main
from auv_dock_guidance.sim.scene import SceneSpec, render


@pytest.fixture(scope="module")
def images(tmp_path_factory, camera):
    folder = tmp_path_factory.mktemp("frames")
    paths = []
    for i, z in enumerate((12.0, 8.0, 4.0)):
        image, _ = render(camera, SceneSpec(marker_center_m=(0.3, 0.1, z), seed=i))
        path = folder / f"frame_{i}.png"
        cv2.imwrite(str(path), image)
        paths.append(str(path))
    empty, _ = render(camera, SceneSpec(marker_center_m=None, seed=9))
    cv2.imwrite(str(folder / "empty.png"), empty)
    (folder / "not_an_image.png").write_text("hello")
    return folder, paths


def _records(capsys):
    return [json.loads(line) for line in capsys.readouterr().out.splitlines()]


def test_detect_prints_one_json_record_per_image(images, capsys):
    folder, paths = images
    assert main(["detect", "--json", *paths, str(folder / "empty.png")]) == 0
    records = _records(capsys)
    assert [r["found"] for r in records] == [True, True, True, False]
    assert [round(r["range_m"]) for r in records[:3]] == [12, 8, 4]
    for key in ("image", "u", "v", "radius_px", "offset_x_m", "offset_y_m", "yaw_deg", "pitch_deg", "threshold"):
        assert key in records[0]
    assert records[0]["yaw_deg"] > 0


def test_a_bad_file_is_reported_and_the_batch_goes_on(images, capsys):
    folder, paths = images
    code = main(["detect", "--json", str(folder / "not_an_image.png"), str(folder / "missing.png"), paths[0]])
    records = _records(capsys)
    assert code == 1
    assert "not an image" in records[0]["error"]
    assert "no such file" in records[1]["error"]
    assert records[2]["found"] is True


def test_wrong_image_size_for_the_camera_is_an_error_not_a_crash(tmp_path, capsys):
    path = tmp_path / "small.png"
    cv2.imwrite(str(path), np.zeros((480, 640, 3), np.uint8))
    assert main(["detect", str(path)]) == 1
    assert "640x480" in capsys.readouterr().out


def test_images_at_half_the_calibrated_resolution_use_the_scaled_camera(tmp_path, camera, capsys):
    half = camera.scaled(0.5)
    image, truth = render(half, SceneSpec(marker_center_m=(0.3, 0.1, 6.0), brightness=3.0, seed=2))
    path = tmp_path / "half.png"
    cv2.imwrite(str(path), image)
    assert main(["detect", "--json", str(path)]) == 0
    captured = capsys.readouterr()
    record = json.loads(captured.out)
    assert record["range_m"] == pytest.approx(6.0, rel=0.03)
    assert abs(record["u"] - truth.center_px[0]) < 1.5 and abs(record["v"] - truth.center_px[1]) < 1.5
    assert "images are 960x540, the camera model 1920x1080: model scaled by 0.5" in captured.err


def test_negative_marker_radius_is_refused(images, capsys):
    _, paths = images
    with pytest.raises(SystemExit) as info:
        main(["detect", "--marker-radius", "-0.3", paths[0]])
    assert info.value.code == 2
    assert "must be a positive number" in capsys.readouterr().err


def test_malformed_camera_info_is_refused_with_its_name(images, tmp_path, capsys):
    _, paths = images
    bad = tmp_path / "camera.yaml"
    bad.write_text("image_width: -4\n")
    with pytest.raises(SystemExit) as info:
        main(["detect", "--camera-info", str(bad), paths[0]])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "image_width" in err


def test_evaluate_json_has_the_report_keys(capsys):
    assert main(["evaluate", "--frames", "6", "--workers", "1", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    for key in ("detection_rate", "false_positives", "reflection_chosen", "center_error_px_p95",
                "range_error_rel_p95", "yaw_error_deg_p95", "pitch_error_deg_p95"):
        assert key in report


def test_no_command_prints_help(capsys):
    assert main([]) == 2
    assert "commands" in capsys.readouterr().out
