import dataclasses

import cv2
import numpy as np
import pytest

from auv_dock_guidance.geometry.calibration import Board, CalibrationError, calibrate, find_corners, undistort_image
from auv_dock_guidance.geometry.camera import paper_camera
from auv_dock_guidance.sim.chessboard import random_views, render_board

BOARD = Board(9, 6, 0.04)


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


def test_an_outlier_view_is_rejected_with_its_error(truth, views):
    other_lens = dataclasses.replace(truth, fx=truth.fx * 1.3, fy=truth.fy * 1.3)
    rng = np.random.default_rng(3)
    rotation, _ = cv2.Rodrigues(np.array([0.2, -0.1, 0.05]))
    odd = render_board(other_lens, BOARD, rotation, np.array([-0.15, -0.1, 0.55]), rng)
    result = calibrate([(f"view{i}", v) for i, v in enumerate(views)] + [("odd", odd)], BOARD, True)
    rejected = {r.name: r.reason for r in result.rejected}
    assert "odd" in rejected and "outlier" in rejected["odd"]


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


def test_undistorted_board_corners_lie_on_a_plane_homography(truth, views):
    straight = undistort_image(views[4], truth)
    corners = find_corners(straight, BOARD)
    assert corners is not None
    plane = np.ascontiguousarray(BOARD.object_points()[:, :2])
    image_points = np.ascontiguousarray(corners[:, 0])
    h, _ = cv2.findHomography(plane, image_points, 0)
    projected = cv2.perspectiveTransform(plane[None], h)[0]
    assert np.max(np.linalg.norm(projected - image_points, axis=1)) < 0.5


def test_board_specification_is_checked():
    with pytest.raises(CalibrationError, match="COLSxROWS"):
        Board.parse("nine-by-six", 0.04)
    with pytest.raises(CalibrationError, match="positive"):
        Board(9, 6, 0.0)
