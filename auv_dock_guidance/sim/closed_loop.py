"""One docking run in the simulated pool or open water, with the real detector, guidance and mixer in the loop.

Each camera frame is rendered from the true vehicle pose; the detector sees only the
image, guidance sees only the detection and the (noisy) navigation attitude, and the
mixer's pulse widths drive the vehicle dynamics. Ground truth is used for judging the
run afterwards (and labelling a detection that landed on the reflection, for the
failure statistics), and in open water for the main controller's acoustic homing that
drives the vehicle while guidance is still searching (another sensor, not guidance's).

The camera renders at ``render_scale`` of 1920x1080 with intrinsics scaled to match
(the documented fast mode: 960x540 by default), so a Monte Carlo of hundreds of runs
fits in minutes on two cores.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from auv_dock_guidance.control.cascade import Attitude, Target
from auv_dock_guidance.control.guidance import Guidance, GuidanceConfig, State
from auv_dock_guidance.control.mixer import Mixer
from auv_dock_guidance.control.pid import wrap_angle
from auv_dock_guidance.geometry.camera import CameraModel, paper_camera
from auv_dock_guidance.geometry.pose import circles_from_ellipse
from auv_dock_guidance.geometry.uncertainty import RingObservation, dock_pose, observation_of, tilt_sigma_rad
from auv_dock_guidance.sim.scenarios import dock_look
from auv_dock_guidance.sim.scene import GroundTruth, SceneSpec, render
from auv_dock_guidance.sim.vehicle import AuvDynamics
from auv_dock_guidance.sim.world import HULL_RADIUS_M, PoolWorld, VehiclePose
from auv_dock_guidance.vision.detection import Detection
from auv_dock_guidance.vision.detector import Detector, DetectorConfig

SCENARIOS = ("clear", "reflection", "open-water")
# Guidance variants compared by `auv-dock simulate --compare`: (velocity steering, axis alignment).
STEERING = {"plain": (False, False), "tracker": (True, False), "axis": (False, True), "both": (True, True)}
OPEN_WATER_CURRENT_MPS = 0.3  # largest steady current in open water unless --current says otherwise


@dataclass(frozen=True)
class OpenWaterStart:
    """A chosen open-water start instead of a random one (tests, demos); the water and dock look stay random."""

    range_m: float
    off_axis_deg: float  # seen from the dock, positive counter-clockwise
    heading_off_deg: float = 0.0  # off the line to the dock
    depth_off_m: float = 0.0
    current_along_mps: float = 0.0  # steady current along the dock's axis (into the dock +)...
    current_across_mps: float = 0.0  # ...and across it (to the left of the inbound path +)


@dataclass(frozen=True)
class EpisodeConfig:
    scenario: str = "clear"  # clear | reflection (the pool) | open-water
    camera_hz: float = 10.0
    control_hz: float = 50.0
    render_scale: float = 0.5
    max_time_s: float | None = None  # None: 150 s in the pool, 300 s in open water
    vehicle_radius_m: float = HULL_RADIUS_M
    max_heading_error_deg: float = 15.0
    steering: str = "both"  # plain (the paper's bearing homing) | tracker | axis | both
    current_mps: float | None = None  # largest random water current; None: 0 in the pool, 0.3 m/s in open water
    guidance: GuidanceConfig = field(default_factory=GuidanceConfig)
    start: OpenWaterStart | None = None  # open water: this start and current instead of random ones

    def __post_init__(self) -> None:
        if self.scenario not in SCENARIOS:
            raise ValueError(f"scenario {self.scenario!r} is not one of {', '.join(SCENARIOS)}")
        if self.steering not in STEERING:
            raise ValueError(f"steering {self.steering!r} is not one of {', '.join(STEERING)}")

    @property
    def open_water(self) -> bool:
        return self.scenario == "open-water"

    def guidance_config(self) -> GuidanceConfig:
        velocity, axis = STEERING[self.steering]
        return replace(self.guidance, velocity_steering=velocity, axis_alignment=axis)

    def largest_current_mps(self) -> float:
        if self.current_mps is not None:
            return self.current_mps
        return OPEN_WATER_CURRENT_MPS if self.open_water else 0.0

    def time_limit_s(self) -> float:
        if self.max_time_s is not None:
            return self.max_time_s
        return 300.0 if self.open_water else 150.0


@dataclass
class EpisodeResult:
    seed: int
    success: bool
    reason: str  # "docked" or the failure
    time_s: float
    entry_lateral_error_m: float | None
    entry_heading_error_deg: float | None
    max_detection_range_m: float | None
    trajectory: list[tuple[float, float, float, float, float]]  # t, nose_in_dock_frame (m), yaw
    bearing_errors: list[tuple[float, float, float]]  # t, yaw bearing deg, pitch bearing deg
    states: list[tuple[float, str]]
    frames: int = 0
    reflection_frames: int = 0
    retries: int = 0
    sidesteps: int = 0  # backing off sideways to bring the approach line within reach
    start_range_m: float = 0.0  # from the dock's entrance centre
    start_off_axis_deg: float = 0.0  # angle off the dock's axis as seen from the dock
    current_mps: float = 0.0  # steady current's speed
    cross_current_mps: float = 0.0  # its part across the dock's axis


def initial_pose(world: PoolWorld, rng: np.random.Generator) -> VehiclePose:
    """8-15 m out, up to 2 m to the side and 1 m off the dock's depth, heading off by up to 20 deg."""
    distance = rng.uniform(8.0, 15.0)
    return VehiclePose(
        x=world.dock_x_m - distance,
        y=rng.uniform(-2.0, 2.0),
        z=-world.dock_depth_m + rng.uniform(-1.0, 1.0),
        yaw=math.radians(rng.uniform(-20.0, 20.0)),
    )


