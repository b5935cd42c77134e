"""Chessboard views through a known camera, for testing calibration against the truth.

Each output pixel's ray (the lens model inverted on a coarse grid by its own solver, then
by Newton steps at every sample, once per camera) is intersected with the board plane,
and the board texture is sampled there; pixels beyond the lens model's fold or off the board show a grey wall. Small
boards get several samples per pixel, averaged as a sensor integrates light over each
pixel's area. Blur, noise and JPEG compression are added last.
"""

from __future__ import annotations

import math
from functools import lru_cache

import cv2
import numpy as np

from auv_dock_guidance.geometry.calibration import Board
from auv_dock_guidance.geometry.camera import CameraModel

_TEXTURE_PX_PER_SQUARE = 40
_MAX_SUPERSAMPLE = 4
_COARSE_STEP = 4  # pixels between the rays solved exactly
_WALL_GREY = 110


@lru_cache(maxsize=4)
def _coarse_rays(camera: CameraModel) -> tuple[np.ndarray, np.ndarray]:
    """Rays (normalized x, y) and fold validity at every ``_COARSE_STEP``-th pixel, from a
    step before the image to a step past it: the lens model's own solver, run on few points."""
    ys = np.arange(-_COARSE_STEP, camera.height + 2 * _COARSE_STEP, _COARSE_STEP, dtype=np.float64)
    xs = np.arange(-_COARSE_STEP, camera.width + 2 * _COARSE_STEP, _COARSE_STEP, dtype=np.float64)
    return camera.pixels_to_normalized(np.stack(np.meshgrid(xs, ys), axis=-1))


@lru_cache(maxsize=4)
def _rays(camera: CameraModel, supersample: int) -> tuple[np.ndarray, np.ndarray]:
    """Rays through ``supersample`` x ``supersample`` points in each pixel and whether each is
    valid: interpolated between the coarse rays, then made exact by Newton steps on the lens
    model (its own solver at every sample would cost many times as much)."""
    xy, valid = _coarse_rays(camera)
    u = (np.arange(camera.width * supersample) + 0.5) / supersample - 0.5  # sample positions in pixels
    v = (np.arange(camera.height * supersample) + 0.5) / supersample - 0.5
    target = np.stack(np.meshgrid(u, v), axis=-1)
    map_u = ((target[..., 0] + _COARSE_STEP) / _COARSE_STEP).astype(np.float32)
    map_v = ((target[..., 1] + _COARSE_STEP) / _COARSE_STEP).astype(np.float32)
    start = cv2.remap(xy.astype(np.float32), map_u, map_v, cv2.INTER_LINEAR).astype(np.float64)
    inside = cv2.remap(valid.astype(np.float32), map_u, map_v, cv2.INTER_LINEAR) > 0.999
    fine, error_px = _newton_to_pixels(camera, start, target)
    return fine, inside & (error_px < 0.01) & camera.normalized_valid(fine)


