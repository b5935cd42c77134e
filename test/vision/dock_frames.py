"""Synthetic frames of a real dock in a real pool, for the detector's tests.

What recorded pool footage shows and our renderer did not: discrete LEDs that bloom (a
white saturated core, a coloured halo several pixels wide) just outside a white lit
funnel with dark vanes and a hub, as bright as the LEDs; greenish hazy water, tiles,
stains and a ring-shaped (non-luminous) wall fixture; PAL video (720x576, interlaced
lines, a black border at the side) recorded as JPEG. Drawn from geometry through an
uncalibrated camera of about 650 px focal length, so the ring's true centre is known.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from auv_dock_guidance.geometry.camera import CameraModel, approximate_camera

PAL = approximate_camera(720, 576, focal_px=650.0)
RING_RADIUS_M = 0.35


@dataclass(frozen=True)
class Dock:
    center_m: tuple[float, float, float] | None = (0.0, 0.0, 2.5)
    normal: tuple[float, float, float] = (0.0, 0.0, -1.0)  # towards the camera
    led_count: int = 8
    led_bgr: tuple[float, float, float] = (1.0, 0.45, 0.15)  # blue
    lit_leds: tuple[int, ...] | None = None  # only these LEDs (None: all)
    funnel: bool = True
    funnel_gain: float = 1.1  # above about 1.1 the lit funnel saturates all over
    rim_m: float = 0.30  # the funnel's rim; LEDs at RING_RADIUS_M just outside it
    fixture: bool = True  # a grey ring on the wall, about the dock's size
    reflection_height_m: float | None = None  # a surface this far above the dock mirrors it
    phase_rad: float = 0.3
    seed: int = 0


def _basis(normal: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    n = np.array(normal, float)
    n /= np.linalg.norm(n)
    e1 = np.cross(n, [0.0, 1.0, 0.0])
    if np.linalg.norm(e1) < 1e-6:
        e1 = np.cross(n, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(n, e1)


def _circle(center: np.ndarray, e1: np.ndarray, e2: np.ndarray, radius: float, count: int = 180,
            phase: float = 0.0) -> np.ndarray:
    t = phase + np.linspace(0.0, 2.0 * math.pi, count, endpoint=False)
    return center + radius * (np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2)


def ring_center_px(dock: Dock, camera: CameraModel = PAL) -> tuple[float, float]:
    pixels, _ = camera.project(np.array([dock.center_m]))
    return float(pixels[0, 0]), float(pixels[0, 1])


def led_pixels(dock: Dock, camera: CameraModel = PAL) -> np.ndarray:
    e1, e2 = _basis(dock.normal)
    points = _circle(np.array(dock.center_m), e1, e2, RING_RADIUS_M, dock.led_count, dock.phase_rad)
    return camera.project(points)[0]


def render_dock(dock: Dock, camera: CameraModel = PAL) -> np.ndarray:
    rng = np.random.default_rng(dock.seed)
    h, w = camera.height, camera.width
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    water = np.array([0.30, 0.42, 0.34], np.float32)  # greenish
    base = (0.75 + 0.35 * (1.0 - yy / h))[..., None] * water * 255.0
    tiles = ((xx.astype(int) % 96 < 3) | (yy.astype(int) % 96 < 3)).astype(np.float32)
    base -= 18.0 * tiles[..., None]
    for _ in range(6):  # stains
        cx, cy, r = rng.uniform(0, w), rng.uniform(0, h), rng.uniform(15, 60)
        base -= (20.0 * np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * r * r)))[..., None]
    image = base
    if dock.fixture:
        fixture = np.zeros((h, w), np.float32)
        cv2.ellipse(fixture, (170, 150), (70, 62), 10, 0, 360, 1.0, 5, cv2.LINE_AA)
        image = image + 35.0 * cv2.GaussianBlur(fixture, (0, 0), 1.5)[..., None]
    if dock.center_m is not None:
        image = _draw_dock(image, dock, camera)
        if dock.reflection_height_m is not None:
            c = np.array(dock.center_m)
            mirrored = Dock(**{**dock.__dict__, "center_m": (c[0], c[1] - 2 * dock.reflection_height_m, c[2]),
                               "reflection_height_m": None, "funnel": False})
            image = _draw_dock(image, mirrored, camera, gain=0.8)
    haze = cv2.GaussianBlur(image, (0, 0), 0.8) + 12.0 * water * 255.0 / 100.0
    haze += rng.normal(0.0, 2.5, haze.shape).astype(np.float32)
    frame = np.clip(haze, 0, 255).astype(np.uint8)
    frame[1::2, 1:] = frame[1::2, :-1]  # interlaced lines a pixel apart
    frame[:, :12] = 0  # the capture card's black border
    ok, data = cv2.imencode(".jpg", frame, [cv2.IMWRITE_JPEG_QUALITY, 75])
    assert ok
    return cv2.imdecode(data, cv2.IMREAD_COLOR)


def _draw_dock(image: np.ndarray, dock: Dock, camera: CameraModel, gain: float = 1.0) -> np.ndarray:
    h, w = image.shape[:2]
    center = np.array(dock.center_m, float)
    e1, e2 = _basis(dock.normal)
    scale = 1 << 4

    def polygon(points: np.ndarray) -> np.ndarray:
        pixels, _ = camera.project(points)
        return np.round(pixels * scale).astype(np.int32)

    out = image.copy()
    if dock.funnel:
        funnel = np.zeros((h, w), np.float32)
        rim = dock.rim_m
        cv2.fillPoly(funnel, [polygon(_circle(center, e1, e2, rim))], 1.0, cv2.LINE_AA, 4)
        shade = 0.85 + 0.5 * np.clip((np.mgrid[0:h, 0:w][0] - 0.3 * h) / h, 0, 1)  # lower half saturates
        for k in range(4):  # dark vanes
            a = dock.phase_rad + k * math.pi / 2
            tip = center + rim * (math.cos(a) * e1 + math.sin(a) * e2)
            side = 0.02 * (-math.sin(a) * e1 + math.cos(a) * e2)
            cv2.fillPoly(funnel, [polygon(np.array([center + side, center - side, tip - side, tip + side]))],
                         0.25, cv2.LINE_AA, 4)
        cv2.fillPoly(funnel, [polygon(_circle(center, e1, e2, 0.06))], 0.05, cv2.LINE_AA, 4)
        cv2.polylines(funnel, [polygon(_circle(center, e1, e2, rim + 0.01))], True, 0.8, 2, cv2.LINE_AA, 4)
        white = np.array([235.0, 250.0, 225.0], np.float32) * dock.funnel_gain
        alpha = cv2.GaussianBlur(funnel, (0, 0), 0.7)
        inside = alpha > 0.02
        out = np.where(inside[..., None], out * (1 - np.minimum(alpha, 1)[..., None]) +
                       (alpha * shade)[..., None] * white, out)
    pixels, valid = camera.project(_circle(center, e1, e2, RING_RADIUS_M, dock.led_count, dock.phase_rad))
    z = max(0.3, center[2])
    halo_px = max(1.5, 0.02 * camera.focal_px / z)
    core_px = max(0.8, 0.005 * camera.focal_px / z)
    light = np.zeros((h, w), np.float32)
    core = np.zeros((h, w), np.float32)
    for k, ((u, v), ok) in enumerate(zip(pixels, valid, strict=True)):
        if not ok or (dock.lit_leds is not None and k not in dock.lit_leds):
            continue
        if not (-3 * halo_px <= u < w + 3 * halo_px and -3 * halo_px <= v < h + 3 * halo_px):
            continue
        d2 = (np.mgrid[0:h, 0:w][1] - u) ** 2 + (np.mgrid[0:h, 0:w][0] - v) ** 2
        light += np.exp(-d2 / (2 * halo_px**2)).astype(np.float32)
        core += np.exp(-d2 / (2 * core_px**2)).astype(np.float32)
    colour = np.array(dock.led_bgr, np.float32) * 255.0
    return out + gain * (2.5 * light[..., None] * colour + 3.0 * core[..., None] * 255.0)
