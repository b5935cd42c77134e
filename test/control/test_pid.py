import math

import pytest

from auv_dock_guidance.control.cascade import Attitude, CascadeController
from auv_dock_guidance.control.pid import Pid, PidGains, wrap_angle
from auv_dock_guidance.errors import ConfigError


def _simulate(pid: Pid, setpoint: float, seconds: float, dt: float = 0.02, plant_gain: float = 1.0):
    """First-order plant x' = gain * u - x."""
    x, t, history = 0.0, 0.0, []
    while t < seconds:
        u = pid.update(setpoint, x, t)
        x += dt * (plant_gain * u - x)
        t += dt
        history.append((t, x, u))
    return history


def test_step_response_settles_without_steady_state_error():
    pid = Pid(PidGains(kp=2.0, ki=1.0, kd=0.05, output_limit=5.0))
    history = _simulate(pid, 1.0, 15.0)
    assert history[-1][1] == pytest.approx(1.0, abs=0.01)
    assert max(x for _, x, _ in history) < 1.3  # no wild overshoot


def test_output_never_exceeds_its_limit():
    pid = Pid(PidGains(kp=50.0, ki=10.0, kd=1.0, output_limit=0.6))
    assert all(abs(u) <= 0.6 for _, _, u in _simulate(pid, 10.0, 5.0))


def test_back_calculation_stops_windup():
    gains = PidGains(kp=1.0, ki=1.0, output_limit=0.5, tracking_time_s=0.5)
    pid = Pid(gains)
    for i in range(5000):  # 100 s saturated against an unreachable setpoint
        pid.update(10.0, 0.0, i * 0.02)
    t = 100.0
    for _ in range(50):  # error flips sign: output must follow within a second
        t += 0.02
        out = pid.update(-1.0, 0.0, t)
    assert out < 0


def test_a_long_turn_round_leaves_the_full_yaw_authority_for_the_turn_back():
    """Seed 73: turning round for 20 s the heading lagged its rate-limited setpoint by 15 deg without
    saturating, and the integral of that lag took half the yaw authority from the turn back that followed."""
    cascade = CascadeController()
    yaw, t = 0.0, 0.0
    for _ in range(1000):  # the goal stays far ahead; the vehicle follows the setpoint 15 deg behind
        cascade.steer(yaw + math.radians(170), 0.0)
        cascade.update(Attitude(t, 0.0, 0.0, wrap_angle(yaw), 8.0), t, 0.0)
        yaw = cascade.setpoint[0] - math.radians(15)
        t += 0.02
    cascade.steer(yaw - math.radians(24), 0.0)  # the approach asks for 24 deg the other way
    for _ in range(150):  # the setpoint slews back to the new goal; the vehicle has not turned yet
        demands = cascade.update(Attitude(t, 0.0, 0.0, wrap_angle(yaw), 8.0), t, 0.0)
        t += 0.02
    assert demands.yaw < -0.45  # nearly all of the 0.6 the inner loop may ask for


def test_a_pitch_the_vehicle_cannot_hold_does_not_wind_up_the_pitch_integrator():
    """A steep climb: the righting moment keeps the nose 6 deg short of the goal for 10 s. Levelling at the
    dock's depth afterwards must not find the pitch integrator still pushing the nose up."""
    cascade, t = CascadeController(), 0.0
    for _ in range(500):
        cascade.steer(0.0, math.radians(21))
        cascade.update(Attitude(t, 0.0, math.radians(15), 0.0, 8.0), t, 0.5)
        t += 0.02
    cascade.steer(0.0, 0.0)
    for _ in range(100):  # the setpoint has slewed back to level, and so has the vehicle
        demands = cascade.update(Attitude(t, 0.0, 0.0, 0.0, 8.0), t, 0.5)
        t += 0.02
    assert abs(demands.pitch) < 0.02


def test_repeated_or_backwards_timestamps_change_nothing():
    pid = Pid(PidGains(kp=1.0, ki=1.0, kd=1.0, output_limit=10.0))
    pid.update(1.0, 0.0, 0.0)
    first = pid.update(1.0, 0.2, 0.1)
    assert pid.update(1.0, 0.9, 0.1) == first  # dt = 0
    assert pid.update(1.0, 0.9, 0.05) == first  # clock went back
    assert pid.update(1.0, math.nan, 0.2) == first


def test_derivative_acts_on_measurement_so_setpoint_steps_do_not_kick():
    pid = Pid(PidGains(kp=1.0, kd=5.0, output_limit=100.0, derivative_tau_s=0.0))
    pid.update(0.0, 0.0, 0.0)
    out = pid.update(1.0, 0.0, 0.01)  # setpoint jumps, measurement still
    assert out == pytest.approx(1.0)


def test_reset_forgets_the_integral():
    pid = Pid(PidGains(kp=0.0, ki=1.0, output_limit=10.0))
    for i in range(100):
        pid.update(1.0, 0.0, i * 0.1)
    pid.reset()
    assert pid.update(1.0, 0.0, 20.0) == 0.0


def test_angle_error_is_wrapped():
    assert wrap_angle(math.radians(350)) == pytest.approx(math.radians(-10))
    pid = Pid(PidGains(kp=1.0, output_limit=10.0))
    out = pid.update(math.radians(170), math.radians(-170), 0.0,
                     error=wrap_angle(math.radians(170) - math.radians(-170)))
    assert out == pytest.approx(math.radians(-20))


def test_negative_gains_are_refused():
    with pytest.raises(ConfigError, match="negative"):
        PidGains(kp=-1.0)
