"""Detector accuracy against rendered ground truth: the numbers behind `auv-dock evaluate`.

Frames are judged by what they show: the ring whole in view, cut by the frame edge with
half of it or more in view, or only a corner in view (less than half). Detection rates
and errors are reported for whole and cut rings together and apart; corners have their
own rate, since a detection there is welcome but not required.

Each good detection's position error is also told in the standard deviations `dock/pose`
publishes for it (x and y across the line of sight, z along it): for a covariance that
neither flatters nor hides the detector, half the errors lie within 0.67 of them and 95 %
within 1.96.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from auv_dock_guidance.geometry.camera import CameraModel
from auv_dock_guidance.geometry.uncertainty import dock_pose, observation_of
from auv_dock_guidance.sim.real_dock import real_dock_scene
from auv_dock_guidance.sim.scenarios import ScenarioMix, random_scene
from auv_dock_guidance.sim.scene import GroundTruth, SceneSpec, render
from auv_dock_guidance.vision.detector import Detection, Detector, DetectorConfig


@dataclass(frozen=True)
class FrameOutcome:
    """One frame judged against its ground truth."""

    kind: str
    range_m: float | None
    found: bool
    correct: bool  # found, and on the marker (not on a reflection or lamp)
    chose_reflection: bool
    center_error_px: float | None
    range_error_rel: float | None
    yaw_error_deg: float | None
    pitch_error_deg: float | None
    view: str = "whole"  # GroundTruth.view: whole, cut, corner, or none (no marker in view)
    error_in_sigmas: tuple[float, float, float] | None = None  # position error / dock/pose's deviations (x, y, z)


def judge(detection: Detection, truth: GroundTruth, kind: str) -> FrameOutcome:
    """Compare one detection with the truth it was rendered from.

    A detection is on the marker when its centre is within half the ring's radius of the
    true centre (5 px at least); on a corner, within the ring (it points at the dock).
    """
    view = truth.view
    if not truth.marker_visible or truth.center_px is None or truth.position_m is None:
        return FrameOutcome(kind, None, detection.found, False, False, None, None, None, None, view)
    x, y, z = truth.position_m
    if not detection.found:
        return FrameOutcome(kind, z, False, False, False, None, None, None, None, view)
    error = math.hypot(detection.u - truth.center_px[0], detection.v - truth.center_px[1])
    on_reflection = False
    if truth.reflection_center_px is not None:
        ru, rv = truth.reflection_center_px
        to_reflection = math.hypot(detection.u - ru, detection.v - rv)
        on_reflection = to_reflection < error
    tolerance = (1.0 if view == "corner" else 0.5) * (truth.radius_px or 0.0)
    correct = not on_reflection and error < max(5.0, tolerance)
    pose = detection.pose
    if not correct or pose is None:
        return FrameOutcome(kind, z, True, correct, on_reflection, error if correct else None, None, None, None, view)
    return FrameOutcome(
        kind=kind,
        range_m=z,
        found=True,
        correct=True,
        chose_reflection=False,
        center_error_px=error,
        range_error_rel=abs(pose.range_m - z) / z,
        yaw_error_deg=abs(pose.yaw_deg - math.degrees(math.atan2(x, z))),
        pitch_error_deg=abs(pose.pitch_deg - math.degrees(math.atan2(y, z))),
        view=view,
    )


@dataclass(frozen=True)
class EvalCase:
    """One frame to render and detect, the camera it is seen through, and what the detector is told."""

    camera: CameraModel
    spec: SceneSpec
    leds_described: bool = False  # the detector is told the dock's LED count (0: a strip), as its user would


def described_marker(config: DetectorConfig, case: EvalCase) -> DetectorConfig:
    """``config`` told this case's dock: its ring radius always, its LED count where described."""
    changes: dict[str, Any] = {}
    if case.spec.marker_radius_m != config.marker_radius_m:
        changes["marker_radius_m"] = case.spec.marker_radius_m
    if case.leds_described and case.spec.led_count != config.led_count:
        changes["led_count"] = case.spec.led_count
    return replace(config, **changes) if changes else config


def _scene_kind(spec: SceneSpec) -> str:
    if spec.marker_center_m is None:
        return "empty"
    if spec.surface_height_m is not None:
        return "reflection"
    return "distractors" if spec.lamps else "plain"


def _run_one(args: tuple[CameraModel, DetectorConfig, SceneSpec]) -> FrameOutcome:
    camera, config, spec = args
    image, truth = render(camera, spec)
    detection = Detector(camera, config).detect(image)
    outcome = judge(detection, truth, _scene_kind(spec))
    if outcome.range_error_rel is None:
        return outcome
    return replace(outcome, error_in_sigmas=error_in_sigmas(detection, truth, camera, config.marker_radius_m))


