"""The real-dock population: scenes as recorded pool footage of a dock shows them.

Beside the paper's population (sim/scenarios.py: a calibrated 1080p camera, the ring
whole in view, 2-15 m), this one draws what a camera on a vehicle records in the last
metres of an approach: an analogue PAL camera (720x576, 500-800 px focal length, square
or PAL-shaped pixels, none or mild barrel distortion) and its video chain; docks with
6-12 blooming LEDs just outside a lit funnel (or a strip), 0.25-0.6 m in radius; the ring
whole, cut by the frame edge with half of it or more in view, or only a corner in view;
green, hazy water; tiled and stained walls with ring-shaped fixtures and tethers; a
surface reflection in some frames; blooming lamps; and frames without any dock at all.
Ranges are wide on purpose, and no draw copies one recording: a detector tuned to one
video will not pass.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from auv_dock_guidance.geometry.camera import CameraModel
from auv_dock_guidance.sim.background import PoolWalls
from auv_dock_guidance.sim.scenarios import dock_look, reflection_above, tilted_normal
from auv_dock_guidance.sim.scene import Lamp, SceneSpec
from auv_dock_guidance.sim.video import VideoRecording

PAL_WIDTH, PAL_HEIGHT = 720, 576
PAL_PIXEL_ASPECT = 16.0 / 15.0  # a 720x576 frame shown 4:3: pixels are taller than wide
# Shares of the population; the rest shows the ring whole.
_KIND_SHARES = (("empty", 0.15), ("reflection", 0.15), ("cut", 0.25), ("corner", 0.12))
_KINDS = ("whole", "reflection", "cut", "corner", "empty")


def pal_camera(rng: np.random.Generator) -> CameraModel:
    """An uncalibrated analogue camera: only roughly known, as on small vehicles and in old footage."""
    fx = rng.uniform(500.0, 800.0)
    fy = fx * (PAL_PIXEL_ASPECT if rng.uniform() < 0.5 else 1.0)
    return CameraModel(
        width=PAL_WIDTH,
        height=PAL_HEIGHT,
        fx=fx,
        fy=fy,
        cx=(PAL_WIDTH - 1) / 2.0 + rng.uniform(-8.0, 8.0),
        cy=(PAL_HEIGHT - 1) / 2.0 + rng.uniform(-8.0, 8.0),
        k1=rng.uniform(-0.15, 0.0) if rng.uniform() < 0.7 else 0.0,
        name="pal_camera",
    )


def real_dock_scene(rng: np.random.Generator, kind: str | None = None) -> tuple[CameraModel, SceneSpec]:
    """One frame of the population and the camera it is seen through.

    ``kind`` forces 'whole', 'reflection', 'cut', 'corner' or 'empty'; what the frame
    really shows (the share of the ring in view) is the ground truth's to say.
    """
    if kind is None:
        roll, kind = rng.uniform(), "whole"
        for name, share in _KIND_SHARES:
            if roll < share:
                kind = name
                break
            roll -= share
    elif kind not in _KINDS:
        raise ValueError(f"kind {kind!r} is not one of {', '.join(_KINDS)}")
    camera = pal_camera(rng)
    spec = _recorded(rng, replace(dock_look(rng, discrete_share=0.7), marker_radius_m=rng.uniform(0.25, 0.6)))
    if kind == "empty":
        walls = spec.walls or PoolWalls(haze=rng.uniform(0.0, 0.7))
        walls = replace(walls, fixtures=int(rng.integers(1, 4)), fixture_contrast=rng.uniform(0.05, 0.2))
        return camera, replace(spec, marker_center_m=None, walls=walls,
                               lamps=_blooming_lamps(rng, int(rng.integers(0, 5))))
    radius_px = _apparent_radius(rng, kind)
    u, v = _image_centre(camera, rng, kind, radius_px)
    z = camera.focal_px * spec.marker_radius_m / radius_px
    center = ((u - camera.cx) / camera.fx * z, (v - camera.cy) / camera.fy * z, z)
    spec = replace(spec, marker_center_m=center, marker_normal=tilted_normal(rng, math.radians(35.0)))
    if kind == "reflection":
        spec = reflection_above(camera, rng, spec)
    if rng.uniform() < 0.25:
        spec = replace(spec, lamps=_blooming_lamps(rng, int(rng.integers(1, 4))))
    return camera, spec


def _apparent_radius(rng: np.random.Generator, kind: str) -> float:
    """The ring's radius in pixels: whole rings from far (8 px) to filling the frame; cut ones close up."""
    if kind in ("whole", "reflection"):
        return float(np.exp(rng.uniform(math.log(8.0), math.log(0.42 * PAL_HEIGHT))))
    return float(np.exp(rng.uniform(math.log(60.0), math.log(420.0))))


