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
    for key in ("rms_px", "camera_matrix", "distortion_coefficients", "image_size", "used_images", "rejected_images"):
        assert key in report
    assert report["image_size"] == [960, 540]
    assert any(r["image"].endswith("broken.png") for r in report["rejected_images"])
    assert CameraModel.from_yaml(out).fx == pytest.approx(report["camera_matrix"][0][0])


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
