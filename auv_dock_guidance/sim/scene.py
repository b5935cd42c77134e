"""Synthetic underwater frames of the LED-ring marker with ground truth.

The ring is drawn where the calibrated camera (lens distortion included) sees it; then
the water acts on the light: attenuation with path length, a forward-scatter halo that
grows with turbidity and distance, backscatter veiling light, an ambient gradient from
the surface, a mirrored copy of the ring in the surface (rippled, similar brightness),
lamps and glints, motion blur and sensor noise. What real docks and pools add is there
too, off by default: LEDs of uneven brightness and dead ones, light thrown on the dock's
funnel inside the ring, out-of-focus structure (floor, walls, the dock's frame), sunlight
caustics, particles, lens vignetting and JPEG recording. And what real docks look like on
real video, also off by default: LEDs that bloom (a point-spread function with a wide
tail on a sensor that clips: white cores, coloured halos that merge), a lit white funnel
with dark vanes and a hub inside the ring, pool walls with tiles, stains and ring-shaped
fixtures, and a PAL video chain (colour bleed, interlace, blanking, MPEG/JPEG blocks).
Everything is drawn from a seeded generator, so a (spec, seed) pair is one exact image.

Geometry is given in the camera optical frame (x right, y down, z forward, metres).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from auv_dock_guidance.geometry.camera import CameraModel
from auv_dock_guidance.sim.background import PoolWalls, background_structure
from auv_dock_guidance.sim.dock_body import BodyPatch, Funnel, draw_funnel
from auv_dock_guidance.sim.glare import Glare
from auv_dock_guidance.sim.ring_geometry import mirror_in_surface, ring_points
from auv_dock_guidance.sim.video import VideoRecording, record

_SHIFT = 4  # fixed-point bits for sub-pixel drawing
_SCALE = 1 << _SHIFT


@dataclass(frozen=True)
class Lamp:
    """A distractor light: a small bright disc (lamp, torch) or a glint."""

    u: float
    v: float
    radius_px: float
    gain: float


@dataclass(frozen=True)
class SceneSpec:
    """Everything that determines one rendered frame."""

    marker_center_m: tuple[float, float, float] | None = (0.0, 0.0, 8.0)
    marker_normal: tuple[float, float, float] = (0.0, 0.0, -1.0)  # towards the camera
    marker_radius_m: float = 0.35
    strip_width_m: float = 0.025
    led_count: int = 0  # 0: a continuous strip; otherwise discrete LEDs
    led_bgr: tuple[float, float, float] = (1.0, 0.9, 0.25)  # blue-green
    brightness: float = 1.6  # radiance of the strip before the water, in image units (1 = 255)
    attenuation_per_m: float = 0.12  # beam attenuation c of the water
    halo_fraction_per_m: float = 0.05  # share of light scattered into the halo per metre
    halo_sigma_rad: float = 0.012  # angular spread of the forward-scatter halo
    backscatter: float = 0.10  # veiling light level (image units, 1 = 255)
    ambient_top: float = 0.18  # ambient light at the top of the frame
    ambient_bottom: float = 0.06
    water_bgr: tuple[float, float, float] = (0.85, 0.65, 0.25)
    surface_height_m: float | None = None  # water surface above the camera: reflection on
    surface_up: tuple[float, float, float] = (0.0, -1.0, 0.0)
    reflection_gain: float = 0.8
    ripple_m: float = 0.02  # surface wave amplitude distorting the reflection
    lamps: tuple[Lamp, ...] = ()
    motion_blur_px: float = 0.0
    motion_blur_angle_rad: float = 0.0
    read_noise: float = 2.0  # grey levels, standard deviation
    shot_noise: float = 0.6  # grey levels per sqrt(grey level)
    led_spread: float = 0.0  # LED-to-LED brightness spread (log-normal sigma); strips vary along their length
    dead_share: float = 0.0  # share of the LEDs (or of the strip's length) that is dark
    funnel_glow: float = 0.0  # light on the funnel inside the ring, as a share of the LEDs' radiance
    clutter: float = 0.0  # contrast of out-of-focus structure behind the dock (image units)
    caustics: float = 0.0  # brightness of sunlight caustics on the floor and walls (image units)
    particles: int = 0  # marine snow and bubbles lit by the LEDs and the surface
    vignetting: float = 0.0  # share of the light lost in the image corners
    jpeg_quality: int = 0  # 0: raw frames; otherwise recorded as JPEG at this quality
    led_psf_tail: float = 0.0  # share of each LED's and lamp's light in a wide glare tail (0: no blooming)
    led_psf_tail_rad: float = 0.004  # angular scale of that tail (its Moffat core width)
    funnel: Funnel | None = None  # the dock's lit funnel inside the ring
    walls: PoolWalls | None = None  # tiles, stains, fixtures and tethers behind the dock
    video: VideoRecording | None = None  # analogue video chain the frame went through
    seed: int = 0


@dataclass(frozen=True)
class GroundTruth:
    """Where the marker really is; None fields when no part of it is in view.

    The centre is given whenever some of the ring is in view, also when the frame cuts
    the ring and the centre itself lies outside the image.
    """

    marker_visible: bool  # some of the ring is in the frame
    center_px: tuple[float, float] | None  # projection of the ring centre (distorted pixels)
    radius_px: float | None  # f * R / z
    position_m: tuple[float, float, float] | None
    reflection_center_px: tuple[float, float] | None
    share_in_view: float = 0.0  # share of the ring's circumference inside the frame (blanking excluded)
    leds_in_view: int = 0  # discrete LEDs inside the frame

    @property
    def view(self) -> str:
        """'whole', 'cut' (half of the ring or more in view), 'corner' (less) or 'none'."""
        if not self.marker_visible:
            return "none"
        if self.share_in_view >= 1.0:
            return "whole"
        return "cut" if self.share_in_view >= 0.5 else "corner"


_VIEW_SAMPLES = 720  # points on the ring that decide its share in view


def ground_truth(camera: CameraModel, spec: SceneSpec) -> GroundTruth:
    if spec.marker_center_m is None:
        return GroundTruth(False, None, None, None, None)
    center = np.array(spec.marker_center_m, dtype=float)
    normal = np.array(spec.marker_normal, dtype=float)
    led_points = ring_points(center, normal, spec.marker_radius_m, spec.led_count) if spec.led_count > 0 \
        else np.empty((0, 3))
    points = np.vstack([ring_points(center, normal, spec.marker_radius_m, _VIEW_SAMPLES), led_points, center[None]])
    pix, valid = camera.project(points)
    seen = _in_frame(spec, camera, pix, valid)
    share = float(seen[:_VIEW_SAMPLES].mean())
    leds = int(seen[_VIEW_SAMPLES:-1].sum())
    u, v = (float(x) for x in pix[-1])
    inside = bool(valid[-1]) and share > 0.0
    reflection = None
    if spec.surface_height_m is not None:
        mirrored = mirror_in_surface(center[None], np.array(spec.surface_up), spec.surface_height_m)
        rpix, rvalid = camera.project(mirrored)
        if rvalid[0]:
            reflection = (float(rpix[0, 0]), float(rpix[0, 1]))
    return GroundTruth(
        marker_visible=inside,
        center_px=(u, v) if inside else None,
        radius_px=camera.focal_px * spec.marker_radius_m / center[2] if inside else None,
        position_m=(float(center[0]), float(center[1]), float(center[2])),
        reflection_center_px=reflection,
        share_in_view=share,
        leds_in_view=leds,
    )


def _in_frame(spec: SceneSpec, camera: CameraModel, pix: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Which projected points lie inside the frame (left of any blanking is outside)."""
    left = spec.video.letterbox_px if spec.video is not None else 0
    return valid & (pix[:, 0] >= left) & (pix[:, 0] < camera.width) & (pix[:, 1] >= 0) & (pix[:, 1] < camera.height)


