"""What lies behind the dock, as light in image units: relief, struts, caustics and pool walls.

Relief: the floor, walls and dock frame far out of focus. Bars: struts of the dock's
frame, brighter or darker than the water. Caustics: sunlight focused by the waves into a
moving web of thin bright lines on the floor and walls (the zero crossings of a smooth
random field), strongest low in the frame where the floor is. Pool walls: tiles or panels
(some darker, grout lines between), stains and streaks, ring-shaped fixtures that give no
light (drains, lamp housings, hoops: rings a detector must not take for the dock) and
tethers hanging from the surface; the water between takes part of their contrast away.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class PoolWalls:
    """A pool's walls behind the dock; contrasts in image units (1 = 255)."""

    tile_contrast: float = 0.05  # darker tiles and grout lines
    tile_share: float = 0.2  # a tile's width as a share of the frame's
    stain_contrast: float = 0.04  # dark blotches and streaks
    fixtures: int = 1  # ring-shaped fixtures without light of their own
    fixture_contrast: float = 0.06
    cables: int = 0  # tethers from the surface, lit from above
    haze: float = 0.0  # share of the walls' contrast the water in between takes away


def smooth_field(h: int, w: int, cell_y: int, cell_x: int, rng: np.random.Generator) -> np.ndarray:
    """Zero-mean, unit-spread random relief with features about cell_y by cell_x pixels."""
    coarse = rng.normal(size=(h // cell_y + 3, w // cell_x + 3)).astype(np.float32)
    return cv2.resize(coarse, (w + 2 * cell_x, h + 2 * cell_y), interpolation=cv2.INTER_CUBIC)[
        cell_y : cell_y + h, cell_x : cell_x + w]


def background_structure(h: int, w: int, clutter: float, caustics: float, walls: PoolWalls | None,
                         rng: np.random.Generator) -> np.ndarray:
    """All structure behind the dock (h, w), float32 image units."""
    out = np.zeros((h, w), np.float32)
    scale = max(1, w // 480)  # features keep their share of the frame at any resolution
    if clutter:
        cell = 40 * scale
        out += 0.5 * clutter * smooth_field(h, w, cell, cell, rng)
        bars = np.zeros((h, w), np.float32)
        for _ in range(int(rng.integers(0, 4))):
            a, b = rng.uniform(0, 1, 2), rng.uniform(0, 1, 2)
            cv2.line(bars, (int(a[0] * w), int(a[1] * h)), (int(b[0] * w), int(b[1] * h)),
                     float(rng.choice([-1.0, 1.0]) * clutter), int(rng.integers(2, 12)) * scale, cv2.LINE_AA)
        out += cv2.GaussianBlur(bars, (0, 0), float(rng.uniform(1.0, 4.0)) * scale)
    if caustics:
        cell = 24 * scale
        web = np.exp(-((smooth_field(h, w, cell, cell, rng) / 0.15) ** 2))
        out += caustics * web * np.linspace(0.3, 1.0, h, dtype=np.float32)[:, None]
    if walls is not None:
        out += _walls(walls, h, w, rng)
    return out


def _walls(walls: PoolWalls, h: int, w: int, rng: np.random.Generator) -> np.ndarray:
    """Drawn at half resolution and scaled up: the walls are out of focus behind the dock anyway."""
    hh, hw = max(1, h // 2), max(1, w // 2)
    canvas = np.zeros((hh, hw), np.float32)
    if walls.tile_contrast:
        canvas += walls.tile_contrast * _tiles(hh, hw, walls.tile_share, rng)
    if walls.stain_contrast:
        blotches = np.maximum(smooth_field(hh, hw, max(2, hw // 16), max(2, hw // 16), rng) - 0.3, 0.0)
        streaks = np.maximum(smooth_field(hh, hw, max(2, hh // 3), max(2, hw // 60), rng) - 0.5, 0.0)
        canvas -= walls.stain_contrast * (blotches + 0.7 * streaks)
    for _ in range(walls.fixtures):
        centre = (rng.uniform(0, hw), rng.uniform(0, hh))
        radius = rng.uniform(0.04, 0.25) * hw
        axes = (radius, radius * rng.uniform(0.5, 1.0))  # seen at an angle
        angle = math.degrees(rng.uniform(0, math.pi))
        band = max(1, int(round(rng.uniform(0.04, 0.15) * radius)))
        value = walls.fixture_contrast * float(rng.choice([-1.0, 1.0])) * rng.uniform(0.5, 1.0)
        if rng.uniform() < 0.4:  # a drain or a housing: darker inside
            _ellipse(canvas, centre, axes, angle, -0.5 * abs(value), -1)
        _ellipse(canvas, centre, axes, angle, value, band)
    for _ in range(walls.cables):
        top = rng.uniform(0, hw)
        bottom = (top + rng.uniform(-0.15, 0.15) * hw, rng.uniform(0.3, 1.0) * hh)
        cv2.line(canvas, (int(top * 16), 0), (int(bottom[0] * 16), int(bottom[1] * 16)),
                 float(rng.uniform(0.05, 0.25)), 1, cv2.LINE_AA, 4)
    canvas *= np.float32(1.0 - walls.haze)
    return cv2.resize(canvas, (w, h), interpolation=cv2.INTER_LINEAR)


def _ellipse(canvas: np.ndarray, centre: tuple[float, float], axes: tuple[float, float], angle_deg: float,
             value: float, thickness: int) -> None:
    layer = np.zeros_like(canvas)
    cv2.ellipse(layer, (int(centre[0] * 16), int(centre[1] * 16)), (int(axes[0] * 16), int(axes[1] * 16)),
                angle_deg, 0.0, 360.0, 1.0, thickness, cv2.LINE_AA, 4)
    canvas += value * layer


def _tiles(h: int, w: int, tile_share: float, rng: np.random.Generator) -> np.ndarray:
    """Unit-contrast tiles: a slightly rotated grid, some tiles darker, thin dark grout between."""
    cell_x = max(4.0, tile_share * w)
    cell_y = cell_x * rng.uniform(0.7, 1.3)
    theta = rng.uniform(-0.15, 0.15)
    c, s = math.cos(theta), math.sin(theta)
    xs = np.arange(w, dtype=np.float32)[None, :]
    ys = np.arange(h, dtype=np.float32)[:, None]
    tu = (xs * c + ys * s) / np.float32(cell_x) + np.float32(rng.uniform(0, 1))
    tv = (ys * c - xs * s) / np.float32(cell_y) + np.float32(rng.uniform(0, 1))
    iu, iv = np.floor(tu), np.floor(tv)
    shade = rng.uniform(size=(64, 64)).astype(np.float32) < rng.uniform(0.1, 0.5)  # which tiles are dark
    dark = shade[iv.astype(np.int64) % 64, iu.astype(np.int64) % 64]
    grout_px = 0.5 * rng.uniform(0.5, 2.0)
    to_line = np.minimum(np.minimum(tu - iu, iu + 1 - tu) * np.float32(cell_x),
                         np.minimum(tv - iv, iv + 1 - tv) * np.float32(cell_y))
    return -(dark.astype(np.float32) + 0.5 * (to_line < grout_px))
