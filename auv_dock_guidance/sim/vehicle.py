"""Dynamics of a torpedo-shaped AUV driven by four stern thrusters.

Five degrees of freedom (surge, sway, heave, pitch, yaw; roll held near zero as in the
paper), with added mass, linear and quadratic damping, a pitch restoring moment from the
centre of buoyancy above the centre of gravity, first-order thruster lag, an optional
water current (steady, plus slow gusts: sinusoids of periods 40-120 s in each horizontal
direction), and a navigation system that reports attitude and depth with noise.

Body axes follow the navigation convention: u forward, v to starboard, w down; q pitch
rate (nose up +), r yaw rate (to starboard +). The pose is a ``VehiclePose`` in the pool
frame (x along the pool, y left, z up).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from auv_dock_guidance.control.mixer import DEFAULT_ALLOCATION, PwmConfig
from auv_dock_guidance.sim.main_controller import VehicleState
from auv_dock_guidance.sim.world import VehiclePose


@dataclass(frozen=True)
class VehicleParams:
    mass_kg: float = 35.0
    added_mass_surge: float = 2.0
    added_mass_sway: float = 30.0
    added_mass_heave: float = 30.0
    inertia_pitch: float = 4.0  # kg m^2, added inertia included
    inertia_yaw: float = 4.0
    damping_surge: tuple[float, float] = (5.0, 40.0)  # linear N/(m/s), quadratic N/(m/s)^2
    damping_sway: tuple[float, float] = (30.0, 120.0)
    damping_heave: tuple[float, float] = (30.0, 120.0)
    damping_pitch: tuple[float, float] = (6.0, 8.0)  # N m/(rad/s), N m/(rad/s)^2
    damping_yaw: tuple[float, float] = (6.0, 8.0)
    restoring_pitch: float = 6.0  # N m per rad of pitch (metacentric height x weight)
    max_thrust_n: float = 12.0  # per thruster, forward and reverse
    thruster_lag_s: float = 0.15
    lateral_arm_m: float = 0.12  # thruster distance from the centre line, sideways...
    vertical_arm_m: float = 0.10  # ...and up/down
    roll_amplitude_rad: float = math.radians(2.0)  # small residual roll (under 5 deg)


@dataclass(frozen=True)
class NavigationNoise:
    attitude_rad: float = math.radians(0.3)
    rate_rad_s: float = math.radians(0.5)
    depth_m: float = 0.01


@dataclass
class AuvDynamics:
    """Integrates the vehicle; ``step`` has the ``VehicleModel`` signature of the main-controller simulator."""

    pose: VehiclePose
    params: VehicleParams = field(default_factory=VehicleParams)
    pwm: PwmConfig = field(default_factory=PwmConfig)
    current_mps: tuple[float, float, float] = (0.0, 0.0, 0.0)  # steady water velocity in the pool frame
    gust_mps: float = 0.0  # amplitude of the slow gusts on top of it (each horizontal direction)
    noise: NavigationNoise = field(default_factory=NavigationNoise)
    seed: int = 0
    docked: bool = False
    time_s: float = 0.0

    def __post_init__(self) -> None:
        self.velocity = np.zeros(3)  # u, v, w (body, nav convention)
        self.rates = np.zeros(2)  # q, r
        self.thrust = np.zeros(4)
        self._rng = np.random.default_rng(self.seed)
        self._allocation = np.asarray(DEFAULT_ALLOCATION)
        gusts = np.random.default_rng([self.seed, 1])
        self._gust_periods_s = gusts.uniform(40.0, 120.0, 2)
        self._gust_phases = gusts.uniform(0.0, 2 * math.pi, 2)

    def current_at(self, time_s: float) -> np.ndarray:
        """Water velocity (pool frame) at this time: the steady current plus the gusts."""
        swing = self.gust_mps * np.sin(2 * math.pi * time_s / self._gust_periods_s + self._gust_phases)
        return np.asarray(self.current_mps, dtype=float) + np.array([swing[0], swing[1], 0.0])

    @property
    def speed_mps(self) -> float:
        return float(self.velocity[0])

    def thrust_command(self, pwm_us: tuple[int, int, int, int]) -> np.ndarray:
        """Thrust each ESC asks for: linear in pulse width outside the deadband."""
        p = self.pwm
        out = np.zeros(4)
        for i, pulse in enumerate(pwm_us):
            offset = pulse - p.pwm_neutral_us
            if abs(offset) <= p.deadband_us:
                continue
            span = p.pwm_max_us - p.pwm_neutral_us if offset > 0 else p.pwm_neutral_us - p.pwm_min_us
            share = (abs(offset) - p.deadband_us) / (span - p.deadband_us)
            out[i] = math.copysign(min(1.0, share), offset) * self.params.max_thrust_n
        return out

    def advance(self, pwm_us: tuple[int, int, int, int], dt: float) -> None:
        """Integrate ``dt`` seconds (semi-implicit Euler, substeps of at most 10 ms)."""
        steps = max(1, int(math.ceil(dt / 0.01)))
        h = dt / steps
        target = self.thrust_command(pwm_us)
        for _ in range(steps):
            self._substep(target, h)

    def _substep(self, target_thrust: np.ndarray, h: float) -> None:
        p = self.params
        self.thrust += (target_thrust - self.thrust) * min(1.0, h / p.thruster_lag_s)
        t = self.thrust
        # Which way each thruster pushes the hull: surge, yaw to starboard, pitch nose up.
        surge = float(np.sum(t * self._allocation[:, 0]))
        yaw_moment = p.lateral_arm_m * float(np.sum(t * self._allocation[:, 1]))
        pitch_moment = p.vertical_arm_m * float(np.sum(t * self._allocation[:, 2]))
        u, v, w = self.velocity
        q, r = self.rates
        m = p.mass_kg
        du = (surge - _drag(p.damping_surge, u)) / (m + p.added_mass_surge)
        dv = (-_drag(p.damping_sway, v) - m * u * r) / (m + p.added_mass_sway)
        dw = (-_drag(p.damping_heave, w) - m * u * q) / (m + p.added_mass_heave)
        restoring = p.restoring_pitch * math.sin(self.pose.pitch)
        dq = (pitch_moment - _drag(p.damping_pitch, q) - restoring) / p.inertia_pitch
        dr = (yaw_moment - _drag(p.damping_yaw, r)) / p.inertia_yaw
        self.velocity += h * np.array([du, dv, dw])
        self.rates += h * np.array([dq, dr])
        pose = self.pose
        pitch = pose.pitch + h * self.rates[0]
        yaw = (pose.yaw + h * self.rates[1] + math.pi) % (2 * math.pi) - math.pi
        self.time_s += h
        roll = p.roll_amplitude_rad * math.sin(0.7 * self.time_s)
        # Body velocity (nav: forward, starboard, down) as FLU, into the pool frame, plus the current.
        flu = np.array([self.velocity[0], -self.velocity[1], -self.velocity[2]])
        world = pose.body_to_world() @ flu + self.current_at(self.time_s)
        self.pose = VehiclePose(pose.x + h * world[0], pose.y + h * world[1], min(0.0, pose.z + h * world[2]),
                                roll, pitch, yaw)

    def step(self, pwm_us: tuple[int, int, int, int], dt: float) -> VehicleState:
        """Advance and report what the navigation system would (with noise)."""
        if dt > 0:
            self.advance(pwm_us, dt)
        return self.navigation()

    def navigation(self) -> VehicleState:
        n, rng, pose = self.noise, self._rng, self.pose
        return VehicleState(
            roll=pose.roll + rng.normal(0, n.attitude_rad),
            pitch=pose.pitch + rng.normal(0, n.attitude_rad),
            yaw=pose.yaw + rng.normal(0, n.attitude_rad),
            depth=-pose.z + rng.normal(0, n.depth_m),
            roll_rate=rng.normal(0, n.rate_rad_s),
            pitch_rate=float(self.rates[0]) + rng.normal(0, n.rate_rad_s),
            yaw_rate=float(self.rates[1]) + rng.normal(0, n.rate_rad_s),
            docked=self.docked,
        )


def _drag(coefficients: tuple[float, float], speed: float) -> float:
    linear, quadratic = coefficients
    return linear * speed + quadratic * abs(speed) * speed