def render(camera: CameraModel, spec: SceneSpec) -> tuple[np.ndarray, GroundTruth]:
    """One BGR uint8 frame of the scene and its ground truth."""
    rng = np.random.default_rng(spec.seed)
    h, w = camera.height, camera.width
    light = np.zeros((h, w), np.float32)
    glare = None
    if spec.led_psf_tail > 0:
        glare = Glare((h, w), spec.led_psf_tail, camera.focal_px * spec.led_psf_tail_rad, 0.3 * max(h, w))
    body: list[BodyPatch] = []
    if spec.marker_center_m is not None:
        center = np.array(spec.marker_center_m, dtype=float)
        normal = np.array(spec.marker_normal, dtype=float)
        leds = _led_pattern(spec, rng)
        _draw_ring(camera, spec, light, center, normal, 1.0, rng, 0.0, leds, glare, body, True)
        if spec.surface_height_m is not None:
            up = np.array(spec.surface_up, dtype=float)
            m_center = mirror_in_surface(center[None], up, spec.surface_height_m)[0]
            m_normal = normal - 2.0 * (normal @ up) * up / (up @ up)
            _draw_ring(camera, spec, light, m_center, m_normal, spec.reflection_gain, rng, spec.ripple_m,
                       leds[::-1], glare, body, False)  # a mirror shows the ring's top at the bottom
    for lamp in spec.lamps:
        _draw_point(light, glare, lamp.u, lamp.v, lamp.radius_px, lamp.gain)
    for _ in range(spec.particles):  # far ones are specks; near the lens, dim out-of-focus discs
        radius = float(np.exp(rng.uniform(np.log(0.5), np.log(6.0))))
        _draw_disc(light, rng.uniform(0, w), rng.uniform(0, h), radius, rng.uniform(0.03, 0.4) / max(1.0, radius))
    if glare is not None:
        glare.finish(light)
    light = _apply_optics(camera, spec, light)
    image = _compose(camera, spec, light, body, rng)
    if spec.video is not None:
        image = record(image, spec.video)
    if spec.jpeg_quality:
        encoded = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(spec.jpeg_quality)])[1]
        decoded = cv2.imdecode(encoded, cv2.IMREAD_COLOR)
        assert decoded is not None  # a JPEG we just made
        image = decoded
    return image, ground_truth(camera, spec)


