"""One docking run in the simulated pool, with the real detector, guidance and mixer in the loop.

Each camera frame is rendered from the true vehicle pose; the detector sees only the
image, guidance sees only the detection and the (noisy) navigation attitude, and the
mixer's pulse widths drive the vehicle dynamics. Ground truth is used for one thing
only: judging the run afterwards (and labelling a detection that landed on the
reflection, for the failure statistics).

The camera renders at ``render_scale`` of 1920x1080 with intrinsics scaled to match
(the documented fast mode: 960x540 by default), so a Monte Carlo of hundreds of runs
fits in minutes on two cores.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from auv_dock_guidance.control.cascade import Attitude, Target
from auv_dock_guidance.control.guidance import Guidance, GuidanceConfig, State
from auv_dock_guidance.control.tracker import TargetTracker
from auv_dock_guidance.geometry.camera import CameraModel, paper_camera
from auv_dock_guidance.sim.scene import SceneSpec, render
from auv_dock_guidance.sim.vehicle import AuvDynamics
from auv_dock_guidance.sim.world import PoolWorld, VehiclePose
from auv_dock_guidance.vision.detector import Detector, DetectorConfig


@dataclass(frozen=True)
class EpisodeConfig:
    scenario: str = "clear"  # clear | reflection
    camera_hz: float = 10.0
    control_hz: float = 50.0
    render_scale: float = 0.5
    max_time_s: float = 150.0
    vehicle_radius_m: float = 0.12
    max_heading_error_deg: float = 15.0
    tracker: bool = False  # smooth detections with a constant-velocity Kalman filter
    axis_alignment: bool = False  # steer onto the dock axis before the terminal phase
    current_mps: float = 0.0  # largest random water current
    guidance: GuidanceConfig = field(default_factory=GuidanceConfig)


@dataclass
class EpisodeResult:
    seed: int
    success: bool
    reason: str  # "docked" or the failure
    time_s: float
    entry_lateral_error_m: float | None
    entry_heading_error_deg: float | None
    max_detection_range_m: float | None
    trajectory: list[tuple[float, float, float, float, float]]  # t, x, y, z, yaw
    bearing_errors: list[tuple[float, float, float]]  # t, yaw bearing deg, pitch bearing deg
    states: list[tuple[float, str]]
    frames: int = 0
    reflection_frames: int = 0


def initial_pose(world: PoolWorld, rng: np.random.Generator) -> VehiclePose:
    """8-15 m out, up to 2 m to the side and 1 m off the dock's depth, heading off by up to 20 deg."""
    distance = rng.uniform(8.0, 15.0)
    return VehiclePose(
        x=world.dock_x_m - distance,
        y=rng.uniform(-2.0, 2.0),
        z=-world.dock_depth_m + rng.uniform(-1.0, 1.0),
        yaw=math.radians(rng.uniform(-20.0, 20.0)),
    )


def episode_world(config: EpisodeConfig, rng: np.random.Generator) -> PoolWorld:
    """The pool with this episode's water: turbidity and LED brightness vary between runs."""
    attenuation = rng.uniform(0.05, 0.15)
    scene = SceneSpec(
        brightness=rng.uniform(2.0, 4.0),
        attenuation_per_m=attenuation,
        halo_fraction_per_m=0.5 * attenuation,
        backscatter=rng.uniform(0.03, 0.12),
        ambient_top=rng.uniform(0.1, 0.3),
        read_noise=rng.uniform(1.5, 3.0),
        reflection_gain=rng.uniform(0.6, 1.0),
        ripple_m=rng.uniform(0.0, 0.04),
        led_count=int(rng.choice([0, 0, 48, 96])),
    )
    return PoolWorld(reflection=config.scenario == "reflection", scene=scene)


