import json

import cv2
import pytest

from auv_dock_guidance.cli.main import main
from auv_dock_guidance.geometry.calibration import Board
from auv_dock_guidance.geometry.camera import CameraModel, paper_camera
from auv_dock_guidance.sim.chessboard import random_views


@pytest.fixture(scope="module")
def board_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("boards")
    paths = []
    for i, view in enumerate(random_views(paper_camera().scaled(0.5), Board(9, 6, 0.04), 6, seed=8)):
        path = folder / f"board{i}.png"
        cv2.imwrite(str(path), view)
        paths.append(str(path))
    return folder, paths


def test_calibrate_writes_a_camera_info_file_and_json(board_files, tmp_path, capsys):
    folder, paths = board_files
    out = tmp_path / "camera_info.yaml"
    (folder / "broken.png").write_text("not a png")
    code = main(["calibrate", *paths, str(folder / "broken.png"), "--board", "9x6", "--square", "0.04",
                 "--fix-tangential", "--output", str(out), "--json"])
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    for key in ("rms_px", "camera_matrix", "distortion_coefficients", "image_size", "used_images", "rejected_images",
                "std", "warnings"):
        assert key in report
    assert report["image_size"] == [960, 540]
    assert any(r["image"].endswith("broken.png") for r in report["rejected_images"])
    assert CameraModel.from_yaml(out).fx == pytest.approx(report["camera_matrix"][0][0])
    for view in report["used_images"]:
        assert view["error_px"] > 0 and view["half_window_px"] >= 3
    assert set(report["std"]) == {"fx_px", "fy_px", "cx_px", "cy_px", "k1", "k2", "p1", "p2", "k3"}
    assert 0 < report["std"]["fx_px"] < 5


def _calibrate(paths, *extra):
    return main(["calibrate", *paths, "--board", "9x6", "--square", "0.04", "--fix-tangential", *extra])


def test_an_existing_output_is_kept_unless_forced(board_files, tmp_path, capsys):
    _, paths = board_files
    out = tmp_path / "camera_info.yaml"
    out.write_text("mine")
    with pytest.raises(SystemExit) as info:
        _calibrate(paths, "--output", str(out))
    assert info.value.code == 2
    assert f"--output {out} exists; give --force to replace it" in capsys.readouterr().err
    assert out.read_text() == "mine"
    assert _calibrate(paths, "--output", str(out), "--force") == 0
    assert CameraModel.from_yaml(out).width == 960


def test_an_input_image_is_never_the_output_even_forced(board_files, capsys):
    _, paths = board_files
    before = open(paths[1], "rb").read()
    for extra in ([], ["--force"]):
        with pytest.raises(SystemExit) as info:
            _calibrate(paths, "--output", paths[1], *extra)
        assert info.value.code == 2
        assert f"is the input image {paths[1]}" in capsys.readouterr().err
    assert open(paths[1], "rb").read() == before


def test_unusable_images_are_each_named(tmp_path, capsys):
    text = tmp_path / "text.png"
    text.write_text("hello")
    with pytest.raises(SystemExit) as info:
        main(["calibrate", str(tmp_path / "nosuch.png"), str(text), "--board", "9x6", "--square", "0.04"])
    assert info.value.code == 1
    err = capsys.readouterr().err.strip()
    assert err == (f"auv-dock: error: none of the images can be used: {tmp_path / 'nosuch.png'}: no such file; "
                   f"{text}: not an image OpenCV can decode")


@pytest.mark.parametrize("square", ["1e-30", "1e40"])
def test_absurd_square_sizes_are_refused_before_any_work(board_files, square, capsys):
    _, paths = board_files
    with pytest.raises(SystemExit) as info:
        main(["calibrate", *paths, "--board", "9x6", "--square", square])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert f"--square: {square} is out of range: must be a number from 1e-05 to 10" in err and "Traceback" not in err


def test_calibrate_with_too_few_boards_fails_cleanly(board_files, capsys):
    _, paths = board_files
    with pytest.raises(SystemExit) as info:
        main(["calibrate", paths[0], "--board", "9x6", "--square", "0.04"])
    assert info.value.code == 1
    assert "need at least 3" in capsys.readouterr().err


def test_undistort_writes_an_image(board_files, tmp_path, capsys):
    _, paths = board_files
    cam_file = tmp_path / "cam.yaml"
    import yaml

    cam_file.write_text(yaml.safe_dump(paper_camera().scaled(0.5).to_yaml_dict()))
    out = tmp_path / "straight.png"
    assert main(["undistort", paths[0], "--camera-info", str(cam_file), "-o", str(out)]) == 0
    assert cv2.imread(str(out)).shape == (540, 960, 3)
    with pytest.raises(SystemExit):
        main(["undistort", paths[0], "--camera-info", str(cam_file), "-o", paths[0], "--force"])
    assert "nothing is written over an input" in capsys.readouterr().err