_PATTERN_BINS = 360  # brightness along a continuous strip, per degree of image angle


def _led_pattern(spec: SceneSpec, rng: np.random.Generator) -> np.ndarray:
    """Relative brightness of each LED (discrete) or of each degree along the strip (continuous).

    LEDs differ from one another (log-normal spread) and some are dead; a strip dims and
    brightens smoothly along its length and may have dark gaps (a broken segment).
    """
    if spec.led_count > 0:
        factors = np.exp(rng.normal(0.0, spec.led_spread, spec.led_count)) if spec.led_spread > 0 \
            else np.ones(spec.led_count)
        if spec.dead_share > 0:
            factors[rng.uniform(size=spec.led_count) < spec.dead_share] = 0.0
        return factors
    angle = np.linspace(0.0, 2 * math.pi, _PATTERN_BINS, endpoint=False)
    pattern = np.ones(_PATTERN_BINS)
    if spec.led_spread > 0:
        wave = sum(rng.normal() * np.sin(k * angle + rng.uniform(0, 2 * math.pi)) / k for k in (1, 2, 3))
        pattern = np.exp(spec.led_spread * wave)
    if spec.dead_share > 0:
        gaps = int(rng.integers(1, 4))
        width = spec.dead_share * _PATTERN_BINS / gaps
        for start in rng.uniform(0, _PATTERN_BINS, gaps):
            pattern[(np.arange(_PATTERN_BINS) - start) % _PATTERN_BINS < width] = 0.0
    return pattern


