"""Open-water approaches in the closed loop with the real renderer, detector, guidance and vehicle.

The hard cases of issue 17 with the default guidance (approach path, tracker and axis):
a strong cross current and a start 40 deg off the dock's axis. Seeded: the seed draws the
dock's look (a lit LED strip round a funnel for these seeds), the water and the gusts.
Asserted on the outcome, not on time.
"""

from auv_dock_guidance.sim.closed_loop import EpisodeConfig, OpenWaterStart, run_episode


def test_a_strong_cross_current_docks_with_the_defaults():
    start = OpenWaterStart(range_m=20.0, off_axis_deg=10.0, heading_off_deg=15.0, current_across_mps=0.2,
                           current_along_mps=0.05)
    result = run_episode(EpisodeConfig(scenario="open-water", start=start), seed=1)
    assert result.cross_current_mps > 0.19
    assert result.success, (result.reason, result.entry_lateral_error_m, result.entry_heading_error_deg)
    # 12 cm is the margin checked from 3 m out; the gusts of the blind last metre add a few (13 cm here).
    assert result.entry_lateral_error_m < 0.15 and result.entry_heading_error_deg < 12.0


def test_forty_degrees_off_the_axis_docks_with_the_defaults():
    start = OpenWaterStart(range_m=18.0, off_axis_deg=-40.0, heading_off_deg=-20.0, current_along_mps=0.05,
                           current_across_mps=-0.05)
    result = run_episode(EpisodeConfig(scenario="open-water", start=start), seed=3)
    assert abs(result.start_off_axis_deg) > 39.0
    assert result.success, (result.reason, result.entry_lateral_error_m, result.entry_heading_error_deg)
    assert result.entry_lateral_error_m < 0.12 and result.entry_heading_error_deg < 12.0


def test_a_start_well_below_the_dock_with_the_current_setting_in_climbs_to_its_depth_and_docks():
    """11 m out, 1.7 m below, a current setting towards the dock: pointing the nose at the dock climbed
    too slowly and arrived 0.45 m low and 20 deg nose up."""
    start = OpenWaterStart(range_m=11.0, off_axis_deg=3.0, heading_off_deg=5.0, depth_off_m=-1.7,
                           current_along_mps=0.25)
    result = run_episode(EpisodeConfig(scenario="open-water", start=start), seed=70)
    assert result.success, (result.reason, result.entry_lateral_error_m, result.entry_heading_error_deg)
    assert result.entry_lateral_error_m < 0.12 and result.entry_heading_error_deg < 12.0
