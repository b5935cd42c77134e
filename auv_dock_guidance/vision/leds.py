"""LED evidence that survives bloom: compact bright blobs found at the LED's own scale.

A real LED blooms: its core saturates to white and a halo of its colour fades over
several pixels. In the brightest channel the halo saturates too and the LED is a flat
plateau (often merged with the lit funnel beside it); in the mean of the channels only
the white core reaches full scale, so the LED stays a compact peak whatever its colour.

On a top-hat of that channel (the search copy's; the opening removes the funnel and
other wide bright regions) every local maximum is a candidate. Its scale is the box size
whose centre-surround contrast (mean of a box minus the mean of the box twice as wide
around it) is largest, measured on an integral image; ridges (cables, rims, edges) are
dropped by the ratio of the curvatures at that scale, and points inside a bright region
(texture on the lit funnel) by their surroundings: a point source is darker all round,
over most of a circle a few blob radii out, and nothing bright passes through it. A blob
of the ring is later reduced to an intensity-weighted centroid at full resolution, and
its glow measured (`refined`): the colour of the light it adds around its core. An LED
glows in its own colour; a bright spot on what the LEDs light (a corner of a white
funnel, a bolt on its rim) adds light of that surface's colour, and the LEDs of one ring,
being one kind of LED, glow alike.

A funnel lit brighter than the sensor takes is one white plateau, and LEDs just outside
its rim bloom into it: the top-hat sees the plateau's parts between the vanes as lights
and the LEDs not at all. When no ring is found and the frame holds such a region
(`lit_region`), the lights are looked for again as bumps on its outline: a round opening
about a third of the region's radius wide fits between the vanes but not into an LED, so
what it removes near the region is the LEDs' share outside the rim (its centroid lies a
pixel or two outside the LED's centre: ranges come out a few percent short).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import cv2
import numpy as np

from auv_dock_guidance.vision.components import components
from auv_dock_guidance.vision.levels import median, median_and_mad, pixel_median

_SCALES = np.array([1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0])  # box half widths tried, search-copy pixels
_RESPONSE_SIGMAS = 5.0  # a blob's centre-surround contrast must stand this many noise deviations clear
_MAX_CURVATURE_RATIO = 10.0  # curvature ratio above which a peak is a ridge (Lowe's edge test)
LIT_LEVEL = 235.0  # mean-channel level of a region at full scale (white, saturated)
_LIT_MIN_RADIUS = 6.0  # copy pixels: a lit region smaller than this is an LED, not a funnel
_RIM_OPENING_SHARE = 0.35  # round opening / radius of the lit region: fits between vanes, not into an LED
_SURROUND_RADII = 2.5  # blob radii out to the circle that must be mostly darker
_HALO_REACH = 5.0  # search-copy pixels: a bloom's halo reaches this far; a small core is also looked at from there
_SURROUND_SAMPLES = 16
_ANGLES = np.linspace(0.0, 2.0 * math.pi, _SURROUND_SAMPLES, endpoint=False)
_GLOW_INNER, _GLOW_OUTER = 1.2, 2.5  # annulus where a blob's glow is measured, in blob radii
_GLOW_KNOWN = 10.0  # grey levels of glow below which its colour is not told
COLOURED_GLOW_SATURATION = 0.3  # glow saturation from which light is clearly coloured (white LEDs: below)
_SAME_HUE_COSINE = 0.5  # glows of one hue, off grey, point within 60 deg of each other (water tints them)


@dataclass(frozen=True)
class LedBlob:
    """One compact light: centre (full-resolution pixels), radius, and how bright it is."""

    u: float
    v: float
    radius_px: float  # half width of its best box, full-resolution pixels
    peak: float  # grey levels of its core above its surroundings (mean of the channels)
    strength: float  # centre-surround contrast in noise deviations
    isolated: bool = True  # darker all round: may seed a ring (else it sits in a glow and can only complete one)
    glow_bgr: tuple[float, float, float] | None = None  # light it adds around its core over the water (`refined`)
    on_outline: bool = False  # a bump on a lit region's outline: its size is its part outside the rim


def mean_channel(image: np.ndarray) -> np.ndarray:
    """The mean of the colour channels: only a white (saturated) core reaches full scale."""
    if image.ndim == 2:
        return image
    return cv2.transform(image, np.full((1, 3), 1.0 / 3.0, np.float32))


def find_leds(small: np.ndarray, scale: float, background_px: int, max_count: int = 48,
              origin: tuple[int, int] = (0, 0), lit: LitRegion | None = None) -> list[LedBlob]:
    """Compact bright blobs, strongest first, at most ``max_count``; centres from the copy.

    ``small`` is the search copy at ``scale`` of the frame, or of the part of it whose top
    left corner is ``origin`` (full-resolution pixels), or the copy's `mean_channel` made
    already; ``background_px`` the width of the top-hat's opening on it (wider than any LED,
    narrower than the lit funnel).
    ``lit`` instead: the LEDs as bumps on the outline of that lit region, which they merge
    with (a funnel brighter than the sensor takes), found by a round opening that fits
    between the funnel's vanes but not into an LED.
    """
    gray = mean_channel(small)
    if lit is not None:
        k = max(5, int(round(_RIM_OPENING_SHARE * lit.radius))) | 1
        disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
        tophat = cv2.subtract(gray, cv2.morphologyEx(gray, cv2.MORPH_OPEN, disc))
        tophat[cv2.dilate(lit.mask, disc, iterations=2) == 0] = 0  # bumps on its outline, not corners elsewhere
    else:
        k = background_px | 1
        opened = cv2.morphologyEx(gray, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_RECT, (k, k)))
        tophat = cv2.subtract(gray, cv2.blur(opened, (k, k)))
    smooth = cv2.GaussianBlur(tophat, (0, 0), 1.0)
    typical, deviation = median_and_mad(smooth[::4, ::4])
    noise = max(0.5, 1.4826 * deviation)
    level = typical + _RESPONSE_SIGMAS * noise
    maxima = (smooth >= cv2.dilate(smooth, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5)))) & (smooth > level)
    _, _, centres = components(maxima.astype(np.uint8))
    if not len(centres):
        return []
    xy = np.round(centres).astype(np.int64)  # one point per maximum: a saturated plateau is one
    heights = smooth[xy[:, 1], xy[:, 0]]
    xy = xy[np.argsort(-heights, kind="stable")][: 8 * max_count]
    x, y = xy[:, 0].astype(np.int64), xy[:, 1].astype(np.int64)
    contrast = _centre_surround(cv2.integral(tophat), x, y)  # (points, scales)
    best = np.argmax(contrast, axis=1)
    strength = contrast[np.arange(len(x)), best] / noise
    radius = _SCALES[best]
    keep = (strength > _RESPONSE_SIGMAS) & _round(smooth.astype(np.float32), x, y, radius)
    water = pixel_median(gray[::4, ::4])
    peak, isolated = _surround_contrast(cv2.GaussianBlur(gray, (0, 0), 1.0).astype(np.float32), x, y, radius, water)
    keep &= peak > 0  # False for NaN: lines are no lights
    order = np.flatnonzero(keep)
    order = order[np.lexsort((-strength[order], ~isolated[order]))]  # isolated lights first, each by strength
    blobs: list[LedBlob] = []
    for i in order:
        r = float(radius[i]) / scale
        u, v = (x[i] + 0.5) / scale - 0.5 + origin[0], (y[i] + 0.5) / scale - 0.5 + origin[1]
        if any(math.hypot(u - b.u, v - b.v) < max(b.radius_px, r) for b in blobs):
            continue  # the same light seen from another of its maxima
        blobs.append(LedBlob(float(u), float(v), r, float(peak[i]), float(strength[i]), bool(isolated[i]),
                             on_outline=lit is not None))
        if len(blobs) >= max_count:
            break
    return blobs


@dataclass(frozen=True)
class LitRegion:
    """What of a search copy is at full scale, when some of it is wider than an LED: a lit
    funnel (split by its vanes into parts) or a lamp the LEDs may merge with."""

    mask: np.ndarray  # uint8, 1 at full scale, copy pixels
    radius: float  # of the largest part, from its area, copy pixels


def lit_region(small: np.ndarray) -> LitRegion | None:
    """The copy's pixels at full scale, if a part of them is wider than an LED (``small``: the copy or its
    `mean_channel`)."""
    bright = (mean_channel(small) >= LIT_LEVEL).astype(np.uint8)
    _, stats, _ = components(bright)
    if not len(stats):
        return None
    radius = math.sqrt(float(stats[:, cv2.CC_STAT_AREA].max()) / math.pi)
    return LitRegion(bright, radius) if radius >= _LIT_MIN_RADIUS else None


def _centre_surround(integral: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Mean of a box of each half width minus the mean of the frame around it out to twice
    that width, per point and scale (boxes clipped to the image)."""
    h, w = integral.shape[0] - 1, integral.shape[1] - 1

    def box(half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x0 = np.clip(x[:, None] - half, 0, w)
        x1 = np.clip(x[:, None] + half + 1, 0, w)
        y0 = np.clip(y[:, None] - half, 0, h)
        y1 = np.clip(y[:, None] + half + 1, 0, h)
        total = integral[y1, x1] - integral[y0, x1] - integral[y1, x0] + integral[y0, x0]
        return total.astype(np.float64), ((x1 - x0) * (y1 - y0)).astype(np.float64)

    inner_half = np.round(_SCALES).astype(np.int64)[None, :]
    inner, inner_area = box(inner_half)
    outer, outer_area = box(2 * inner_half + 1)
    return inner / inner_area - (outer - inner) / np.maximum(outer_area - inner_area, 1.0)


def _round(smooth: np.ndarray, x: np.ndarray, y: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Both curvatures at the blob's scale are strong: a blob, not a ridge (a cable, a rim, an edge)."""
    h, w = smooth.shape
    step = np.maximum(1, np.round(radius).astype(np.int64))

    def at(dx: np.ndarray | int, dy: np.ndarray | int) -> np.ndarray:
        return smooth[np.clip(y + dy, 0, h - 1), np.clip(x + dx, 0, w - 1)]

    centre = at(0, 0)
    dxx = at(step, 0) + at(-step, 0) - 2.0 * centre
    dyy = at(0, step) + at(0, -step) - 2.0 * centre
    dxy = 0.25 * (at(step, step) - at(-step, step) - at(step, -step) + at(-step, -step))
    trace, det = dxx + dyy, dxx * dyy - dxy * dxy
    ratio = _MAX_CURVATURE_RATIO
    with np.errstate(divide="ignore", invalid="ignore"):
        return (trace < 0) & (det > 0) & (trace * trace < det * (ratio + 1.0) ** 2 / ratio)


def _surround_contrast(gray: np.ndarray, x: np.ndarray, y: np.ndarray, radius: np.ndarray,
                       water: float) -> tuple[np.ndarray, np.ndarray]:
    """How far each blob's core stands above its surroundings (grey levels), and whether it is
    a point source standing clear of them. It is not where most of a circle a few blob radii
    out is nearly as bright, or where the core stands above it by less than a third of its
    height above the water (a spot on a lit region); the LEDs of a ring that blooms into one
    glow fail these tests too, which is why such lights are kept, to complete a ring. A bright
    LED's halo can reach past that circle when the blob's scale is its core's, a pixel or two,
    so a light that stands clear on a circle beyond the halo is a point source too. NaN where
    the near circle is bright at two opposite points and dark between them: a line passing
    through (a cable, a rim, a fixture's ring, a caustic; a light beside a lit region is
    bright on one side only)."""
    near = _SURROUND_RADII * np.maximum(radius, 1.0)
    height, clear, line = _on_circle(gray, x, y, near, water)
    _, clear_beyond_halo, _ = _on_circle(gray, x, y, np.maximum(near, _HALO_REACH), water)
    return np.where(line, np.nan, height), clear | (clear_beyond_halo & ~line)


def _on_circle(gray: np.ndarray, x: np.ndarray, y: np.ndarray, reach: np.ndarray,
               water: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per point, on the circle of radius ``reach`` round it: the core's height above the
    circle's median, whether it stands clear of the circle (a point source seen from there),
    and whether a line crosses the circle."""
    h, w = gray.shape
    xs = np.clip(np.round(x[:, None] + reach[:, None] * np.cos(_ANGLES)).astype(np.int64), 0, w - 1)
    ys = np.clip(np.round(y[:, None] + reach[:, None] * np.sin(_ANGLES)).astype(np.int64), 0, h - 1)
    circle = gray[ys, xs]
    around = np.sort(circle, axis=1)
    core = gray[y, x]
    darkest = around[:, 0]
    typical = 0.5 * (around[:, _SURROUND_SAMPLES // 2 - 1] + around[:, _SURROUND_SAMPLES // 2])
    bright = circle >= (core - 0.5 * (core - darkest))[:, None]
    half, quarter = _SURROUND_SAMPLES // 2, _SURROUND_SAMPLES // 4
    across = (bright & np.roll(bright, half, axis=1)
              & ~np.roll(bright, quarter, axis=1) & ~np.roll(bright, -quarter, axis=1))
    line = across.any(axis=1)
    clear = ((core - darkest > 0) & (core - typical >= 0.5 * (core - darkest))
             & (core - typical >= (core - water) / 3.0) & ~line)
    return core - typical, clear, line


def refined(image: np.ndarray, blob: LedBlob, water_bgr: np.ndarray | None = None) -> LedBlob:
    """The blob with its centroid measured at full resolution and, given the water's colour
    (``water_bgr``, the frame's typical pixel), its glow."""
    u, v = _centroid(image, blob.u, blob.v, blob.radius_px)
    glow = None if water_bgr is None or image.ndim == 2 else _glow(image, u, v, blob.radius_px, water_bgr)
    return replace(blob, u=u, v=v, glow_bgr=glow)


def water_colour(small: np.ndarray) -> np.ndarray:
    """The typical colour of a frame (its median pixel): the water most lights are seen against."""
    if small.ndim == 2:
        return np.array([float(np.median(small[::4, ::4]))] * 3)
    return np.median(small[::4, ::4].reshape(-1, 3), axis=0).astype(np.float64)


def _glow(image: np.ndarray, u: float, v: float, radius: float, water_bgr: np.ndarray) -> tuple[float, float, float]:
    """The light a blob adds around its core: mean colour over the water of the brighter half of
    an annulus just outside the core (1.2-2.5 radii). The brighter half is the glow's side where
    the light sits against something bright (the funnel): there the glow, not the surface, is seen."""
    h, w = image.shape[:2]
    r = max(2.0, radius)
    x0, x1 = max(0, int(u - _GLOW_OUTER * r)), min(w, int(u + _GLOW_OUTER * r) + 1)
    y0, y1 = max(0, int(v - _GLOW_OUTER * r)), min(h, int(v + _GLOW_OUTER * r) + 1)
    distance = np.hypot(np.arange(x0, x1)[None, :] - u, np.arange(y0, y1)[:, None] - v)
    annulus = image[y0:y1, x0:x1][(distance >= _GLOW_INNER * r) & (distance <= _GLOW_OUTER * r)].astype(np.float64)
    if len(annulus) == 0:
        return 0.0, 0.0, 0.0
    brightest = annulus.max(axis=1)
    excess = annulus[brightest >= median(brightest)].mean(axis=0) - water_bgr
    return float(excess[0]), float(excess[1]), float(excess[2])


def glow_saturation(glow_bgr: tuple[float, float, float] | None) -> float:
    """How coloured a glow is: 0 for white light, 1 for light of one channel only; NaN where it
    is not told (no colour image, or too little glow to tell: a far, faint LED)."""
    top = max(glow_bgr) if glow_bgr is not None else 0.0
    if glow_bgr is None or top <= 0.0 or math.hypot(*glow_bgr) < _GLOW_KNOWN:
        return math.nan
    return (top - max(0.0, min(glow_bgr))) / top


def glow_matches(glow_bgr: tuple[float, float, float] | None, bgr: tuple[float, float, float]) -> bool:
    """Whether a blob's glow has the hue of LEDs of colour ``bgr`` (its direction off grey in
    colour space): a lamp or glint of another colour, or of none where the LEDs have one,
    does not. Water tints every glow, so only the hue is compared, loosely; white LEDs, and
    glows too faint to tell, match any."""
    colour = np.array(bgr, np.float64) - np.mean(bgr)
    saturation = glow_saturation(glow_bgr)
    if glow_bgr is None or not np.any(colour) or math.isnan(saturation):
        return True
    if saturation < COLOURED_GLOW_SATURATION:
        return False
    hue = np.array(glow_bgr, np.float64) - np.mean(glow_bgr)
    return float(hue @ colour) >= _SAME_HUE_COSINE * float(np.linalg.norm(hue) * np.linalg.norm(colour))


def _centroid(image: np.ndarray, u: float, v: float, radius: float) -> tuple[float, float]:
    """Intensity-weighted centroid of the core (above half its height over the local floor)."""
    h, w = image.shape[:2]
    reach = max(2, int(math.ceil(1.5 * radius)))
    x0, x1 = max(0, int(round(u)) - reach), min(w, int(round(u)) + reach + 1)
    y0, y1 = max(0, int(round(v)) - reach), min(h, int(round(v)) + reach + 1)
    patch = mean_channel(image[y0:y1, x0:x1]).astype(np.float32)
    if patch.size == 0:
        return u, v
    floor, top = float(patch.min()), float(patch.max())
    weight = np.clip(patch - (floor + 0.5 * (top - floor)), 0.0, None)
    xs, ys = np.arange(x0, x1)[None, :], np.arange(y0, y1)[:, None]
    inside = (xs - u) ** 2 + (ys - v) ** 2 <= reach * reach
    weight *= inside
    total = float(weight.sum())
    if total <= 0:
        return u, v
    return float((weight * xs).sum() / total), float((weight * ys).sum() / total)
