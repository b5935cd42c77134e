"""Stage 1: where to look. Bright regions on a small copy of the frame, as windows to refine.

The brightest colour channel (an LED of any colour is bright in its own channel), minus
a local background (a morphological opening wider than the LED strip, so surface light
gradients and backscatter do not count), cut just above the noise floor and again
halfway to the brightest light in view, grouped at several gap widths.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Generator, Sequence

import cv2
import numpy as np

from auv_dock_guidance.vision.components import components
from auv_dock_guidance.vision.config import DetectorConfig
from auv_dock_guidance.vision.image_input import intensity
from auv_dock_guidance.vision.levels import median_and_mad

Box = tuple[int, int, int, int]  # x0, y0, x1, y1 in full-resolution pixels
Window = tuple[Box, float]  # a box to refine and the radius the ring is expected to have in it
Extent = tuple[float, float, float, float]  # x0, y0, x1, y1 of a region, full-resolution px


def search_copy(image: np.ndarray, config: DetectorConfig, lens_scale: float,
                box: Box | None = None) -> tuple[np.ndarray, float]:
    """The small copy the search works on (of the whole frame, or of ``box`` in it), and its
    scale: the ring keeps its size in it, whatever the lens."""
    s = min(1.0, config.search_scale / lens_scale)
    part = image if box is None else image[box[1]:box[3], box[0]:box[2]]
    return (part if s == 1.0 else cv2.resize(part, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)), s


def picture_area(small: np.ndarray, scale: float, black: float = 16.0) -> Box:
    """The part of the frame with a picture in it (full-resolution box): video capture often
    leaves black columns or rows at the sides, and a ring cut there is cut by them."""
    gray = intensity(small)
    columns = cv2.reduce(gray, 0, cv2.REDUCE_MAX).ravel() > black
    rows = cv2.reduce(gray, 1, cv2.REDUCE_MAX).ravel() > black
    if not columns.any() or not rows.any():
        return 0, 0, int(round(small.shape[1] / scale)), int(round(small.shape[0] / scale))
    x0, x1 = int(np.argmax(columns)), len(columns) - int(np.argmax(columns[::-1]))
    y0, y1 = int(np.argmax(rows)), len(rows) - int(np.argmax(rows[::-1]))
    return (int(math.floor(x0 / scale)), int(math.floor(y0 / scale)),
            int(math.ceil(x1 / scale)), int(math.ceil(y1 / scale)))


Copy = tuple[np.ndarray, float]  # the search copy and its scale
SearchSteps = Generator[None, np.ndarray, tuple[list[Window], Copy]]
BANDS = 4  # slices of the search copy when the search is spread over frames


def search(image: np.ndarray, config: DetectorConfig, lens_scale: float, min_radius_px: float,
           copy: Copy | None = None) -> list[Window]:
    """Bright regions on a small copy: (full-resolution box, radius estimate) each.

    Regions are grouped at several gap widths, so the separate LEDs of a ring come out
    as one region at the width that bridges their spacing. The light is cut at two
    levels: just above the noise (faint, far rings) and halfway to the brightest light
    in view, where the LEDs come apart from dimmer light they touch (a web of caustics,
    glow on structure) that would otherwise make one region of the whole frame.
    ``lens_scale`` is the focal length relative to the paper's camera; ``min_radius_px``
    the smallest ring accepted (full resolution); ``copy`` the search copy when made already.
    """
    steps = search_steps(config, lens_scale, min_radius_px, copy=copy)
    next(steps)
    try:
        while True:
            steps.send(image)
    except StopIteration as done:
        return done.value[0]


def search_steps(config: DetectorConfig, lens_scale: float, min_radius_px: float, bands: int = 1,
                 copy: Copy | None = None) -> SearchSteps:
    """`search` in slices of about a millisecond: send a frame for each slice (the same one
    throughout, or each new frame: the copy is then made of ``bands`` slices of successive
    frames, where the marker has barely moved); the generator's value is the windows and
    the search copy."""
    c = config
    lens = lens_scale
    image = yield
    small, s = copy if copy is not None else (yield from _copy_steps(image, config, lens_scale, bands))
    gray = intensity(small)
    k = c.search_background_px | 1
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (k, k))
    background = cv2.blur(cv2.morphologyEx(gray, cv2.MORPH_OPEN, kernel), (k, k))
    tophat = cv2.subtract(gray, background)
    typical, deviation = median_and_mad(tophat[::2, ::2])
    noise = 1.4826 * deviation
    # Search wide: a low floor finds faint, far rings; the refinement's floor decides.
    floor = typical + max(c.search_floor_grey, c.search_floor_noise_sigmas * noise)
    bright = floor + 0.5 * (float(tophat.max()) - floor)
    h, w = image.shape[:2]
    min_radius = 0.7 * max(c.selection.min_radius_px, min_radius_px)  # smaller: no ring we accept
    boxes: list[Window] = []
    cores: list[tuple[Extent, float]] = []  # each region's own extent (the grouping's growth taken off)
    low, high = (cv2.threshold(tophat, level, 255, cv2.THRESH_BINARY)[1] for level in (floor, bright))
    for mask, gap_px in [*itertools.product([low], c.search_gaps_px), (high, 0), (high, 32)]:
        kernel_size = int(round(gap_px * lens * s)) | 1
        image = yield
        grouped = mask if kernel_size <= 1 else cv2.dilate(
            mask, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (kernel_size, kernel_size))
        )
        labels, stats, _ = components(grouped)
        grow = (kernel_size - 1) // 2  # how far the grouping widened each region (small-copy px)
        found = []
        for i, row in enumerate(stats, start=1):
            x, y, bw, bh = (int(v) for v in row[:4])
            x0, y0, x1, y1 = (x - 1) / s, (y - 1) / s, (x + bw + 1) / s, (y + bh + 1) / s
            radius = max(1.0, 0.5 * max(x1 - x0, y1 - y0) - 0.5 * (kernel_size - 1) / s)
            if radius >= min_radius:
                peak = float(tophat[y:y + bh, x:x + bw][labels[y:y + bh, x:x + bw] == i].max())
                core = (x0 + grow / s, y0 + grow / s, x1 - grow / s, y1 - grow / s)
                found.append((peak, radius, (x0, y0, x1, y1), core))
        found.sort(reverse=True)  # brightest first: a web of caustics or glow must not crowd the LEDs out
        for _, radius, (x0, y0, x1, y1), core in found[: c.max_candidates]:
            if _covered(core, radius, cores):
                continue  # a wider grouping that added nothing: the same region, refined already
            cores.append((core, radius))
            margin = 0.25 * radius + 12 + 0.5 * kernel_size / s
            box = (
                max(0, int(x0 - margin)),
                max(0, int(y0 - margin)),
                min(w, int(math.ceil(x1 + margin))),
                min(h, int(math.ceil(y1 + margin))),
            )
            if not _covered(box, radius, boxes):
                boxes.append((box, radius))
    return boxes, (small, s)


def _copy_steps(image: np.ndarray, config: DetectorConfig, lens_scale: float,
                bands: int) -> Generator[None, np.ndarray, Copy]:
    """The search copy, made ``bands`` slices of successive frames at a time where that is
    exact (whole blocks of pixels: a slice of the frame gives exactly its slice of the copy)."""
    s = min(1.0, config.search_scale / lens_scale)
    factor = round(1.0 / s)
    if bands == 1 or s == 1.0 or abs(factor * s - 1.0) > 1e-9 or image.shape[0] % factor or image.shape[1] % factor:
        return search_copy(image, config, lens_scale)
    small = np.empty((image.shape[0] // factor, image.shape[1] // factor, *image.shape[2:]), image.dtype)
    edges = [round(i * small.shape[0] / bands) for i in range(bands + 1)]
    for r0, r1 in itertools.pairwise(edges):
        small[r0:r1] = cv2.resize(image[r0 * factor:r1 * factor], None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
        image = yield
    return small, s


def _covered(box: Extent, radius: float, boxes: Sequence[tuple[Extent, float]]) -> bool:
    """A window adds nothing when another nearly the same, or one at most twice as large that
    contains it, is already refined."""
    return any(
        _overlap(box, other) > 0.7
        or (other[0] <= box[0] and other[1] <= box[1] and other[2] >= box[2] and other[3] >= box[3]
            and other_radius <= 2.0 * radius)
        for other, other_radius in boxes
    )


def _overlap(a: Extent, b: Extent) -> float:
    """Intersection over union of two boxes (x0, y0, x1, y1)."""
    ix = max(0, min(a[2], b[2]) - max(a[0], b[0]))
    iy = max(0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = ix * iy
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / union if union > 0 else 0.0
