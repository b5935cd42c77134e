import math

import pytest

from auv_dock_guidance.sim.closed_loop import EpisodeConfig, entry_outcome, run_episode
from auv_dock_guidance.sim.monte_carlo import summarize, wilson_interval
from auv_dock_guidance.sim.vehicle import AuvDynamics
from auv_dock_guidance.sim.world import PoolWorld, VehiclePose

FULL, NEUTRAL = (1900, 1900, 1900, 1900), (1500, 1500, 1500, 1500)


def test_full_thrust_settles_near_one_metre_per_second():
    auv = AuvDynamics(VehiclePose(0, 0, -2))
    auv.advance(FULL, 30.0)
    assert 0.8 < auv.speed_mps < 1.2
    assert auv.pose.x > 15


def test_port_thrust_turns_to_starboard_and_lower_thrust_lifts_the_nose():
    turn = AuvDynamics(VehiclePose(0, 0, -2))
    turn.advance((1700, 1300, 1700, 1300), 2.0)
    assert turn.pose.yaw > math.radians(5)
    lift = AuvDynamics(VehiclePose(0, 0, -2))
    lift.advance((1300, 1300, 1700, 1700), 2.0)
    assert lift.pose.pitch > math.radians(3)


def test_pitch_returns_to_level_without_thrust():
    auv = AuvDynamics(VehiclePose(0, 0, -2, pitch=math.radians(20)))
    auv.advance(NEUTRAL, 20.0)
    assert abs(auv.pose.pitch) < math.radians(2)


def test_dock_seen_from_the_side_appears_on_the_other_side():
    world = PoolWorld()
    spec = world.scene_for(VehiclePose(18, 1.0, -1.5))
    x, y, z = spec.marker_center_m
    assert x > 0 and y > 0  # dock to the right and below
    assert z == pytest.approx(28 - 18 - world.camera_offset_m)


def test_entry_inside_the_entrance_and_straight_docks():
    world = PoolWorld()
    nose_on_axis = VehiclePose(world.dock_x_m - world.camera_offset_m, 0.05, -2.0, yaw=math.radians(5))
    assert entry_outcome(world, nose_on_axis)[0] == "docked"
    assert entry_outcome(world, VehiclePose(27.1, 0.3, -2.0))[0] == "missed"
    yaw = math.radians(25)  # nose on the centre, hull at 25 deg to the axis
    angled = VehiclePose(28 - 0.9 * math.cos(yaw), 0.9 * math.sin(yaw), -2.0, yaw=yaw)
    assert entry_outcome(world, angled)[0] == "bad_heading"


def test_wilson_interval_is_sane_at_the_extremes():
    low, high = wilson_interval(20, 20)
    assert high == 1.0 and 0.8 < low < 0.9
    assert wilson_interval(0, 10)[0] == 0.0


def test_a_simulated_episode_docks_with_the_real_detector_in_the_loop():
    result = run_episode(EpisodeConfig(scenario="reflection"), seed=3)
    assert result.success, (result.reason, result.states)
    assert result.entry_lateral_error_m < 0.23
    assert 15 < result.time_s < 60
    report = summarize([result])
    assert report["success_rate"] == 1.0 and report["failures"] == {}
