"""Random but physically plausible scenes: the test and evaluation population.

Every draw varies what real water and real docks vary: range and bearing, ring tilt,
strip width, continuous strip or discrete LEDs, LED colour and brightness, turbidity
(attenuation, halo, backscatter), ambient light from the surface, water colour, motion
blur, sensor noise, a surface reflection (sometimes cut by the frame edge), lamps and
glints; and what real docks and pools add: LEDs of uneven brightness and dead ones, light
on the funnel inside the ring, structure behind the dock, caustics, particles,
vignetting and JPEG recording. The ranges are wide on purpose: a detector tuned to one
look of one renderer will not survive real water.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from auv_dock_guidance.geometry.camera import PAPER_FOCAL_PX, CameraModel
from auv_dock_guidance.sim.dock_body import Funnel
from auv_dock_guidance.sim.scene import Lamp, SceneSpec

_LED_COLOURS = (
    (1.0, 0.9, 0.25),  # blue-green
    (1.0, 0.6, 0.15),  # blue
    (0.7, 1.0, 0.3),  # green
    (1.0, 1.0, 0.9),  # white
)
_WATER_COLOURS = ((0.85, 0.65, 0.25), (0.6, 0.8, 0.35), (0.9, 0.55, 0.2), (0.55, 0.7, 0.5))
# Real LEDs seen through a colour camera: a blue LED excites the green and red pixels a
# little (so its clipped core is white) and its halo stays deep blue.
_BLOOMING_LED_COLOURS = (
    (1.0, 0.18, 0.03),  # blue
    (1.0, 0.55, 0.08),  # cyan-blue
    (0.2, 1.0, 0.25),  # green
    (1.0, 1.0, 0.95),  # white
)
# Pool and coastal water, often green and hazy: yellow-green, green, grey-green, blue-green.
_GREEN_WATER_COLOURS = ((0.3, 0.9, 0.85), (0.45, 0.95, 0.7), (0.8, 0.95, 0.9), (0.85, 0.8, 0.5))


@dataclass(frozen=True)
class ScenarioMix:
    """Shares of the population (the rest are plain marker frames)."""

    reflection_share: float = 1.0 / 3.0
    distractor_share: float = 0.25
    empty_share: float = 0.1
    min_range_m: float = 2.0
    max_range_m: float = 15.0
    marker_radius_m: float = 0.35
    real_world: bool = True  # uneven and dead LEDs, funnel glow, structure, caustics, particles, vignetting, JPEG


def random_scene(camera: CameraModel, rng: np.random.Generator, mix: ScenarioMix = ScenarioMix(),
                 range_m: float | None = None, kind: str | None = None) -> SceneSpec:
    """One scene. ``kind`` forces 'plain', 'reflection', 'distractors' or 'empty'."""
    if kind is None:
        roll = rng.uniform()
        if roll < mix.empty_share:
            kind = "empty"
        elif roll < mix.empty_share + mix.reflection_share:
            kind = "reflection"
        elif roll < mix.empty_share + mix.reflection_share + mix.distractor_share:
            kind = "distractors"
        else:
            kind = "plain"
    attenuation = rng.uniform(0.04, 0.2)
    spec = SceneSpec(
        marker_radius_m=mix.marker_radius_m,
        strip_width_m=rng.uniform(0.015, 0.04),
        led_count=int(rng.choice([0, 0, 0, 24, 48, 96])),
        led_bgr=_LED_COLOURS[rng.integers(len(_LED_COLOURS))],
        brightness=float(np.exp(rng.uniform(np.log(1.2), np.log(8.0)))),
        attenuation_per_m=attenuation,
        halo_fraction_per_m=rng.uniform(0.3, 1.0) * attenuation * 0.6,
        halo_sigma_rad=rng.uniform(0.006, 0.03),
        backscatter=rng.uniform(0.01, 0.15),
        ambient_top=rng.uniform(0.04, 0.35),
        ambient_bottom=rng.uniform(0.01, 0.08),
        water_bgr=_WATER_COLOURS[rng.integers(len(_WATER_COLOURS))],
        motion_blur_px=float(rng.choice([0.0, rng.uniform(1.0, 8.0)])),
        motion_blur_angle_rad=rng.uniform(0, math.pi),
        read_noise=rng.uniform(1.0, 4.0),
        shot_noise=rng.uniform(0.3, 1.0),
        seed=int(rng.integers(2**31)),
    )
    if mix.real_world:
        spec = _real_world(rng, spec)
    if kind == "empty":
        lamps = _glints(camera, rng, int(rng.integers(0, 6)))
        return replace(spec, marker_center_m=None, lamps=lamps)
    z = range_m if range_m is not None else rng.uniform(mix.min_range_m, mix.max_range_m)
    center = _marker_position(camera, rng, z, mix.marker_radius_m)
    spec = replace(spec, marker_center_m=tuple(center), marker_normal=tilted_normal(rng, math.radians(25)))
    if kind == "reflection":
        spec = reflection_above(camera, rng, spec)
    elif kind == "distractors":
        lamps = _lamps(camera, rng, int(rng.integers(1, 4))) + _glints(camera, rng, int(rng.integers(0, 4)))
        spec = replace(spec, lamps=lamps)
    return spec


def _real_world(rng: np.random.Generator, spec: SceneSpec) -> SceneSpec:
    """Each effect present in part of the population, at a strength drawn for the frame."""

    def sometimes(share: float, low: float, high: float) -> float:
        return float(rng.uniform(low, high)) if rng.uniform() < share else 0.0

    return replace(
        spec,
        led_spread=sometimes(0.7, 0.05, 0.35),
        dead_share=sometimes(0.3, 0.02, 0.12),
        funnel_glow=sometimes(0.4, 0.02, 0.15),
        clutter=sometimes(0.5, 0.02, 0.1),
        caustics=sometimes(0.3, 0.02, 0.1),
        particles=int(sometimes(0.4, 10, 250)),
        vignetting=sometimes(0.6, 0.1, 0.5),
        jpeg_quality=int(sometimes(0.5, 55, 95)),
    )


def _marker_position(camera: CameraModel, rng: np.random.Generator, z: float, radius_m: float) -> np.ndarray:
    """A centre whose whole ring is in view (when it fits) and inside the lens model's fold."""
    r_norm = radius_m / z * 1.15
    half_w = (camera.width / 2.0) / camera.fx
    half_h = (camera.height / 2.0) / camera.fy
    limit_x = max(0.0, 0.8 * half_w - r_norm)
    limit_y = max(0.0, 0.8 * half_h - r_norm)
    ox, oy = (camera.width / 2.0 - camera.cx) / camera.fx, (camera.height / 2.0 - camera.cy) / camera.fy
    x = ox + rng.uniform(-limit_x, limit_x)
    y = oy + rng.uniform(-limit_y, limit_y)
    return np.array([x * z, y * z, z])