def error_in_sigmas(detection: Detection, truth: GroundTruth, camera: CameraModel,
                    marker_radius_m: float) -> tuple[float, float, float] | None:
    """The detection's position error over the standard deviations dock/pose publishes with it (x, y, z)."""
    observation = observation_of(detection, marker_radius_m, camera.focal_px, camera.width)
    if observation is None or truth.position_m is None:
        return None
    try:
        pose = dock_pose(observation)
    except ValueError:  # a fit behind the camera: dock/pose publishes nothing either
        return None
    sigmas = np.sqrt(np.diag(pose.matrix())[:3])
    errors = np.subtract(pose.position_m, truth.position_m)
    x, y, z = (float(v) for v in np.abs(errors) / sigmas)
    return x, y, z


def run_frames(
    camera: CameraModel,
    config: DetectorConfig,
    specs: list[SceneSpec],
    workers: int = 1,
    progress: Callable[[int, int], None] | None = None,
) -> list[FrameOutcome]:
    """Render and detect every scene (each frame independent), in parallel when workers > 1."""
    return run_cases([EvalCase(camera, spec) for spec in specs], config, workers, progress)


def run_cases(
    cases: list[EvalCase],
    config: DetectorConfig,
    workers: int = 1,
    progress: Callable[[int, int], None] | None = None,
) -> list[FrameOutcome]:
    """Render and detect each case through its own camera, in parallel when workers > 1.

    The detector is told each scene's dock (described_marker), as a user describes their
    marker, also in frames where the dock is not in view.
    """
    jobs = [(case.camera, described_marker(config, case), case.spec) for case in cases]
    results: list[FrameOutcome] = []
    mapped: Iterable[FrameOutcome]
    if workers > 1:
        pool = ProcessPoolExecutor(max_workers=workers)
        mapped = pool.map(_run_one, jobs, chunksize=4)
    else:
        pool = None
        mapped = map(_run_one, jobs)
    try:
        for outcome in mapped:
            results.append(outcome)
            if progress is not None:
                progress(len(results), len(jobs))
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
    return results


def population(camera: CameraModel, frames: int, seed: int, mix: ScenarioMix = ScenarioMix()) -> list[SceneSpec]:
    rng = np.random.default_rng(seed)
    return [random_scene(camera, rng, mix) for _ in range(frames)]


def real_dock_population(frames: int, seed: int) -> list[EvalCase]:
    """The real-dock population (sim/real_dock.py): each frame with its own PAL camera, the
    detector told each dock's radius and LED count (not its colour)."""
    rng = np.random.default_rng(seed)
    return [EvalCase(*real_dock_scene(rng), leds_described=True) for _ in range(frames)]


def sweep_population(
    camera: CameraModel,
    ranges_m: Iterable[int],
    frames_per_range: int,
    seed: int,
    attenuation_per_m: float,
    brightness: float,
    mix: ScenarioMix = ScenarioMix(),
) -> list[SceneSpec]:
    """Plain marker frames at each whole-metre range, with one water and LED brightness."""
    rng = np.random.default_rng(seed)
    specs = []
    for r in ranges_m:
        for _ in range(frames_per_range):
            spec = random_scene(camera, rng, mix, range_m=float(r) + rng.uniform(-0.5, 0.5), kind="plain")
            specs.append(
                replace(
                    spec,
                    attenuation_per_m=attenuation_per_m,
                    halo_fraction_per_m=0.5 * attenuation_per_m,
                    brightness=brightness,
                )
            )
    return specs


def _percentile(values: list[float], q: float) -> float | None:
    return float(np.percentile(values, q)) if values else None


def _rate(outcomes: list[FrameOutcome]) -> float | None:
    return sum(o.correct for o in outcomes) / len(outcomes) if outcomes else None


