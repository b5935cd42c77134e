"""Chessboard views through a known camera, for testing calibration against the truth.

Each output pixel is undistorted (the camera's own Newton solver, computed once per
camera), its ray is intersected with the board plane, and the board texture is sampled
there; pixels beyond the lens model's fold or off the board show a grey wall. Blur and
noise are added last.
"""

from __future__ import annotations

import math
from functools import lru_cache

import cv2
import numpy as np

from auv_dock_guidance.geometry.calibration import Board
from auv_dock_guidance.geometry.camera import CameraModel

_TEXTURE_PX_PER_SQUARE = 40


@lru_cache(maxsize=4)
def _rays(camera: CameraModel) -> tuple[np.ndarray, np.ndarray]:
    ys, xs = np.mgrid[0 : camera.height, 0 : camera.width].astype(np.float64)
    xy, valid = camera.pixels_to_normalized(np.stack([xs, ys], axis=-1))
    return xy, valid


def board_texture(board: Board) -> np.ndarray:
    """The printed board with a one-square white margin, 8-bit grey."""
    squares_x, squares_y = board.columns + 1, board.rows + 1
    s = _TEXTURE_PX_PER_SQUARE
    texture = np.full(((squares_y + 2) * s, (squares_x + 2) * s), 235, np.uint8)
    for j in range(squares_y):
        for i in range(squares_x):
            if (i + j) % 2 == 0:
                texture[(j + 1) * s : (j + 2) * s, (i + 1) * s : (i + 2) * s] = 25
    return texture


def render_board(
    camera: CameraModel,
    board: Board,
    rotation: np.ndarray,
    translation: np.ndarray,
    rng: np.random.Generator,
    noise: float = 2.0,
    blur_sigma: float = 0.7,
) -> np.ndarray:
    """One grey view of the board; the board's first inner corner sits at ``translation``.

    ``rotation`` (3x3) takes board coordinates (x along columns, y along rows) to the camera frame.
    """
    xy, valid = _rays(camera)
    rays = np.concatenate([xy, np.ones((*xy.shape[:-1], 1))], axis=-1)
    normal = rotation[:, 2]
    depth = (translation @ normal) / (rays @ normal)
    points = rays * depth[..., None] - translation
    bx, by = points @ rotation[:, 0], points @ rotation[:, 1]
    s = _TEXTURE_PX_PER_SQUARE / board.square_m
    # The first inner corner is two squares in from the texture's corner (margin + one square).
    map_x = (bx * s + 2 * _TEXTURE_PX_PER_SQUARE - 0.5).astype(np.float32)
    map_y = (by * s + 2 * _TEXTURE_PX_PER_SQUARE - 0.5).astype(np.float32)
    usable = valid & (depth > 0)
    map_x[~usable] = -1
    map_y[~usable] = -1
    image = cv2.remap(board_texture(board), map_x, map_y, cv2.INTER_LINEAR,
                      borderMode=cv2.BORDER_CONSTANT, borderValue=110)
    image = np.asarray(cv2.GaussianBlur(image, (0, 0), blur_sigma), dtype=np.float32)
    image += rng.normal(0, noise, image.shape).astype(np.float32)
    return np.clip(image, 0, 255).astype(np.uint8)


def random_views(camera: CameraModel, board: Board, count: int, seed: int) -> list[np.ndarray]:
    """Views spread over the image (centre and towards the corners), tilted up to 35 deg."""
    rng = np.random.default_rng(seed)
    views = []
    width_m, height_m = (board.columns - 1) * board.square_m, (board.rows - 1) * board.square_m
    for i in range(count):
        span = rng.uniform(0.35, 0.5)  # share of the image width the board covers
        distance = width_m * camera.fx / (span * camera.width)
        target = np.array([(i % 3 - 1) * 0.28, ((i // 3) % 3 - 1) * 0.1]) + rng.normal(0, 0.02, 2)
        rvec = rng.uniform(-1, 1, 3) * np.array([math.radians(35), math.radians(35), math.radians(20)])
        rotation, _ = cv2.Rodrigues(rvec)
        centre = np.array([target[0] * distance, target[1] * distance, distance])
        translation = centre - rotation @ np.array([width_m / 2, height_m / 2, 0.0])
        views.append(render_board(camera, board, rotation, translation, rng))
    return views