def _image_centre(camera: CameraModel, rng: np.random.Generator, kind: str, radius_px: float) -> tuple[float, float]:
    """Where the ring's centre is imaged (ignoring distortion; the ground truth does not)."""
    w, h = camera.width, camera.height
    if kind in ("whole", "reflection"):
        margin = 1.15 * radius_px + 4.0  # the whole ring and most of its halo in the frame
        return (rng.uniform(margin, max(margin, w - margin)), rng.uniform(margin, max(margin, h - margin)))
    if kind == "cut":  # the centre a little inside one edge: about half or more of the ring in view
        inside = rng.uniform(0.02, 0.95) * radius_px
        along = (rng.uniform(min(radius_px, w / 2), max(w - radius_px, w / 2)),
                 rng.uniform(min(radius_px, h / 2), max(h - radius_px, h / 2)))
        edge = int(rng.integers(4))
        if edge == 0:
            return inside, along[1]
        if edge == 1:
            return w - 1 - inside, along[1]
        if edge == 2:
            return along[0], inside
        return along[0], h - 1 - inside
    # A corner: the centre beyond both edges of one corner, the ring still reaching into the frame.
    while True:
        dx, dy = rng.uniform(-0.7, 0.2, 2) * radius_px
        if math.hypot(min(dx, 0.0), min(dy, 0.0)) < 0.9 * radius_px:
            break
    right, bottom = rng.uniform() < 0.5, rng.uniform() < 0.5
    return (w - 1 - dx if right else dx), (h - 1 - dy if bottom else dy)


def _recorded(rng: np.random.Generator, spec: SceneSpec) -> SceneSpec:
    """Green, hazy pool water, the pool's walls and a PAL video chain, each varied per frame."""

    def sometimes(share: float, low: float, high: float) -> float:
        return float(rng.uniform(low, high)) if rng.uniform() < share else 0.0

    attenuation = rng.uniform(0.08, 0.4)
    walls = None
    if rng.uniform() < 0.85:
        walls = PoolWalls(
            tile_contrast=sometimes(0.7, 0.03, 0.2),
            tile_share=rng.uniform(0.1, 0.35),
            stain_contrast=sometimes(0.8, 0.02, 0.15),
            fixtures=int(rng.integers(0, 3)),
            fixture_contrast=rng.uniform(0.03, 0.15),
            cables=int(rng.integers(0, 4)),
            haze=rng.uniform(0.0, 0.6),
        )
    video = VideoRecording(
        chroma_blur_px=rng.uniform(1.0, 3.0),
        interlace_px=sometimes(0.4, -4.0, 4.0),
        letterbox_px=int(sometimes(0.5, 6, 15)),
        recorder_quality=int(sometimes(0.5, 25, 60)),
        quality=int(rng.uniform(50, 90)),
    )
    return replace(
        spec,
        attenuation_per_m=attenuation,
        halo_fraction_per_m=rng.uniform(0.1, 0.6) * attenuation * 0.6,
        # A camera exposing for the scene: the water mid-grey or brighter, rarely dark.
        backscatter=rng.uniform(0.1, 0.45),
        ambient_top=rng.uniform(0.1, 0.4),
        ambient_bottom=rng.uniform(0.05, 0.25),
        motion_blur_px=sometimes(0.3, 1.0, 8.0),
        motion_blur_angle_rad=rng.uniform(0, math.pi),
        dead_share=sometimes(0.1, 0.05, 0.15),
        particles=int(sometimes(0.3, 10, 200)),
        vignetting=sometimes(0.4, 0.1, 0.4),
        caustics=sometimes(0.1, 0.02, 0.06),
        walls=walls,
        video=video,
        seed=int(rng.integers(2**31)),
    )


def _blooming_lamps(rng: np.random.Generator, count: int) -> tuple[Lamp, ...]:
    """Pool lamps and torches: small, and as bright as the dock's LEDs (they bloom as much)."""
    return tuple(
        Lamp(rng.uniform(0, PAL_WIDTH), rng.uniform(0, PAL_HEIGHT), rng.uniform(1.0, 5.0),
             float(np.exp(rng.uniform(math.log(5.0), math.log(2000.0)))))
        for _ in range(count)
    )
