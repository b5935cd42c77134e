import dataclasses
import math

import cv2
import numpy as np
import pytest

from auv_dock_guidance.geometry.calibration import (
    Board,
    CalibrationError,
    ViewResult,
    calibrate,
    calibrate_boards,
    corner_clearance_px,
    find_corners,
    grid_bend,
    outlier_limit_px,
    refinement_half_window,
    undistort_image,
)
from auv_dock_guidance.geometry.camera import CameraModel, paper_camera
from auv_dock_guidance.sim.chessboard import random_poses, random_views, render_board, true_corners

BOARD = Board(9, 6, 0.04)
# A small camera with a moderate lens (no fold in the image), the kind whose boards are small in pixels.
SMALL_LENS = CameraModel(640, 480, fx=520.0, fy=520.0, cx=322.0, cy=236.0, k1=-0.25, k2=0.07)


@pytest.fixture(scope="module")
def truth():
    return paper_camera().scaled(0.5)


@pytest.fixture(scope="module")
def views(truth):
    return random_views(truth, BOARD, 10, seed=4)


def test_recovers_the_true_camera_from_noisy_blurred_distorted_views(truth, views):
    result = calibrate([(f"view{i}", v) for i, v in enumerate(views)], BOARD, fix_tangential=True)
    cam = result.camera
    assert cam.fx == pytest.approx(truth.fx, rel=0.005) and cam.fy == pytest.approx(truth.fy, rel=0.005)
    assert abs(cam.cx - truth.cx) < 2 and abs(cam.cy - truth.cy) < 2
    assert result.rms_px < 0.5
    assert cam.k1 == pytest.approx(truth.k1, abs=0.02)
    assert result.std_fx > 0


# Squares of 12 px: a board with more, smaller squares, as one prints for a small or distant
# board (a 9x6 one would cover a fifth of the image and constrain the lens poorly).
@pytest.mark.parametrize(("square_px", "scale", "board"), [(12, 0.5, Board(13, 9, 0.02)), (25, 1.0, BOARD),
                                                           (60, 2.0, BOARD)])
def test_boards_of_12_25_and_60_px_squares_give_the_true_intrinsics_within_0_2_percent(square_px, scale, board):
    camera = SMALL_LENS.scaled(scale)
    shots = random_views(camera, board, 12, seed=1, square_px=square_px, noise=2.0, blur_sigma=0.8,
                         jpeg_quality=90, max_tilt_deg=30)
    result = calibrate([(f"view{i}", v) for i, v in enumerate(shots)], board)
    assert result.rejected == []
    cam = result.camera
    assert cam.fx == pytest.approx(camera.fx, rel=0.002) and cam.fy == pytest.approx(camera.fy, rel=0.002)
    assert abs(cam.cx - camera.cx) < 0.002 * camera.width and abs(cam.cy - camera.cy) < 0.002 * camera.width
    windows = [v.half_window_px for v in result.used]
    assert all(w is not None and 3 <= w <= 0.3 * square_px * 1.2 for w in windows)  # sized to the squares


def test_the_refinement_window_grows_with_the_squares():
    small, large = SMALL_LENS.scaled(0.5), SMALL_LENS.scaled(2.0)
    rng = np.random.default_rng(2)
    rotation, _ = cv2.Rodrigues(np.array([0.2, -0.3, 0.1]))
    windows = []
    for camera, square_px in ((small, 12), (large, 60)):
        translation = np.array([-0.16, -0.1, camera.fx * BOARD.square_m / square_px])
        found = find_corners(render_board(camera, BOARD, rotation, translation, rng), BOARD)
        assert found is not None
        error = np.linalg.norm(found.corners[:, 0] - true_corners(camera, BOARD, rotation, translation), axis=1)
        assert error.max() < 0.25
        windows.append(found.half_window_px)
    assert windows[0] == 3 and windows[1] >= 10


def test_clearance_is_the_spacing_of_an_upright_grid_and_less_when_turned():
    grid = np.mgrid[0:6, 0:9].transpose(1, 2, 0)[..., ::-1].reshape(-1, 2).astype(float) * 20.0
    assert corner_clearance_px(grid, BOARD) == pytest.approx(20.0)
    turn = np.array([[math.cos(math.pi / 4), -math.sin(math.pi / 4)], [math.sin(math.pi / 4), math.cos(math.pi / 4)]])
    assert corner_clearance_px(grid @ turn.T, BOARD) == pytest.approx(20.0 / math.sqrt(2))
    assert refinement_half_window(grid, BOARD) == 6  # 0.3 of the clearance
    assert refinement_half_window(grid / 4, BOARD) == 3  # never below a 7x7 window


def test_a_corner_on_the_wrong_square_bends_the_grid():
    grid = np.mgrid[0:6, 0:9].transpose(1, 2, 0)[..., ::-1].reshape(-1, 2).astype(float) * 20.0
    assert grid_bend(grid, BOARD) == pytest.approx(0.0)
    grid[23] += [12.0, 0.0]
    assert grid_bend(grid, BOARD) > 0.5


