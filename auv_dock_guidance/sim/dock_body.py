"""The dock's entrance inside the LED ring: a white funnel lit from within, dark vanes and a hub.

Real docks put their LEDs just outside the rim of a funnel. A lit white funnel is as
bright as the LEDs in a camera set for the water (it saturates in places); the vanes that
hold the hub, and the hub itself, are dark. The funnel is a cone: the hub lies behind the
rim plane, so a tilted dock shows it off centre. The body hides the wall behind it and is
seen through the water like the LEDs (attenuated, veiled), so it is drawn as a patch of
radiance and coverage that the composition puts in place of the background. Everything
is drawn inside the funnel's bounding box only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from auv_dock_guidance.geometry.camera import CameraModel
from auv_dock_guidance.sim.ring_geometry import plane_basis, ring_points

_SHIFT = 4  # fixed-point bits for sub-pixel drawing
_SCALE = 1 << _SHIFT


@dataclass(frozen=True)
class Funnel:
    """How the dock's funnel looks; sizes are shares of the rim radius."""

    rim_share: float = 0.9  # rim radius as a share of the LED ring's radius (the LEDs sit just outside)
    brightness: float = 1.0  # radiance of the lit white inside (full-scale units; above 1 it clips)
    bgr: tuple[float, float, float] = (1.0, 1.0, 0.92)
    shading: float = 0.4  # the light falls by this share across the funnel (lit from one side)
    shading_angle_rad: float = 0.0  # image direction the funnel is brightest towards
    vanes: int = 3
    vane_angle_rad: float = 0.0  # of the first vane, in the ring's plane
    vane_width_share: float = 0.08  # at the rim; half of it at the hub
    hub_share: float = 0.22
    depth_share: float = 0.5  # the hub's depth behind the rim plane
    dark: float = 0.04  # radiance of the vanes and the hub
    rim_brightness: float = 0.0  # a bright metal lip along the rim (0: none)


@dataclass(frozen=True)
class BodyPatch:
    """The dock's surfaces in one box of the frame: their radiance and where they hide the background."""

    y0: int
    x0: int
    radiance: np.ndarray  # (h, w) float32, full-scale units, already weighted by coverage
    coverage: np.ndarray | None  # (h, w) float32 in [0, 1]; None for a mirror image, which hides nothing

    @property
    def box(self) -> tuple[slice, slice]:
        return np.s_[self.y0:self.y0 + self.radiance.shape[0], self.x0:self.x0 + self.radiance.shape[1]]


