"""Blooming point lights: a clipping sensor behind a point-spread function with a wide tail.

A bright LED seen through water and a housing port images as a narrow core (its dome,
blurred by the lens) plus a wide tail of glare and forward scatter. The tail is a Moffat
profile, (1 + r^2 / s^2) ** -1.5, the usual model of a lens's glare wings; it holds a share
of the light. LEDs are tens to thousands of times brighter than what the exposure was set
for, so the sensor clips: every channel saturates in the core (white), only the LED's own
colour saturates in the inner tail (a coloured halo), and the tail fades into the water
further out. Neighbouring halos add up and merge.

The tail is drawn analytically per light and only where it is above a fraction of a grey
level: near the light at full resolution, the smooth remainder on a grid four times
coarser with one upsampling per frame, so a dozen blooming LEDs cost about a millisecond
instead of a full-frame convolution with a kernel hundreds of pixels wide.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

_BETA = 1.5  # Moffat exponent: glare wings fall as r^-3
_COARSE = 4  # decimation of the grid the far tail is drawn on
_FLOOR = 3e-3  # tail values below this (full-scale units, under a grey level) are not drawn


class Glare:
    """The tails of every point light in one frame; ``finish`` adds them to the light layer."""

    def __init__(self, shape: tuple[int, int], tail_share: float, tail_px: float, max_radius_px: float) -> None:
        self.tail_share = tail_share
        self.scale_px = max(0.5, tail_px)
        self.max_radius_px = max_radius_px
        h, w = shape
        self._shape = shape
        self._coarse = np.zeros((-(-h // _COARSE), -(-w // _COARSE)), np.float32)
        self._box: list[int] | None = None  # touched coarse cells: j0, j1, i0, i1

    def add(self, light: np.ndarray, u: float, v: float, flux: float) -> None:
        """The tail of a light of total ``flux`` (full-scale units x px^2) centred at (u, v)."""
        s = self.scale_px
        peak = self.tail_share * flux * (_BETA - 1.0) / (math.pi * s * s)  # the tail integrates to its share
        if peak <= _FLOOR:
            return
        reach = min(self.max_radius_px, s * math.sqrt((peak / _FLOOR) ** (1.0 / _BETA) - 1.0))
        # The far part is the tail softened over a (smooth at the coarse grid's scale); the
        # near part, tail minus far part, falls as r^-5 and is drawn at full resolution.
        soft = max(s, 2.0 * _COARSE)
        near_peak = peak * _BETA * (soft / s) ** 2
        near_reach = min(reach, s * math.sqrt(max(0.0, (near_peak / _FLOOR) ** (1.0 / (_BETA + 1.0)) - 1.0)))
        inv_s2 = 1.0 / (s * s)
        soft2 = soft * soft
        h, w = self._shape
        window = _window(u, v, near_reach, 1, 0.0, w, h)
        if window is not None:
            xs, ys, x0, y0 = window
            r2 = (xs * xs)[None, :] + (ys * ys)[:, None]
            edge = np.float32(near_reach**2)
            near = _moffat(r2, inv_s2) - _moffat(r2 + soft2, inv_s2)
            near -= float(_moffat(edge, inv_s2) - _moffat(edge + soft2, inv_s2))
            np.maximum(near, 0.0, out=near)
            light[y0:y0 + len(ys), x0:x0 + len(xs)] += peak * near
        gh, gw = self._coarse.shape
        window = _window(u, v, reach, _COARSE, 0.5 * _COARSE - 0.5, gw, gh)
        if window is None:
            return
        xs, ys, j0, i0 = window
        r2 = (xs * xs)[None, :] + (ys * ys)[:, None]
        far = _moffat(r2 + soft2, inv_s2) - float(_moffat(np.float32(reach**2 + soft2), inv_s2))
        np.maximum(far, 0.0, out=far)
        self._coarse[i0:i0 + len(ys), j0:j0 + len(xs)] += peak * far
        box = [j0, j0 + len(xs), i0, i0 + len(ys)]
        self._box = box if self._box is None else [min(self._box[0], box[0]), max(self._box[1], box[1]),
                                                    min(self._box[2], box[2]), max(self._box[3], box[3])]

    def finish(self, light: np.ndarray) -> None:
        """Upsample the far tails (only the touched cells, with a margin) into the light layer."""
        if self._box is None:
            return
        gh, gw = self._coarse.shape
        j0, j1 = max(0, self._box[0] - 1), min(gw, self._box[1] + 1)
        i0, i1 = max(0, self._box[2] - 1), min(gh, self._box[3] + 1)
        block = cv2.resize(self._coarse[i0:i1, j0:j1], ((j1 - j0) * _COARSE, (i1 - i0) * _COARSE),
                           interpolation=cv2.INTER_LINEAR)
        h, w = self._shape
        y0, x0 = i0 * _COARSE, j0 * _COARSE
        y1, x1 = min(h, i1 * _COARSE), min(w, j1 * _COARSE)
        light[y0:y1, x0:x1] += block[: y1 - y0, : x1 - x0]


def _moffat(r2: np.ndarray | np.float32, inv_s2: float) -> np.ndarray:
    q = 1.0 + r2 * np.float32(inv_s2)
    return 1.0 / (q * np.sqrt(q))  # q ** -1.5, cheaper than a power


def _window(u: float, v: float, radius: float, step: int, offset: float, w: int,
            h: int) -> tuple[np.ndarray, np.ndarray, int, int] | None:
    """Grid cells within ``radius`` of (u, v): offsets (x, y) of their centres from it, and the first cell.

    Cell j's centre is at full-resolution pixel j * step + offset (how cv2.resize places
    a grid ``step`` times coarser).
    """
    j0 = max(0, math.floor((u - radius - offset) / step))
    j1 = min(w, math.ceil((u + radius - offset) / step) + 1)
    i0 = max(0, math.floor((v - radius - offset) / step))
    i1 = min(h, math.ceil((v + radius - offset) / step) + 1)
    if j1 <= j0 or i1 <= i0:
        return None
    xs = (np.arange(j0, j1, dtype=np.float32) * step + np.float32(offset - u))
    ys = (np.arange(i0, i1, dtype=np.float32) * step + np.float32(offset - v))
    return xs, ys, j0, i0