def open_water_start(world: PoolWorld, rng: np.random.Generator, chosen: OpenWaterStart | None = None
                     ) -> VehiclePose:
    """10-30 m from the dock, within 40 deg of its axis seen from the dock, heading within 40 deg of the
    line to the dock, depth within 2 m of the dock's (or the chosen start)."""
    distance, off_axis = rng.uniform(10.0, 30.0), rng.uniform(-40.0, 40.0)
    heading_off, depth_off = rng.uniform(-40.0, 40.0), rng.uniform(-2.0, 2.0)
    if chosen is not None:
        distance, off_axis = chosen.range_m, chosen.off_axis_deg
        heading_off, depth_off = chosen.heading_off_deg, chosen.depth_off_m
    outward = world.dock_axis_yaw_rad + math.pi + math.radians(off_axis)
    x = world.dock_center[0] + distance * math.cos(outward)
    y = world.dock_center[1] + distance * math.sin(outward)
    to_dock = math.atan2(world.dock_center[1] - y, world.dock_center[0] - x)  # world yaw, left +
    return VehiclePose(x=x, y=y, z=world.dock_center[2] + depth_off,
                       yaw=wrap_angle(-to_dock + math.radians(heading_off)))


OPEN_WATER_ATTENUATION_PER_M = (0.03, 0.1)  # clear to coastal sea water: the dock shows where the camera takes over


def episode_world(config: EpisodeConfig, rng: np.random.Generator) -> PoolWorld:
    """The pool (or open water) with this episode's water: turbidity and LED brightness vary between runs.

    Open water: a real-looking dock (``dock_look``: blooming LEDs around a lit funnel, or a
    strip) in sea water of 0.03-0.1 /m, where a dock shows 15-30 m out, where the camera
    takes over from acoustic homing (``dock_look`` draws up to 0.2 /m, the turbid water of
    harbours and pools, which would hide it there). Its halo is scaled with the attenuation.
    """
    if config.open_water:
        look = dock_look(rng)
        attenuation = rng.uniform(*OPEN_WATER_ATTENUATION_PER_M)
        scene = replace(look, attenuation_per_m=attenuation,
                        halo_fraction_per_m=look.halo_fraction_per_m * attenuation / look.attenuation_per_m)
        return PoolWorld(dock_depth_m=8.0, walls=False, scene=scene,
                         dock_axis_yaw_rad=float(rng.uniform(-math.pi, math.pi)))
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


def episode_vehicle(config: EpisodeConfig, world: PoolWorld, rng: np.random.Generator, seed: int) -> AuvDynamics:
    """The vehicle at its start, in this episode's current (open water: any direction, with slow gusts)."""
    largest = config.largest_current_mps()
    if config.open_water:
        start = open_water_start(world, rng, config.start)
        speed, direction = rng.uniform(0.0, largest), rng.uniform(-math.pi, math.pi)
        if config.start is not None:
            along, across = config.start.current_along_mps, config.start.current_across_mps
            speed, direction = math.hypot(along, across), world.dock_axis_yaw_rad + math.atan2(across, along)
        current = (speed * math.cos(direction), speed * math.sin(direction), 0.0)
        return AuvDynamics(start, seed=seed, current_mps=current, gust_mps=0.2 * speed)
    start = initial_pose(world, rng)
    x, y, z = (float(v) for v in rng.uniform(-1, 1, 3) * largest * np.array([1, 1, 0.2]))
    return AuvDynamics(start, seed=seed, current_mps=(x, y, z))