def tilted_normal(rng: np.random.Generator, max_tilt_rad: float) -> tuple[float, float, float]:
    """The dock's axis towards the camera, tilted by up to ``max_tilt_rad`` in any direction."""
    tilt = rng.uniform(0, max_tilt_rad)
    azimuth = rng.uniform(0, 2 * math.pi)
    return (math.sin(tilt) * math.cos(azimuth), math.sin(tilt) * math.sin(azimuth), -math.cos(tilt))


def reflection_above(camera: CameraModel, rng: np.random.Generator, spec: SceneSpec) -> SceneSpec:
    """Put the surface where the ring's mirror image lands above it, sometimes cut by the top edge.

    With a level camera the surface is the plane y = -h and mirroring keeps z, so the
    mirrored centre's image row fixes h.
    """
    assert spec.marker_center_m is not None
    _, y, z = spec.marker_center_m
    r_px = camera.fy * spec.marker_radius_m / z
    v_marker = camera.fy * y / z + camera.cy
    if rng.uniform() < 0.3:
        target_v = rng.uniform(-0.5 * r_px, 0.5 * r_px)  # cut by the frame's top edge
    else:
        target_v = rng.uniform(r_px, max(r_px, v_marker - 2.2 * r_px))
    mirrored_y = (target_v - camera.cy) / camera.fy * z
    height = max(-(mirrored_y + y) / 2.0, -(y - spec.marker_radius_m) + 0.1)  # ring under water
    return replace(
        spec,
        surface_height_m=float(height),
        surface_up=(0.0, -1.0, 0.0),
        reflection_gain=rng.uniform(0.5, 1.0),
        ripple_m=rng.uniform(0.0, 0.05),
    )