def _newton_to_pixels(camera: CameraModel, xy: np.ndarray, target: np.ndarray, steps: int = 3
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Normalized points moved by Newton steps until they project onto ``target`` pixels."""
    h = 1e-6
    along_x, along_y = np.array([h, 0.0]), np.array([0.0, h])
    for _ in range(steps):
        residual = camera.normalized_to_pixels(xy) - target
        dx = (camera.normalized_to_pixels(xy + along_x) - camera.normalized_to_pixels(xy - along_x)) / (2 * h)
        dy = (camera.normalized_to_pixels(xy + along_y) - camera.normalized_to_pixels(xy - along_y)) / (2 * h)
        det = dx[..., 0] * dy[..., 1] - dy[..., 0] * dx[..., 1]
        det = np.where(np.abs(det) < 1e-12, 1e-12, det)
        xy = xy - np.stack([(dy[..., 1] * residual[..., 0] - dy[..., 0] * residual[..., 1]) / det,
                            (-dx[..., 1] * residual[..., 0] + dx[..., 0] * residual[..., 1]) / det], axis=-1)
    error = camera.normalized_to_pixels(xy) - target
    return xy, np.hypot(error[..., 0], error[..., 1])


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


def apparent_square_px(camera: CameraModel, board: Board, rotation: np.ndarray, translation: np.ndarray) -> float:
    """The side of a square in pixels at the board's centre, seen face on."""
    centre = translation + rotation @ np.array([(board.columns - 1) / 2, (board.rows - 1) / 2, 0.0]) * board.square_m
    return float(camera.focal_px * board.square_m / centre[2])


def render_board(
    camera: CameraModel,
    board: Board,
    rotation: np.ndarray,
    translation: np.ndarray,
    rng: np.random.Generator,
    noise: float = 2.0,
    blur_sigma: float = 0.7,
    jpeg_quality: int | None = None,
) -> np.ndarray:
    """One grey view of the board; the board's first inner corner sits at ``translation``.

    ``rotation`` (3x3) takes board coordinates (x along columns, y along rows) to the camera frame.
    """
    # Enough samples per pixel that each covers about one texel of the printed board, averaged
    # as a sensor integrates light over each pixel's area: point samples of a small board's
    # sharp print would put every edge on the pixel grid.
    texels_per_pixel = _TEXTURE_PX_PER_SQUARE / apparent_square_px(camera, board, rotation, translation)
    supersample = int(np.clip(math.ceil(texels_per_pixel), 1, _MAX_SUPERSAMPLE))
    sharp = _sample_board(*_rays(camera, supersample), board, rotation, translation)
    if supersample > 1:
        sharp = cv2.resize(sharp, (camera.width, camera.height), interpolation=cv2.INTER_AREA)
    image = np.asarray(cv2.GaussianBlur(sharp, (0, 0), blur_sigma), dtype=np.float32)
    image += rng.normal(0, noise, image.shape).astype(np.float32)
    grey = np.clip(image, 0, 255).astype(np.uint8)
    if jpeg_quality is None:
        return grey
    _, data = cv2.imencode(".jpg", grey, [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality])
    return np.asarray(cv2.imdecode(data, cv2.IMREAD_GRAYSCALE), dtype=np.uint8)


def _sample_board(xy: np.ndarray, valid: np.ndarray, board: Board, rotation: np.ndarray,
                  translation: np.ndarray) -> np.ndarray:
    """The board texture (float32) where each ray meets the board plane; the wall elsewhere."""
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
    texture = board_texture(board).astype(np.float32)
    return cv2.remap(texture, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                     borderValue=_WALL_GREY)


def true_corners(camera: CameraModel, board: Board, rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """Where the inner corners of a rendered view really are (N, 2) pixels, row by row."""
    pixels, _ = camera.project(board.object_points().astype(float) @ rotation.T + translation)
    return pixels


def random_poses(
    camera: CameraModel,
    board: Board,
    count: int,
    rng: np.random.Generator,
    square_px: float | None = None,
    max_tilt_deg: float = 35.0,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Board poses (rotation, translation) spread over the image (centre and towards the
    corners), tilted up to ``max_tilt_deg`` about each image axis and rolled up to 20 deg.

    Without ``square_px`` the board covers 35-50 % of the image width; with it, its squares
    are about that many pixels across (within -10/+20 %). Every pose shows the whole printed
    sheet, its white margin included, as a calibration photo must.
    """
    width_m, height_m = (board.columns - 1) * board.square_m, (board.rows - 1) * board.square_m
    # The printed sheet's outline: one square of board and one of white margin beyond the inner corners.
    low_x, low_y, high_x, high_y = -2, -2, board.columns + 1, board.rows + 1
    outline = np.array([[low_x, low_y, 0], [high_x, low_y, 0], [high_x, high_y, 0], [low_x, high_y, 0]],
                       dtype=float) * board.square_m
    tilt = math.radians(max_tilt_deg)
    poses = []
    for i in range(count):
        for attempt in range(200):
            if square_px is None:
                distance = width_m * camera.fx / (rng.uniform(0.35, 0.5) * camera.width)
            else:
                distance = camera.fx * board.square_m / (square_px * rng.uniform(0.9, 1.2))
            spread = 1.0 - 0.9 * attempt / 200  # aim nearer the centre after each miss
            target = spread * np.array([(i % 3 - 1) * 0.28, ((i // 3) % 3 - 1) * 0.1]) + rng.normal(0, 0.02, 2)
            rvec = rng.uniform(-1, 1, 3) * np.array([tilt, tilt, math.radians(20)])
            rotation, _ = cv2.Rodrigues(rvec)
            centre = np.array([target[0] * distance, target[1] * distance, distance])
            translation = centre - rotation @ np.array([width_m / 2, height_m / 2, 0.0])
            pixels, valid = camera.project(outline @ rotation.T + translation)
            inside = (pixels[:, 0] >= 0) & (pixels[:, 0] <= camera.width - 1) & (pixels[:, 1] >= 0) & (
                pixels[:, 1] <= camera.height - 1)
            if valid.all() and inside.all():
                poses.append((rotation, translation))
                break
        else:
            raise ValueError(f"no view of a {board.columns}x{board.rows} board fits a {camera.width}x{camera.height} "
                             "image at that size")
    return poses


def random_views(
    camera: CameraModel,
    board: Board,
    count: int,
    seed: int,
    square_px: float | None = None,
    noise: float = 2.0,
    blur_sigma: float = 0.7,
    jpeg_quality: int | None = None,
    max_tilt_deg: float = 35.0,
) -> list[np.ndarray]:
    """Rendered views at the poses of ``random_poses`` (see there)."""
    rng = np.random.default_rng(seed)
    return [render_board(camera, board, rotation, translation, rng, noise, blur_sigma, jpeg_quality)
            for rotation, translation in random_poses(camera, board, count, rng, square_px, max_tilt_deg)]