def summarize(outcomes: list[FrameOutcome]) -> dict[str, Any]:
    """The evaluate report: rates and error percentiles.

    "marker" frames are those with half of the ring or more in view (whole or cut);
    corners (less than half) are counted apart and enter no other figure.
    """
    marker = [o for o in outcomes if o.range_m is not None and o.view != "corner"]
    whole = [o for o in marker if o.view == "whole"]
    cut = [o for o in marker if o.view == "cut"]
    corner = [o for o in outcomes if o.view == "corner"]
    empty = [o for o in outcomes if o.range_m is None]
    reflection = [o for o in marker if o.kind == "reflection"]
    good = [o for o in marker if o.correct and o.center_error_px is not None]
    centre = [o.center_error_px for o in good if o.center_error_px is not None]
    yaw = [o.yaw_error_deg for o in good if o.yaw_error_deg is not None]
    pitch = [o.pitch_error_deg for o in good if o.pitch_error_deg is not None]

    def range_errors(view: str | None) -> list[float]:
        return [o.range_error_rel for o in good if o.range_error_rel is not None and view in (None, o.view)]

    in_sigmas = [o.error_in_sigmas for o in good if o.error_in_sigmas is not None]
    across = [v for x, y, _ in in_sigmas for v in (x, y)]
    along = [z for _, _, z in in_sigmas]

    return {
        "frames": len(outcomes),
        "marker_frames": len(marker),
        "detection_rate": _rate(marker),
        "whole_frames": len(whole),
        "detection_rate_whole": _rate(whole),
        "cut_frames": len(cut),
        "detection_rate_cut": _rate(cut),
        "corner_frames": len(corner),
        "detection_rate_corner": _rate(corner),
        "corner_wrong_object": sum(o.found and not o.correct for o in corner),
        "empty_frames": len(empty),
        "false_positives": sum(o.found for o in empty),
        "reflection_frames": len(reflection),
        "reflection_chosen": sum(o.chose_reflection for o in reflection),
        "reflection_chosen_rate": sum(o.chose_reflection for o in reflection) / len(reflection) if reflection else None,
        "wrong_object": sum(o.found and not o.correct for o in marker),
        "center_error_px_p50": _percentile(centre, 50),
        "center_error_px_p95": _percentile(centre, 95),
        "range_error_rel_p50": _percentile(range_errors(None), 50),
        "range_error_rel_p95": _percentile(range_errors(None), 95),
        "range_error_rel_p50_whole": _percentile(range_errors("whole"), 50),
        "range_error_rel_p95_whole": _percentile(range_errors("whole"), 95),
        "range_error_rel_p50_cut": _percentile(range_errors("cut"), 50),
        "range_error_rel_p95_cut": _percentile(range_errors("cut"), 95),
        "yaw_error_deg_p50": _percentile(yaw, 50),
        "yaw_error_deg_p95": _percentile(yaw, 95),
        "pitch_error_deg_p50": _percentile(pitch, 50),
        "pitch_error_deg_p95": _percentile(pitch, 95),
        "pose_error_sigmas_across_p50": _percentile(across, 50),  # consistent: 0.67
        "pose_error_sigmas_across_p95": _percentile(across, 95),  # consistent: 1.96
        "pose_error_sigmas_range_p50": _percentile(along, 50),
        "pose_error_sigmas_range_p95": _percentile(along, 95),
    }


def sweep_summary(outcomes: list[FrameOutcome], required_rate: float = 0.95) -> dict[str, Any]:
    """Detection rate per whole metre, and the largest range up to which it stays at the required rate."""
    per_metre: dict[int, list[bool]] = {}
    for o in outcomes:
        if o.range_m is not None:
            per_metre.setdefault(int(round(o.range_m)), []).append(o.correct)
    rates = {m: sum(v) / len(v) for m, v in sorted(per_metre.items())}
    reach = None
    for metre, rate in rates.items():
        if rate < required_rate:
            break
        reach = metre
    return {"detection_rate_by_range_m": rates, "max_range_m_at_95pct": reach}


def edge_comparison(camera: CameraModel, frames: int, seed: int, scale: float = 0.5) -> dict[str, float]:
    """The paper's Table 1: traditional vs improved Canny on noisy renders with known clean edges.

    Each scene is rendered twice, with and without sensor noise. The ideal edges are the
    traditional Canny edges of the clean render (so neither method gets its own pipeline
    as the reference); both methods then run on the noisy render with the same hysteresis
    thresholds. PSNR (eq. 4) compares the edge maps (0/255) with the ideal one; Pratt's
    figure of merit (eq. 5, alpha = 1/9) scores edge placement. A half-size image keeps it quick.
    """
    import cv2

    from auv_dock_guidance.vision.edges import improved_canny, pratt_figure_of_merit, psnr, traditional_canny
    from auv_dock_guidance.vision.image_input import intensity

    small_camera = camera.scaled(scale)
    rng = np.random.default_rng(seed)
    totals = {"traditional": [0.0, 0.0], "improved": [0.0, 0.0]}
    for _ in range(frames):
        spec = random_scene(small_camera, rng, ScenarioMix(real_world=False), range_m=rng.uniform(3.0, 10.0),
                            kind="plain")
        spec = replace(spec, read_noise=rng.uniform(6.0, 12.0), shot_noise=rng.uniform(1.0, 2.0), led_count=0)
        noisy, _ = render(small_camera, spec)
        clean, _ = render(small_camera, replace(spec, read_noise=0.0, shot_noise=0.0))
        ideal = cv2.Canny(intensity(clean), 20, 50, L2gradient=True)
        gray = intensity(noisy)
        for name, edges in (
            ("traditional", traditional_canny(gray, 2.5, 6.0)),
            ("improved", improved_canny(gray, 2.5, 6.0)),
        ):
            totals[name][0] += psnr(ideal, edges)
            totals[name][1] += pratt_figure_of_merit(edges, ideal)
    return {
        "frames": frames,
        "traditional_psnr_db": totals["traditional"][0] / frames,
        "traditional_pfom": totals["traditional"][1] / frames,
        "improved_psnr_db": totals["improved"][0] / frames,
        "improved_pfom": totals["improved"][1] / frames,
    }