def test_a_board_with_wrong_corners_is_rejected_and_every_other_kept(truth, views):
    found = [find_corners(v, BOARD, f"view{i}") for i, v in enumerate(views)]
    assert all(f is not None for f in found)
    boards = [f for f in found if f is not None]
    shifted = boards[3].corners.copy()
    shifted[::7] += np.float32([1.5, -1.0])  # every seventh corner off by 1.8 px
    boards[3] = dataclasses.replace(boards[3], corners=shifted)
    result = calibrate_boards(boards, BOARD, (truth.width, truth.height), fix_tangential=True)
    assert [r.name for r in result.rejected] == ["view3"]
    assert result.rejected[0].reason.startswith("outlier") and result.rejected[0].error_px > 0.3
    assert len(result.used) == len(views) - 1
    assert result.camera.fx == pytest.approx(truth.fx, rel=0.005)


def test_an_outlier_view_is_rejected_with_its_error(truth, views):
    other_lens = dataclasses.replace(truth, fx=truth.fx * 1.3, fy=truth.fy * 1.3)
    rng = np.random.default_rng(3)
    rotation, _ = cv2.Rodrigues(np.array([0.2, -0.1, 0.05]))
    odd = render_board(other_lens, BOARD, rotation, np.array([-0.15, -0.1, 0.55]), rng)
    result = calibrate([(f"view{i}", v) for i, v in enumerate(views)] + [("odd", odd)], BOARD, True)
    rejected = {r.name: r.reason for r in result.rejected}
    assert "odd" in rejected and "outlier" in rejected["odd"]


def test_the_outlier_rule_is_relative_to_the_other_views():
    ordinary = np.array([0.16, 0.17, 0.18, 0.19, 0.19, 0.20, 0.21, 0.24, 0.25])
    assert outlier_limit_px(ordinary) > ordinary.max()  # the spread of real photos is no outlier
    assert outlier_limit_px(np.r_[ordinary, 0.9]) < 0.9
    tight = np.full(10, 0.05) + np.linspace(0, 0.002, 10)
    assert outlier_limit_px(tight) >= 0.1  # a tight cluster does not make an ordinary view an outlier


def test_the_square_size_changes_no_intrinsic(views):
    named = [(f"view{i}", v) for i, v in enumerate(views[:5])]
    metres = calibrate(named, BOARD).camera
    tiny = calibrate(named, Board(9, 6, 2e-5)).camera
    assert tiny.fx == pytest.approx(metres.fx, rel=1e-6) and tiny.cx == pytest.approx(metres.cx, rel=1e-6)


def test_square_sizes_outside_any_printed_board_are_refused():
    for square_m in (1e-30, 0.0, -0.04, 1e40, math.inf, math.nan):
        with pytest.raises(CalibrationError, match=r"square size .* is outside"):
            Board(9, 6, square_m)


def test_images_of_different_sizes_are_refused(views):
    with pytest.raises(CalibrationError, match="differ in size"):
        calibrate([("a", views[0]), ("b", views[1][:100, :100])], BOARD)


def test_no_board_anywhere_is_refused():
    blank = np.full((540, 960), 128, np.uint8)
    with pytest.raises(CalibrationError, match="no 9x6 board found in any"):
        calibrate([("a", blank), ("b", blank)], BOARD)


def test_too_few_views_are_refused(views):
    with pytest.raises(CalibrationError, match="need at least 3"):
        calibrate([("a", views[0]), ("b", views[1])], BOARD)


def test_unusable_inputs_are_named_with_their_reasons():
    skipped = [ViewResult("nosuch.png", reason="no such file"), ViewResult("text.png", reason="not an image")]
    with pytest.raises(CalibrationError, match=r"none of the images can be used: nosuch\.png: no such file; "
                                               r"text\.png: not an image"):
        calibrate([], BOARD, skipped=skipped)


def test_poses_show_the_whole_sheet():
    camera = SMALL_LENS.scaled(0.5)
    for rotation, translation in random_poses(camera, BOARD, 6, np.random.default_rng(0), square_px=12):
        corners = true_corners(camera, BOARD, rotation, translation)
        assert corners[:, 0].min() > 12 and corners[:, 0].max() < camera.width - 12
        assert corners[:, 1].min() > 12 and corners[:, 1].max() < camera.height - 12


def test_undistorted_board_corners_lie_on_a_plane_homography(truth, views):
    straight = undistort_image(views[4], truth)
    found = find_corners(straight, BOARD)
    assert found is not None
    plane = np.ascontiguousarray(BOARD.object_points()[:, :2])
    image_points = np.ascontiguousarray(found.corners[:, 0])
    h, _ = cv2.findHomography(plane, image_points, 0)
    projected = cv2.perspectiveTransform(plane[None], h)[0]
    assert np.max(np.linalg.norm(projected - image_points, axis=1)) < 0.5


def test_board_specification_is_checked():
    with pytest.raises(CalibrationError, match="COLSxROWS"):
        Board.parse("nine-by-six", 0.04)
    with pytest.raises(CalibrationError, match="outside"):
        Board(9, 6, 0.0)
