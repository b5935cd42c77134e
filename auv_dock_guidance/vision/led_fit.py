"""Rings of separate LEDs from their centroids, and the dock's pose from them.

The lights (`leds.py`) are refined to full-resolution centroids, undistorted, and
assembled into rings (`led_ring.py`) on the undistorted plane. The pose of a ring of
known radius whose LEDs sit at known slots is a planar pose problem: from four LEDs on,
OpenCV's IPPE solves it exactly in perspective (the two planar solutions; the one that
reprojects better is taken), which puts the centre where the ring's centre is, not where
the visible part's middle is, however much of the ring the frame cuts. Three LEDs (a
corner) give the affine ring through them: a bearing towards the centre and a rough
range, marked partial.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import cv2
import numpy as np

from auv_dock_guidance.geometry.camera import CameraModel
from auv_dock_guidance.geometry.pose import Ellipse, pose_from_circle, pose_from_point
from auv_dock_guidance.vision.config import DetectorConfig
from auv_dock_guidance.vision.detection import Detection
from auv_dock_guidance.vision.led_ring import LedRing, assemble_rings, ring_model
from auv_dock_guidance.vision.leds import (
    LIT_LEVEL,
    LedBlob,
    LitRegion,
    find_leds,
    glow_matches,
    lit_region,
    mean_channel,
    refined,
    water_colour,
)
from auv_dock_guidance.vision.search import Box, picture_area
from auv_dock_guidance.vision.selection import CandidateShape

_LIT_FACE_RADII = 1.5  # ring radii out from the centre where a ring on a lit face still finds full scale
_BLOOMED_SHARE = 0.5  # share of the gaps between LEDs at full scale from which the LEDs are one glow


@dataclass(frozen=True)
class LedRingCandidate:
    """One assembled ring: its LEDs in image pixels and on the normalized plane."""

    ring: LedRing  # fitted on the normalized plane scaled by the focal length
    leds_px: np.ndarray  # (M, 2) the members' centroids, distorted image pixels
    leds_xy: np.ndarray  # (M, 2) the same on the normalized plane
    shape: CandidateShape  # for the choice among candidates (largest, lowest on ties)
    bloomed: bool = False  # the LEDs merged into one glow at full scale (`_bloomed`)


@dataclass(frozen=True)
class FrameView:
    """What a search of the whole frame tells the searches of parts of it: the part with a
    picture (``area``, full-resolution box) and the water's colour, the glows' reference."""

    area: Box
    water_bgr: np.ndarray

    @classmethod
    def of(cls, copy: tuple[np.ndarray, float]) -> FrameView:
        """From the search copy of the whole frame."""
        return cls(picture_area(*copy), water_colour(copy[0]))


def find_led_rings(image: np.ndarray, copy: tuple[np.ndarray, float], camera: CameraModel | None,
                   config: DetectorConfig, view: FrameView, origin: tuple[int, int] = (0, 0),
                   likely_count: int | None = None) -> list[LedRingCandidate]:
    """Rings of evenly spaced lights in the frame, or in the part of it whose search copy is
    ``copy`` and whose top left corner is ``origin`` (a tracking window); ``likely_count``:
    the count the dock has shown when the config gives none (`assemble_rings`)."""
    small, scale = copy
    gray = mean_channel(small)  # all the lights are looked for on: made once, not once per look
    lit = lit_region(gray)

    def round_the_lit(rings: list[LedRingCandidate]) -> list[LedRingCandidate]:
        return rings if lit is None else [r for r in rings if not _on_lit_face(r, lit, scale, origin, camera)]

    rings = round_the_lit(_rings_of(image, find_leds(gray, scale, config.search_background_px, origin=origin),
                                    camera, config, view, likely_count))
    if lit is not None and not rings:  # LEDs merged with a funnel brighter than the sensor takes: bumps on its outline
        rings = round_the_lit(_rings_of(
            image, find_leds(gray, scale, config.search_background_px, origin=origin, lit=lit), camera, config, view,
            likely_count))
    return rings if lit is None else [replace(r, bloomed=_bloomed(r, image, camera)) for r in rings]


def _bloomed(candidate: LedRingCandidate, image: np.ndarray, camera: CameraModel | None) -> bool:
    """Whether the gaps between the ring's LEDs are at full scale, as its LEDs are: the LEDs then
    make one glow, and what the search took for them are bulges of its outline, a glow's width
    outside the LEDs (renders of the open-water docks: ranges 14 % off at p68, where rings whose gaps
    are resolved read within 2.4 %), at slots and a tilt that follow the bulges, not the LEDs. Looked
    at on the full-resolution frame, half way between each pair of neighbouring slots in view."""
    px = np.round(_plane_to_pixels(candidate.ring.gap_positions(), camera)).astype(int)
    h, w = image.shape[:2]
    seen = (px[:, 0] >= 0) & (px[:, 0] < w) & (px[:, 1] >= 0) & (px[:, 1] < h)
    if not seen.any():
        return False
    level = mean_channel(image[px[seen, 1], px[seen, 0]][None])[0]
    return bool(np.count_nonzero(level >= LIT_LEVEL) >= _BLOOMED_SHARE * np.count_nonzero(seen))


def _on_lit_face(candidate: LedRingCandidate, lit: LitRegion, scale: float, origin: tuple[int, int],
                 camera: CameraModel | None) -> bool:
    """Whether the ring's surroundings are at full scale all round: spots on a lit funnel's face (its
    plateau between the vanes round the hub, close in), not LEDs round its rim, beyond which lies the
    dark dock or water. Looked at on a wider ring through every slot; only for a ring wholly in view
    (the affine ring through a corner's few LEDs is too loose to tell its surroundings)."""
    ring = candidate.ring
    if not ring.whole:
        return False
    centre = np.array(ring.center)
    around = centre + _LIT_FACE_RADII * (ring.slot_positions() - centre)
    copy = (_plane_to_pixels(around, camera) - np.asarray(origin)) * scale
    x, y = np.round(copy[:, 0]).astype(int), np.round(copy[:, 1]).astype(int)
    h, w = lit.mask.shape
    seen = (x >= 0) & (x < w) & (y >= 0) & (y < h)
    return bool(seen.any() and np.count_nonzero(lit.mask[y[seen], x[seen]]) >= 0.5 * np.count_nonzero(seen))


def _plane_to_pixels(plane: np.ndarray, camera: CameraModel | None) -> np.ndarray:
    """Image pixels of points on the plane the rings are fitted on (normalized, scaled by the focal length)."""
    return plane if camera is None else camera.normalized_to_pixels(plane / camera.focal_px)


def _rings_of(image: np.ndarray, found: list[LedBlob], camera: CameraModel | None, config: DetectorConfig,
              view: FrameView, likely_count: int | None) -> list[LedRingCandidate]:
    blobs = [refined(image, b, view.water_bgr) for b in found]
    if config.led_bgr is not None:
        blobs = [b for b in blobs if glow_matches(b.glow_bgr, config.led_bgr)]
    if len(blobs) < 3:
        return []
    pixels = np.array([(b.u, b.v) for b in blobs])
    focal = camera.focal_px if camera is not None else 1.0
    if camera is not None:
        xy, valid = camera.pixels_to_normalized(pixels)
        blobs = [b for b, ok in zip(blobs, valid, strict=True) if ok]
        pixels, xy = pixels[valid], xy[valid]
    else:
        xy = pixels.astype(np.float64)
    if len(blobs) < 3:
        return []
    margin = float(np.median([b.radius_px for b in blobs]))
    x0, y0, x1, y1 = view.area

    def in_view(plane: np.ndarray) -> np.ndarray:
        """Whether a point on the fitting plane shows in the picture (an LED's size clear of its edge)."""
        px = _plane_to_pixels(plane, camera)
        return ((px[:, 0] >= x0 + margin) & (px[:, 0] <= x1 - 1 - margin)
                & (px[:, 1] >= y0 + margin) & (px[:, 1] <= y1 - 1 - margin))

    # Lights that stand clear of their surroundings first, as the real footage shows rings; lights
    # in a glow (a ring blooming into one halo far out) are let in only where those made no ring.
    isolated = np.flatnonzero([b.isolated for b in blobs])
    passes = [isolated] if len(isolated) == len(blobs) else [isolated, np.arange(len(blobs))]
    for part in (p for p in passes if len(p) >= 3):
        chosen = [blobs[i] for i in part]
        rings = assemble_rings(xy[part] * focal, chosen, in_view, config.led_count, likely_count=likely_count)
        if rings:
            return [_candidate(ring, chosen, pixels[part], xy[part]) for ring in rings]
    return []


def _candidate(ring: LedRing, blobs: list[LedBlob], pixels: np.ndarray, xy: np.ndarray) -> LedRingCandidate:
    members = list(ring.members)
    major, minor = ring.semi_axes()
    shape = CandidateShape(
        area_px=math.pi * major * minor, center_v=float(np.mean(pixels[members, 1])),
        radius_px=major, axis_ratio=minor / max(major, 1e-9), hole_fraction=1.0, edge_support=1.0,
        contrast=float(np.mean([blobs[m].peak for m in members])), ellipse_residual=ring.residual,
        arc_deg=360.0 * min(1.0, ring.expected / ring.count),
    )
    return LedRingCandidate(ring, pixels[members], xy[members], shape)


def led_detection(candidate: LedRingCandidate, candidates: int, camera: CameraModel | None,
                  config: DetectorConfig) -> Detection:
    """The Detection of an assembled LED ring: its centre, range and bearing."""
    ring = candidate.ring
    radius_m = config.marker_radius_m
    slots = np.array(ring.slots)
    (mu, mv), mr = cv2.minEnclosingCircle(candidate.leds_px.astype(np.float32))
    ellipse = _slot_ellipse(candidate.leds_xy, slots, ring.count)
    common: dict[str, Any] = dict(
        found=True, candidates=candidates, is_ring=True, mec_u=float(mu), mec_v=float(mv),
        mec_radius_px=float(mr), ellipse=ellipse, leds=tuple((float(u), float(v)) for u, v in candidate.leds_px),
        led_count=ring.count, partial=2 * ring.expected < ring.count, bloomed=candidate.bloomed,
        visible_arc_deg=360.0 * min(1.0, ring.expected / ring.count),
        range_approximate=camera is not None and camera.approximate,
        fit_sigma=ring.residual * 2.0 * math.sin(math.pi / ring.count) * ellipse.semi_major
        / math.sqrt(max(1, len(slots) - 3)),
    )
    focal = camera.focal_px if camera is not None else 1.0
    solved = _planar_pose(candidate.leds_xy, slots, ring.count, radius_m) if len(slots) >= 4 else None
    if solved is None:  # a corner of three LEDs: the affine ring through them
        pose = pose_from_circle((ellipse.center_x, ellipse.center_y), ellipse.semi_major, radius_m)
        normal = None
    else:
        pose = pose_from_point(solved[0])
        normal = (float(solved[1][0]), float(solved[1][1]), float(solved[1][2]))
    x, y = pose.offset_x_m / pose.range_m, pose.offset_y_m / pose.range_m
    if camera is not None:
        u, v = (float(c) for c in camera.normalized_to_pixels(np.array([x, y])))
    else:
        u, v = x, y
    return Detection(u=u, v=v, radius_px=radius_m / pose.range_m * focal, pose=pose, ring_normal=normal,
                     **common)


def _slot_ellipse(xy: np.ndarray, slots: np.ndarray, count: int) -> Ellipse:
    """The ellipse c + a cos t + b sin t of the ring through the LEDs at their slots."""
    center, a, b = ring_model(xy, slots, count)
    u, singular, _ = np.linalg.svd(np.column_stack([a, b]))
    return Ellipse(float(center[0]), float(center[1]), float(singular[0]), float(max(singular[1], 1e-12)),
                   math.atan2(u[1, 0], u[0, 0]))


def _planar_pose(xy: np.ndarray, slots: np.ndarray, count: int,
                 radius_m: float) -> tuple[np.ndarray, np.ndarray] | None:
    """Centre (m) and axis (towards the camera) of the ring whose LED ``slots`` image at ``xy``."""
    angle = 2.0 * np.pi * slots / count
    ring = np.column_stack([radius_m * np.cos(angle), radius_m * np.sin(angle), np.zeros(len(slots))])
    try:
        solutions, rotations, translations, errors = cv2.solvePnPGeneric(
            ring, xy.astype(np.float64), np.eye(3), None, flags=cv2.SOLVEPNP_IPPE)
    except cv2.error:
        return None
    if not solutions:
        return None
    best = int(np.argmin(np.ravel(errors))) if errors is not None else 0
    center = np.ravel(translations[best]).astype(float)
    normal = cv2.Rodrigues(rotations[best])[0][:, 2]
    if center[2] <= 0 or not np.all(np.isfinite(center)):
        return None
    return center, (-normal if normal[2] > 0 else normal)