def _draw_ring(
    camera: CameraModel,
    spec: SceneSpec,
    light: np.ndarray,
    center: np.ndarray,
    normal: np.ndarray,
    gain: float,
    rng: np.random.Generator,
    ripple: float,
    leds: np.ndarray,
    glare: Glare | None,
    body: list[BodyPatch],
    occludes: bool,
) -> None:
    """The ring (or its reflection) into the light layer, its funnel into ``body``; ``leds`` from _led_pattern."""
    distance = float(np.linalg.norm(center))
    if center[2] <= 0.05:
        return
    radius_px_est = camera.focal_px * spec.marker_radius_m / center[2]
    count = int(np.clip(radius_px_est * 2.0 * math.pi / 2.0, 64, 4096))
    count = spec.led_count if spec.led_count > 0 else count
    pts = ring_points(center, normal, spec.marker_radius_m, count)
    if ripple > 0:
        phase = rng.uniform(0, 2 * math.pi, 3)
        t = np.linspace(0, 2 * math.pi, count, endpoint=False)
        wobble = ripple * (np.sin(3 * t + phase[0]) + 0.6 * np.sin(7 * t + phase[1]))
        pts = pts + wobble[:, None] * rng.normal(size=3) / 1.7
    pix, valid = camera.project(pts)
    radiance = spec.brightness * gain * math.exp(-spec.attenuation_per_m * distance)
    width_px = camera.focal_px * spec.strip_width_m / center[2]
    thickness = max(1, int(round(width_px)))
    # Thin strips are drawn as lines carrying the same light per unit length as the strip:
    # narrower than a pixel, they come out dimmer, not thinner.
    value = radiance * width_px / thickness
    if spec.funnel is not None:
        transmission = gain * math.exp(-spec.attenuation_per_m * distance)
        patch = draw_funnel(camera, spec.funnel, center, normal, spec.marker_radius_m, transmission,
                            0.6 + 0.03 * distance, occludes)
        if patch is not None:
            body.append(patch)
    if spec.funnel_glow > 0 and valid.all():
        _draw_funnel_glow(light, pix, radiance * spec.funnel_glow)
    if spec.led_count > 0:
        for (u, v), ok, factor in zip(pix, valid, leds, strict=True):
            if ok and factor > 0:
                _draw_point(light, glare, u, v, max(0.7, width_px * 0.6), factor * radiance * min(1.0, width_px))
        return
    layer = np.zeros(light.shape, np.uint8)
    if valid.all() and width_px >= 3.0 and ripple == 0.0:
        # The strip is the annulus between two concentric 3-D circles, projected exactly:
        # its near side comes out wider than its far side, as through a real lens.
        half = 0.5 * spec.strip_width_m
        outer, _ = camera.project(ring_points(center, normal, spec.marker_radius_m + half, count))
        inner, _ = camera.project(ring_points(center, normal, spec.marker_radius_m - half, count))
        cv2.fillPoly(layer, [np.round(outer * _SCALE).astype(np.int32)], 255, cv2.LINE_AA, _SHIFT)
        cv2.fillPoly(layer, [np.round(inner * _SCALE).astype(np.int32)], 0, cv2.LINE_AA, _SHIFT)
        _add_strip(light, layer, pix[valid], radiance, leds)
        return
    # A thin strip, a rippled reflection, or a ring partly beyond the lens model's fold or
    # behind the camera: a polyline through the valid runs (never a chord across the image).
    for run in _valid_runs(valid):
        if np.any(np.abs(pix[run]) > 1e6):
            continue
        poly = np.round(pix[run] * _SCALE).astype(np.int32)
        cv2.polylines(layer, [poly], len(run) == len(pix), 255, thickness, cv2.LINE_AA, _SHIFT)
    if valid.any():
        _add_strip(light, layer, pix[valid], value, leds)


def _add_strip(light: np.ndarray, layer: np.ndarray, ring_px: np.ndarray, value: float, pattern: np.ndarray) -> None:
    """A drawn strip into the light layer, its brightness following the pattern around the ring."""
    x0, y0, bw, bh = cv2.boundingRect(layer)
    if bw == 0 or bh == 0:
        return
    strip = layer[y0:y0 + bh, x0:x0 + bw].astype(np.float32) * (value / 255.0)
    if not np.all(pattern == 1.0):
        cu, cv = ring_px.mean(axis=0)
        ys, xs = np.nonzero(strip)  # only the strip's own pixels: the rest of its box stays dark
        angle = np.arctan2(ys + y0 - cv, xs + x0 - cu)
        strip[ys, xs] *= pattern[((angle + math.pi) / (2 * math.pi) * len(pattern)).astype(int) % len(pattern)]
    light[y0:y0 + bh, x0:x0 + bw] += strip