class AcousticHoming:
    """Open water: the main controller's own homing on an acoustic bearing, until the camera takes over.

    Guidance is neutral in SEARCH; a real vehicle is then still homing on the dock's
    acoustic beacon, so the simulated main controller steers towards the beacon's bearing
    (off by a fixed bias of up to 8 deg) at cruise speed. It reads the simulator's truth:
    it stands for another sensor, not for anything guidance sees.
    """

    def __init__(self, world: PoolWorld, rng: np.random.Generator, cruise_mps: float, full_thrust_mps: float) -> None:
        self.world = world
        self.bias_rad = math.radians(rng.uniform(-8.0, 8.0))
        self.surge = (cruise_mps / full_thrust_mps) ** 2
        self.mixer = Mixer()

    def command(self, pose: VehiclePose, yaw_rate: float) -> tuple[int, int, int, int]:
        dock = self.world.dock_center
        to_dock = -math.atan2(dock[1] - pose.y, dock[0] - pose.x) + self.bias_rad  # navigation yaw
        yaw = 1.5 * wrap_angle(to_dock - pose.yaw) - 0.6 * yaw_rate
        pitch = 1.5 * (-pose.pitch)
        return self.mixer.mix(self.surge, max(-0.6, min(0.6, yaw)), max(-0.6, min(0.6, pitch))).pwm_us


FrameHook = Callable[[float, np.ndarray, Detection, GroundTruth], None]  # t, frame, what was found, truth


def run_episode(config: EpisodeConfig, seed: int, on_frame: FrameHook | None = None) -> EpisodeResult:
    """One reproducible run; ``on_frame`` sees every camera frame (the report's pictures)."""
    rng = np.random.default_rng(seed)
    world = episode_world(config, rng)
    camera: CameraModel = paper_camera().scaled(config.render_scale)
    vehicle = episode_vehicle(config, world, rng, seed)
    guidance_config = config.guidance_config()
    guidance_config = replace(guidance_config, approach=replace(  # as a deployment in a pool or harbour sets it
        guidance_config.approach, side_room_m=world.side_room_m(config.vehicle_radius_m)))
    homing = AcousticHoming(world, rng, guidance_config.cascade.cruise_speed_mps,
                            guidance_config.cascade.full_thrust_speed_mps) if config.open_water else None
    # Tracking as the deployed detector node runs it: a window round the predicted ring, the whole frame when lost.
    detector = Detector(camera, DetectorConfig(marker_radius_m=world.entrance_radius_m, tracking=True))
    guidance = Guidance(guidance_config)
    result = EpisodeResult(seed, False, "timeout", 0.0, None, None, None, [], [], [])
    _describe_start(result, world, vehicle)
    dt = 1.0 / config.control_hz
    frame_period = 1.0 / config.camera_hz
    next_frame, t, frame = 0.0, 0.0, 0
    max_range = 0.0
    docked_at: float | None = None
    last_state = guidance.state
    while t < config.time_limit_s():
        nav = vehicle.navigation()
        attitude = Attitude(t, nav.roll, nav.pitch, nav.yaw, nav.depth, nav.yaw_rate)
        target = None
        if t >= next_frame:
            next_frame += frame_period
            frame += 1
            spec = world.scene_for(vehicle.pose, seed=seed * 100000 + frame)
            image, truth = render(camera, spec)
            detection = detector.detect(image, t)
            if on_frame is not None:
                on_frame(t, image, detection, truth)
            guidance.frame_processed(t)
            pose = detection.pose
            if detection.found and pose is not None:
                observation = observation_of(detection, world.entrance_radius_m, camera.focal_px, camera.width)
                axis, axis_sigma = ring_axis(detection, observation, world.entrance_radius_m)
                target = Target(t, pose.range_m, pose.offset_x_m, pose.offset_y_m, axis, axis_sigma,
                                position_covariance(observation))
                if truth.center_px is not None:
                    max_range = max(max_range, truth.position_m[2] if truth.position_m else 0.0)
                if _on_reflection(detection.u, detection.v, truth):
                    result.reflection_frames += 1
                result.bearing_errors.append((t, pose.yaw_deg, pose.pitch_deg))
            else:
                guidance.marker_missed()
        out = guidance.update(t, target, attitude, docked_signal=False)
        if out.state is not last_state:
            result.states.append((t, out.state.value))
            last_state = out.state
        pwm = out.command.pwm_us
        if homing is not None and out.state is State.SEARCH:
            pwm = homing.command(vehicle.pose, nav.yaw_rate)
        vehicle.advance(pwm, dt)
        t += dt
        p = vehicle.pose
        crossed = world.past_entrance_m(p) >= 0
        if frame % 2 == 0 or crossed:  # the track ends on the entrance plane
            result.trajectory.append((t, *nose_in_dock_frame(world, p), p.yaw))
        if crossed:
            result.reason, result.entry_lateral_error_m, result.entry_heading_error_deg = entry_outcome(
                world, p, config.vehicle_radius_m, config.max_heading_error_deg)
            result.success = result.reason == "docked"
            break
        if world.collides(p, config.vehicle_radius_m):
            result.reason = "collision"
            break
        if out.state is State.ABORT:
            reason = out.transition.reason if out.transition else ""
            result.reason = "lost_marker" if ("marker" in reason or "lost" in reason) else \
                "would_miss" if "would miss" in reason else "abort"
            break
        if out.state is State.DOCKED:
            docked_at = docked_at if docked_at is not None else t
            if t - docked_at > 10.0:
                result.reason = "stopped_short"
                break
    result.time_s = t
    result.frames = frame
    result.retries = guidance.retries
    result.sidesteps = guidance.sidesteps
    result.max_detection_range_m = max_range or None
    if not result.success and result.reason != "timeout" and result.reflection_frames > frame / 4:
        result.reason = "chose_reflection"
    return result