def _lamps(camera: CameraModel, rng: np.random.Generator, count: int) -> tuple[Lamp, ...]:
    size = camera.focal_px / PAPER_FOCAL_PX  # sizes below are for the paper's lens; a shorter one shows them smaller
    return tuple(
        Lamp(rng.uniform(0, camera.width), rng.uniform(0, camera.height), size * rng.uniform(2.0, 10.0),
             rng.uniform(0.3, 3.0))
        for _ in range(count)
    )


def _glints(camera: CameraModel, rng: np.random.Generator, count: int) -> tuple[Lamp, ...]:
    size = camera.focal_px / PAPER_FOCAL_PX
    return tuple(
        Lamp(rng.uniform(0, camera.width), rng.uniform(0, camera.height), size * rng.uniform(0.5, 2.0),
             rng.uniform(0.2, 1.5))
        for _ in range(count)
    )


def dock_look(rng: np.random.Generator, discrete_share: float = 0.5) -> SceneSpec:
    """How one real-looking dock and its water look for a whole episode (geometry left to the caller).

    ``discrete_share`` of the docks carry 6-12 discrete LEDs that bloom (saturated white
    cores, halos of the LED's colour several pixels wide) just outside a lit white funnel
    with dark vanes and a hub; the others a continuous strip, around a funnel in half of them. The
    water is drawn too: attenuation, haze, colour. The caller sets marker_center_m,
    marker_normal, marker_radius_m, the surface and the seed per frame (PoolWorld.scene_for
    does).
    """
    attenuation = rng.uniform(0.05, 0.2)
    spec = SceneSpec(
        strip_width_m=rng.uniform(0.015, 0.04),
        attenuation_per_m=attenuation,
        halo_fraction_per_m=rng.uniform(0.1, 0.6) * attenuation * 0.6,
        halo_sigma_rad=rng.uniform(0.006, 0.03),
        backscatter=rng.uniform(0.02, 0.3),
        ambient_top=rng.uniform(0.05, 0.35),
        ambient_bottom=rng.uniform(0.01, 0.1),
        water_bgr=_GREEN_WATER_COLOURS[rng.integers(len(_GREEN_WATER_COLOURS))],
        read_noise=rng.uniform(1.0, 4.0),
        shot_noise=rng.uniform(0.3, 1.0),
        led_spread=float(rng.uniform(0.0, 0.3)),
    )
    discrete = rng.uniform() < discrete_share
    funnel = _funnel(rng) if discrete or rng.uniform() < 0.5 else None
    if discrete:
        return replace(
            spec,
            led_count=int(rng.integers(6, 13)),
            strip_width_m=rng.uniform(0.008, 0.025),  # the LED's lit dome
            led_bgr=_BLOOMING_LED_COLOURS[rng.integers(len(_BLOOMING_LED_COLOURS))],
            brightness=float(np.exp(rng.uniform(np.log(100.0), np.log(1500.0)))),
            led_psf_tail=rng.uniform(0.1, 0.3),
            led_psf_tail_rad=float(np.exp(rng.uniform(np.log(0.005), np.log(0.02)))),
            funnel=funnel,
        )
    return replace(
        spec,
        led_count=0,
        led_bgr=_LED_COLOURS[rng.integers(len(_LED_COLOURS))],
        brightness=float(np.exp(rng.uniform(np.log(2.0), np.log(20.0)))),
        funnel=funnel,
    )


def _funnel(rng: np.random.Generator) -> Funnel:
    """A dock's funnel: from dim grey to brighter than the sensor takes, vanes or none."""
    return Funnel(
        rim_share=1.0 / rng.uniform(1.04, 1.15),  # the LEDs sit just outside the rim
        brightness=float(np.exp(rng.uniform(np.log(0.3), np.log(3.0)))),
        bgr=(1.0, 1.0, rng.uniform(0.8, 1.0)),
        shading=rng.uniform(0.2, 0.7),
        shading_angle_rad=rng.uniform(0, 2 * math.pi),
        vanes=int(rng.choice([0, 3, 3, 4])),
        vane_angle_rad=rng.uniform(0, 2 * math.pi),
        vane_width_share=rng.uniform(0.05, 0.16),
        hub_share=rng.uniform(0.12, 0.3),
        depth_share=rng.uniform(0.3, 1.0),
        dark=rng.uniform(0.01, 0.1),
        rim_brightness=float(rng.choice([0.0, rng.uniform(0.2, 0.8)])),
    )