def _draw_funnel_glow(light: np.ndarray, ring_px: np.ndarray, value: float) -> None:
    """LED light thrown on the dock's funnel: brightest next to the ring, fading towards its centre."""
    h, w = light.shape
    x0, y0 = (max(0, int(ring_px[:, i].min()) - 2) for i in (0, 1))
    x1, y1 = min(w, int(ring_px[:, 0].max()) + 3), min(h, int(ring_px[:, 1].max()) + 3)
    if x1 - x0 < 3 or y1 - y0 < 3:
        return
    inside = np.zeros((y1 - y0, x1 - x0), np.uint8)
    cv2.fillPoly(inside, [np.round((ring_px - (x0, y0)) * _SCALE).astype(np.int32)], 255, cv2.LINE_8, _SHIFT)
    depth = cv2.distanceTransform(inside, cv2.DIST_L2, 3)
    radius = max(1.0, 0.5 * min(x1 - x0, y1 - y0))
    light[y0:y1, x0:x1] += (inside > 0) * np.exp(-depth / (0.35 * radius)).astype(np.float32) * value


def _valid_runs(valid: np.ndarray) -> list[np.ndarray]:
    idx = np.flatnonzero(valid)
    if idx.size == 0:
        return []
    if idx.size == valid.size:
        return [idx]
    breaks = np.flatnonzero(np.diff(idx) > 1)
    runs = np.split(idx, breaks + 1)
    if valid[0] and valid[-1] and len(runs) > 1:  # join the run that wraps around
        runs[0] = np.concatenate([runs[-1], runs[0]])
        runs = runs[:-1]
    return [r for r in runs if r.size > 1]


def _draw_point(light: np.ndarray, glare: Glare | None, u: float, v: float, radius: float, value: float) -> None:
    """An LED or a lamp: a disc of the given radiance and, with glare, the wide tail of its light."""
    if glare is None:
        _draw_disc(light, u, v, radius, value)
        return
    flux = value * math.pi * max(radius, 0.5) ** 2
    _draw_disc(light, u, v, radius, value * (1.0 - glare.tail_share))
    glare.add(light, u, v, flux)


def _draw_disc(layer: np.ndarray, u: float, v: float, radius: float, value: float) -> None:
    h, w = layer.shape
    if not (-radius <= u < w + radius and -radius <= v < h + radius):
        return
    center = (int(round(u * _SCALE)), int(round(v * _SCALE)))
    r = int(round(max(radius, 0.5) * _SCALE))
    x0, y0 = max(0, int(u - radius - 2)), max(0, int(v - radius - 2))
    x1, y1 = min(w, int(u + radius + 3)), min(h, int(v + radius + 3))
    if x1 <= x0 or y1 <= y0:
        return
    sub = np.zeros((y1 - y0, x1 - x0), np.uint8)
    cv2.circle(sub, (center[0] - x0 * _SCALE, center[1] - y0 * _SCALE), r, 255, -1, cv2.LINE_AA, _SHIFT)
    layer[y0:y1, x0:x1] += sub.astype(np.float32) * (value / 255.0)


def _apply_optics(camera: CameraModel, spec: SceneSpec, light: np.ndarray) -> np.ndarray:
    """Lens blur, forward-scatter halo and motion blur of the light layer (region of interest only)."""
    box = _box(light > 1e-4)
    if box is None:
        return light
    top, bottom, left, right = box
    distance = float(np.linalg.norm(spec.marker_center_m)) if spec.marker_center_m else 10.0
    halo_sigma = max(2.0, camera.focal_px * spec.halo_sigma_rad * (0.5 + distance / 10.0))
    margin = int(3 * halo_sigma + spec.motion_blur_px + 8)
    y0, y1 = max(0, top - margin), min(light.shape[0], bottom + margin + 1)
    x0, x1 = max(0, left - margin), min(light.shape[1], right + margin + 1)
    roi = light[y0:y1, x0:x1]
    core = cv2.GaussianBlur(roi, (0, 0), 0.6 + 0.03 * distance)
    halo_share = 1.0 - math.exp(-spec.halo_fraction_per_m * distance)
    # The halo is smooth: blur a quarter-size copy and scale it back up.
    small = cv2.resize(core, None, fx=0.25, fy=0.25, interpolation=cv2.INTER_AREA)
    small = cv2.GaussianBlur(small, (0, 0), halo_sigma / 4.0)
    halo = cv2.resize(small, (roi.shape[1], roi.shape[0]), interpolation=cv2.INTER_LINEAR)
    out = core * (1.0 - halo_share) + halo * halo_share
    if spec.motion_blur_px >= 1.0:
        out = _motion_blur(out, spec.motion_blur_px, spec.motion_blur_angle_rad)
    result = np.zeros_like(light)
    result[y0:y1, x0:x1] = out
    return result