def ring_axis(detection: Detection, observation: RingObservation | None, entrance_radius_m: float
              ) -> tuple[tuple[float, float, float] | None, float | None]:
    """The ring's axis as the fit resolved it, or else one of the two circles its ellipse fits (guidance's
    axis estimate takes every observation as a pair of mirror images and tells them apart as the view
    moves), with the standard deviation of its tilt from the fit's scatter (``observation``, the detection's)."""
    normal = detection.ring_normal
    if normal is None and detection.ellipse is not None:
        candidates = circles_from_ellipse(detection.ellipse, entrance_radius_m)
        normal = tuple(float(v) for v in candidates[0].normal) if candidates else None  # type: ignore[assignment]
    if normal is None or observation is None or observation.visible_arc_deg < 360.0 or observation.tilt_disputed:
        return None, None  # a ring cut by the frame or of the wrong LED count: dock/pose reports no axis either
    return normal, tilt_sigma_rad(observation, normal)


def position_covariance(observation: RingObservation | None) -> tuple[float, ...] | None:
    """The position covariance dock/pose would publish with this observation (the tracker weighs the
    detection by it), or None where dock/pose publishes nothing."""
    if observation is None:
        return None
    try:
        return tuple(float(v) for v in dock_pose(observation).matrix()[:3, :3].ravel())
    except ValueError:
        return None


def _describe_start(result: EpisodeResult, world: PoolWorld, vehicle: AuvDynamics) -> None:
    """Where the episode starts relative to the dock, and its current: the bins results are reported by."""
    p = vehicle.pose
    outward = np.array([p.x, p.y, p.z]) - world.dock_center
    result.start_range_m = float(np.linalg.norm(outward))
    horizontal = outward[:2] / max(float(np.linalg.norm(outward[:2])), 1e-9)
    result.start_off_axis_deg = math.degrees(math.acos(max(-1.0, min(1.0, float(-horizontal @ world.dock_axis[:2])))))
    current = np.asarray(vehicle.current_mps, dtype=float)
    result.current_mps = float(np.linalg.norm(current[:2]))
    result.cross_current_mps = float(abs(current[0] * -world.dock_axis[1] + current[1] * world.dock_axis[0]))


def nose_in_dock_frame(world: PoolWorld, pose: VehiclePose) -> tuple[float, float, float]:
    """The nose along the dock's axis (0 on the entrance plane, negative in front of it), left
    of the axis and above it (m): where trajectories of any scenario are drawn."""
    rel = world.camera_position(pose) - world.dock_center
    axis = world.dock_axis
    left = np.array([-axis[1], axis[0], 0.0])
    return float(rel @ axis), float(rel @ left), float(rel[2])


def entry_outcome(world: PoolWorld, pose: VehiclePose, vehicle_radius_m: float = HULL_RADIUS_M,
                  max_heading_error_deg: float = 15.0) -> tuple[str, float, float]:
    """(reason, lateral error m, heading error deg) as the nose crosses the entrance plane.

    Docked: the nose is inside the entrance radius less the hull radius, and the hull is
    within the heading limit of the dock's axis.
    """
    lateral = world.off_axis_m(pose)
    heading = math.degrees(world.heading_off_axis_rad(pose))
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