def run_episode(config: EpisodeConfig, seed: int) -> EpisodeResult:
    rng = np.random.default_rng(seed)
    world = episode_world(config, rng)
    camera: CameraModel = paper_camera().scaled(config.render_scale)
    vehicle = AuvDynamics(initial_pose(world, rng), seed=seed,
                          current_mps=tuple(rng.uniform(-1, 1, 3) * config.current_mps * np.array([1, 1, 0.2])))
    detector = Detector(camera, DetectorConfig(marker_radius_m=world.entrance_radius_m))
    guidance = Guidance(config.guidance)
    tracker = TargetTracker() if config.tracker else None
    result = EpisodeResult(seed, False, "timeout", 0.0, None, None, None, [], [], [])
    dt = 1.0 / config.control_hz
    frame_period = 1.0 / config.camera_hz
    next_frame, t, frame = 0.0, 0.0, 0
    max_range = 0.0
    docked_at: float | None = None
    last_state = guidance.state
    while t < config.max_time_s:
        nav = vehicle.navigation()
        attitude = Attitude(t, nav.roll, nav.pitch, nav.yaw, nav.depth)
        target = None
        if t >= next_frame:
            next_frame += frame_period
            frame += 1
            spec = world.scene_for(vehicle.pose, seed=seed * 100000 + frame)
            image, truth = render(camera, spec)
            detection = detector.detect(image)
            guidance.frame_processed(t)
            pose = detection.pose
            if detection.found and pose is not None:
                target = Target(t, pose.range_m, pose.offset_x_m, pose.offset_y_m)
                if truth.center_px is not None:
                    max_range = max(max_range, truth.position_m[2] if truth.position_m else 0.0)
                if _on_reflection(detection.u, detection.v, truth):
                    result.reflection_frames += 1
                result.bearing_errors.append((t, pose.yaw_deg, pose.pitch_deg))
            else:
                guidance.marker_missed()
            if tracker is not None:
                target = tracker.update(t, target)
            if config.axis_alignment and target is not None and detection.ring_normal is not None:
                target = _aligned(target, detection.ring_normal, guidance.config.terminal_range_m)
        out = guidance.update(t, target, attitude, docked_signal=False)
        if out.state is not last_state:
            result.states.append((t, out.state.value))
            last_state = out.state
        vehicle.advance(out.command.pwm_us, dt)
        t += dt
        p = vehicle.pose
        if frame % 2 == 0:
            result.trajectory.append((t, p.x, p.y, p.z, p.yaw))
        if world.camera_position(p)[0] >= world.dock_x_m:
            result.reason, result.entry_lateral_error_m, result.entry_heading_error_deg = entry_outcome(
                world, p, config.vehicle_radius_m, config.max_heading_error_deg)
            result.success = result.reason == "docked"
            break
        if abs(p.y) > world.width_m / 2 - config.vehicle_radius_m or not (-world.depth_m < p.z < -0.1):
            result.reason = "collision"
            break
        if out.state is State.ABORT:
            reason = out.transition.reason if out.transition else ""
            result.reason = "lost_marker" if ("marker" in reason or "lost" in reason) else "abort"
            break
        if out.state is State.DOCKED:
            docked_at = docked_at if docked_at is not None else t
            if t - docked_at > 10.0:
                result.reason = "stopped_short"
                break
    result.time_s = t
    result.frames = frame
    result.max_detection_range_m = max_range or None
    if not result.success and result.reason != "timeout" and result.reflection_frames > frame / 4:
        result.reason = "chose_reflection"
    return result


def entry_outcome(world: PoolWorld, pose: VehiclePose, vehicle_radius_m: float = 0.12,
                  max_heading_error_deg: float = 15.0) -> tuple[str, float, float]:
    """(reason, lateral error m, heading error deg) as the nose crosses the entrance plane.

    Docked: the nose is inside the entrance radius less the hull radius, and the hull is
    within the heading limit of the dock's axis.
    """
    nose = world.camera_position(pose)
    lateral = float(math.hypot(nose[1] - world.dock_center[1], nose[2] - world.dock_center[2]))
    heading = math.degrees(math.acos(max(-1.0, min(1.0, float(pose.body_to_world()[0, 0])))))
    if lateral >= world.entrance_radius_m - vehicle_radius_m:
        return "missed", lateral, heading
    return ("docked" if heading < max_heading_error_deg else "bad_heading"), lateral, heading


def _on_reflection(u: float, v: float, truth) -> bool:
    if truth.reflection_center_px is None:
        return False
    to_reflection = math.hypot(u - truth.reflection_center_px[0], v - truth.reflection_center_px[1])
    if truth.center_px is None:
        return True
    return to_reflection < math.hypot(u - truth.center_px[0], v - truth.center_px[1])


def _aligned(target: Target, ring_normal: tuple[float, float, float], terminal_range_m: float) -> Target:
    """Aim at a point on the dock's axis ahead of the entrance instead of at the entrance itself.

    The ring's axis (from the tilt-aware fit) points out of the dock towards the camera; a
    lead point on it at a distance shrinking with range pulls the vehicle onto the axis
    before the terminal phase, so it enters straight rather than at an angle.
    """
    n = np.asarray(ring_normal, dtype=float)
    if n[2] > -0.5:  # implausible axis (more than 60 deg off): keep the plain target
        return target
    lead = 0.35 * max(0.0, target.range_m - terminal_range_m)
    aim = np.array([target.offset_x_m, target.offset_y_m, target.range_m]) + lead * n
    if aim[2] <= 0.5:
        return target
    return replace(target, range_m=float(aim[2]), offset_x_m=float(aim[0]), offset_y_m=float(aim[1]))