def _motion_blur(image: np.ndarray, length: float, angle: float) -> np.ndarray:
    size = int(math.ceil(length)) | 1
    kernel = np.zeros((size, size), np.float32)
    c = size // 2
    dx, dy = math.cos(angle) * (length - 1) / 2, math.sin(angle) * (length - 1) / 2
    cv2.line(kernel, (int(round((c - dx) * _SCALE)), int(round((c - dy) * _SCALE))),
             (int(round((c + dx) * _SCALE)), int(round((c + dy) * _SCALE))), 1.0, 1, cv2.LINE_AA, _SHIFT)
    kernel /= max(kernel.sum(), 1e-6)
    return cv2.filter2D(image, -1, kernel)


_NOISE_MARGIN = 61


@lru_cache(maxsize=4)
def _noise_field(height: int, width: int) -> np.ndarray:
    """A standard-normal field a little larger than the frame; each frame reads a shifted window.

    Drawing 6 million normals per 1080p frame cost more than everything else in the
    renderer; a window at a random offset is as random to a detector and ten times cheaper.
    """
    field = np.empty((height + _NOISE_MARGIN, width + _NOISE_MARGIN, 3), np.float32)
    cv2.setRNGSeed(12345)
    cv2.randn(field, 0.0, 1.0)  # type: ignore[call-overload]  # scalar mean and deviation: fine, the stubs say arrays
    field.setflags(write=False)
    return field


def _box(mask: np.ndarray) -> tuple[int, int, int, int] | None:
    """First and last row and column where ``mask`` holds (inclusive), or None when it holds nowhere."""
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        return None
    cols = np.flatnonzero(mask[rows[0]:rows[-1] + 1].any(axis=0))
    return int(rows[0]), int(rows[-1]), int(cols[0]), int(cols[-1])