def draw_funnel(
    camera: CameraModel,
    funnel: Funnel,
    center: np.ndarray,
    normal: np.ndarray,
    ring_radius_m: float,
    transmission: float,
    blur_px: float,
    occludes: bool,
) -> BodyPatch | None:
    """The funnel as the camera sees it; a mirror image (``occludes`` False) adds light but hides nothing.

    None when no part of it is in the frame, or part of it is behind the camera.
    """
    normal = normal / np.linalg.norm(normal)
    e1, e2 = plane_basis(normal)
    rim_m = funnel.rim_share * ring_radius_m
    rim_px_est = camera.focal_px * rim_m / max(center[2], 1e-3)
    count = int(np.clip(rim_px_est * 2.0 * math.pi / 3.0, 48, 720))
    hub_center = center - normal * funnel.depth_share * rim_m
    hub_m = funnel.hub_share * rim_m
    half = 0.5 * funnel.vane_width_share * rim_m
    vanes = []
    for k in range(funnel.vanes):
        phi = funnel.vane_angle_rad + 2.0 * math.pi * k / funnel.vanes
        along = math.cos(phi) * e1 + math.sin(phi) * e2
        across = -math.sin(phi) * e1 + math.cos(phi) * e2
        vanes += [hub_center + hub_m * along - 0.5 * half * across, center + rim_m * along - half * across,
                  center + rim_m * along + half * across, hub_center + hub_m * along + 0.5 * half * across]
    hub_count = max(24, count // 4)
    points = np.vstack([ring_points(center, normal, rim_m, count), ring_points(hub_center, normal, hub_m, hub_count),
                        np.reshape(vanes, (-1, 3))])
    if np.any(points[:, 2] <= 1e-3):
        return None
    pix = _project_beyond_fold(camera, points)
    rim, hub_px, vane_px = pix[:count], pix[count:count + hub_count], pix[count + hub_count:]
    h, w = camera.height, camera.width
    margin = int(math.ceil(3.0 * blur_px)) + 3
    x0, y0 = max(0, int(rim[:, 0].min()) - margin), max(0, int(rim[:, 1].min()) - margin)
    x1, y1 = min(w, int(rim[:, 0].max()) + margin + 1), min(h, int(rim[:, 1].max()) + margin + 1)
    if x1 - x0 < 2 or y1 - y0 < 2:
        return None
    origin = np.array([x0, y0], float)

    def poly(points_px: np.ndarray) -> np.ndarray:
        return np.round((points_px - origin) * _SCALE).astype(np.int32)

    inside = np.zeros((y1 - y0, x1 - x0), np.uint8)
    cv2.fillPoly(inside, [poly(rim)], 255, cv2.LINE_AA, _SHIFT)
    dark = np.zeros_like(inside)
    for part in [*np.reshape(vane_px, (-1, 4, 2)), hub_px]:  # one at a time: overlaps must not cancel
        cv2.fillPoly(dark, [poly(part)], 255, cv2.LINE_AA, _SHIFT)
    cover = inside.astype(np.float32) / 255.0
    dark_share = np.minimum(dark.astype(np.float32) / 255.0, cover)
    # Lit from one side: brightness falls linearly across the projected rim.
    centre_px = rim.mean(axis=0) - origin
    radius_px = max(1.0, 0.5 * float(np.ptp(rim[:, 0]) + np.ptp(rim[:, 1])) / 2.0)
    dx, dy = math.cos(funnel.shading_angle_rad), math.sin(funnel.shading_angle_rad)
    xs = (np.arange(x1 - x0, dtype=np.float32) - np.float32(centre_px[0])) * np.float32(dx / radius_px)
    ys = (np.arange(y1 - y0, dtype=np.float32) - np.float32(centre_px[1])) * np.float32(dy / radius_px)
    towards = np.clip(xs[None, :] + ys[:, None], -1.0, 1.0)
    lit = np.float32(funnel.brightness) * (1.0 - np.float32(0.5 * funnel.shading) * (1.0 - towards))
    radiance = (cover - dark_share) * lit + dark_share * np.float32(funnel.dark)
    if funnel.rim_brightness > 0:
        lip = np.zeros_like(inside)
        cv2.polylines(lip, [poly(rim)], True, 255, max(1, int(round(0.012 * radius_px))), cv2.LINE_AA, _SHIFT)
        radiance += lip.astype(np.float32) * np.float32(funnel.rim_brightness / 255.0)
    if blur_px > 0.3:
        cv2.GaussianBlur(radiance, (0, 0), blur_px, dst=radiance)
        cv2.GaussianBlur(cover, (0, 0), blur_px, dst=cover)
    radiance *= np.float32(transmission)
    return BodyPatch(y0, x0, radiance, cover if occludes else None)


def _project_beyond_fold(camera: CameraModel, points: np.ndarray) -> np.ndarray:
    """Pixels of points in front of the camera; those beyond the lens model's fold (outside the
    frame) are put far out in their own direction, so a filled outline still covers the frame's edge."""
    pix, valid = camera.project(points)
    if valid.all():
        return pix
    xy = points[~valid, :2] / points[~valid, 2:3]
    direction = xy / np.maximum(np.linalg.norm(xy, axis=1, keepdims=True), 1e-9)
    far = 4.0 * max(camera.width, camera.height)
    pix[~valid] = np.array([camera.cx, camera.cy]) + direction * far
    return pix
