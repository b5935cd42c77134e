"""The cascade's inner loop on the simulated hull."""

import math

from auv_dock_guidance.control.cascade import Attitude, CascadeController
from auv_dock_guidance.control.mixer import Mixer
from auv_dock_guidance.sim.vehicle import AuvDynamics
from auv_dock_guidance.sim.world import VehiclePose


def _fly(cascade: CascadeController, auv: AuvDynamics, pitch_goal_rad: float, start_s: float, seconds: float,
         speed_mps: float = 0.7, dt: float = 0.02) -> float:
    mixer = Mixer()
    t = start_s
    cascade.steer(0.0, pitch_goal_rad)
    while t < start_s + seconds:
        p = auv.pose
        demands = cascade.update(Attitude(t, p.roll, p.pitch, p.yaw, -p.z, float(auv.rates[1])), t, speed_mps)
        auv.advance(mixer.mix(demands.surge, demands.yaw, demands.pitch).pwm_us, dt)
        t += dt
    return t


def test_after_a_long_climb_the_pitch_follows_a_small_nose_down_goal_within_seconds():
    """The integrator holds a climb against the righting moment; when the goal turns to a gentle descent
    (the last metres to the dock's depth) that trim must be gone within ten seconds. Trimmed slowly, it held
    the nose 2-3 deg above a -1.5 deg goal for the whole final approach: 3-4 cm high at the entrance."""
    cascade = CascadeController()
    auv = AuvDynamics(VehiclePose(0.0, 0.0, -5.0))
    t = _fly(cascade, auv, math.radians(8.0), 0.0, 20.0)
    t = _fly(cascade, auv, math.radians(-1.5), t, 10.0)
    assert abs(math.degrees(auv.pose.pitch) + 1.5) < 0.75