def _compose(camera: CameraModel, spec: SceneSpec, light: np.ndarray, body: list[BodyPatch],
             rng: np.random.Generator) -> np.ndarray:
    """Water background + the dock's body + coloured light + shot and read noise, as 8-bit BGR.

    A plain background is smooth per row and the same in every frame of one water but for
    the window of noise it shows, so it is made once (`_plain_water`); only where light or
    the dock was drawn is it computed per pixel. Structure, caustics, walls or vignetting
    make every pixel different: then everything is computed per pixel. The dock's body
    hides the background; what is left in front of it is the veiling light.
    """
    h, w = camera.height, camera.width
    rows = np.linspace(spec.ambient_top, spec.ambient_bottom, h, dtype=np.float32) + np.float32(spec.backscatter)
    water = np.array(spec.water_bgr, np.float32) * 255.0
    led = np.array(spec.led_bgr, np.float32) * 255.0
    veil = np.float32(spec.backscatter) * water
    body_bgr = np.array(spec.funnel.bgr if spec.funnel is not None else (1.0, 1.0, 1.0), np.float32) * 255.0
    dy, dx = (int(v) for v in rng.integers(0, _NOISE_MARGIN, 2))
    dy -= dy % _PLAIN_ROW_STEP  # the plain water is kept for a few row offsets only
    noise = _noise_field(h, w)[dy : dy + h, dx : dx + w]
    if spec.clutter or spec.caustics or spec.vignetting or spec.walls is not None:
        structure = background_structure(h, w, spec.clutter, spec.caustics, spec.walls, rng)
        level = np.maximum(rows[:, None] + structure, 0.0)  # no negative light
        clean = level[:, :, None] * water + light[:, :, None] * led
        for patch in body:
            _add_body(clean[patch.box], patch, veil, level[patch.box][:, :, None] * water, body_bgr)
        if spec.vignetting:
            clean *= _vignette(h, w, spec.vignetting)[:, :, None]
        noisy = _with_noise(clean, noise, spec)
        np.clip(noisy, 0, 255, out=noisy)
        return noisy.astype(np.uint8)
    background = rows[:, None] * water[None, :]  # (h, 3)
    image = _plain_water(h, w, spec.ambient_top, spec.ambient_bottom, spec.backscatter, tuple(spec.water_bgr),
                         spec.read_noise, spec.shot_noise, dy // _PLAIN_ROW_STEP)[:, dx:dx + w].copy()
    drawn = light[::4, ::4] > 1e-4
    for patch in body:
        drawn[patch.y0 // 4:-(-(patch.y0 + patch.radiance.shape[0]) // 4),
              patch.x0 // 4:-(-(patch.x0 + patch.radiance.shape[1]) // 4)] = True
    box = _box(drawn)
    if box is not None:  # the light and the dock, and their shot noise, only where there are any
        top, bottom, left, right = box
        y0, y1 = max(0, 4 * top - 4), min(h, 4 * bottom + 8)
        x0, x1 = max(0, 4 * left - 4), min(w, 4 * right + 8)
        clean = light[y0:y1, x0:x1, None] * led
        clean += background[y0:y1, None, :]
        for patch in body:
            py, px = patch.box
            inner = np.s_[py.start - y0:py.stop - y0, px.start - x0:px.stop - x0]
            _add_body(clean[inner], patch, veil, background[py, None, :], body_bgr)
        noisy = _with_noise(clean, noise[y0:y1, x0:x1], spec)
        np.clip(noisy, 0, 255, out=noisy)
        image[y0:y1, x0:x1] = noisy
    return image


_PLAIN_ROW_STEP = 16  # row offsets of the noise window a plain background is kept for (4 of them)


@lru_cache(maxsize=8)
def _plain_water(h: int, w: int, ambient_top: float, ambient_bottom: float, backscatter: float,
                 water_bgr: tuple[float, float, float], read_noise: float, shot_noise: float,
                 row_offset: int) -> np.ndarray:
    """The plain water with its noise as 8-bit BGR, as wide as the noise field: a frame takes
    a window of it. Made once per water and row offset; per frame it was half the renderer's time.
    """
    dy = row_offset * _PLAIN_ROW_STEP
    rows = np.linspace(ambient_top, ambient_bottom, h, dtype=np.float32) + np.float32(backscatter)
    background = rows[:, None] * (np.array(water_bgr, np.float32) * 255.0)[None, :]
    sigma = np.sqrt(read_noise**2 + shot_noise**2 * background).astype(np.float32)
    image = _noise_field(h, w)[dy:dy + h] * sigma[:, None, :]
    image += background[:, None, :]
    np.clip(image, 0, 255, out=image)
    plain = image.astype(np.uint8)
    plain.setflags(write=False)
    return plain


def _with_noise(clean: np.ndarray, noise: np.ndarray, spec: SceneSpec, out: np.ndarray | None = None) -> np.ndarray:
    """clean + noise * sqrt(read^2 + shot^2 * clean), without a temporary per step."""
    noisy = np.multiply(clean, np.float32(spec.shot_noise**2), out=out)
    noisy += np.float32(spec.read_noise**2)
    np.sqrt(noisy, out=noisy)
    noisy *= noise
    noisy += clean
    return noisy


def _add_body(clean: np.ndarray, patch: BodyPatch, veil: np.ndarray, background: np.ndarray,
              bgr: np.ndarray) -> None:
    """The dock's surfaces in place of the background they hide (``clean`` and ``background``: the patch's box)."""
    if patch.coverage is not None:
        clean += patch.coverage[:, :, None] * (veil - background)
    clean += patch.radiance[:, :, None] * bgr


@lru_cache(maxsize=4)
def _vignette_shape(h: int, w: int) -> np.ndarray:
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    r2 = ((xs - (w - 1) / 2) ** 2 + (ys - (h - 1) / 2) ** 2) / (((w - 1) / 2) ** 2 + ((h - 1) / 2) ** 2)
    r2.setflags(write=False)
    return r2


def _vignette(h: int, w: int, share: float) -> np.ndarray:
    """Lens and housing fall-off: 1 at the centre, 1 - share in the corners."""
    return 1.0 - np.float32(share) * _vignette_shape(h, w)
