from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from auv_dock_guidance.control.mixer import Mixer, MixerConfig, PwmConfig
from auv_dock_guidance.errors import ConfigError

CONFIG = Path(__file__).resolve().parents[2] / "config" / "thrusters.yaml"
PU, SU, PL, SL = range(4)


def test_config_file_is_the_default_allocation():
    assert MixerConfig.from_yaml(CONFIG) == MixerConfig()


def test_pure_surge_drives_all_four_forward_equally():
    cmd = Mixer().mix(0.5, 0.0, 0.0)
    assert cmd.thrust == (0.5, 0.5, 0.5, 0.5)
    assert len(set(cmd.pwm_us)) == 1 and cmd.pwm_us[0] > 1500


def test_yaw_to_starboard_pushes_the_port_side():
    cmd = Mixer().mix(0.0, 0.3, 0.0)
    assert cmd.thrust[PU] > 0 > cmd.thrust[SU] and cmd.thrust[PL] > 0 > cmd.thrust[SL]


def test_nose_up_pushes_the_lower_pair():
    cmd = Mixer().mix(0.0, 0.0, 0.3)
    assert cmd.thrust[PL] > 0 > cmd.thrust[PU]


def test_full_surge_keeps_the_yaw_authority():
    cmd = Mixer().mix(1.0, 0.4, 0.0)
    assert max(abs(t) for t in cmd.thrust) <= 1.0
    differential = (cmd.thrust[PU] - cmd.thrust[SU]) / 2
    assert differential == pytest.approx(0.4)
    assert cmd.thrust[SU] == pytest.approx(0.2)  # surge reduced to 0.6, not the turn


def test_pwm_jumps_the_deadband_and_respects_reversal():
    mixer = Mixer(MixerConfig(pwm=PwmConfig(deadband_us=25, reversed=(True, False, False, False))))
    assert mixer.to_pwm(1, 0.0) == 1500
    assert mixer.to_pwm(1, 0.01) == 1529  # 1525 + 0.01 * 375
    assert mixer.to_pwm(1, 1.0) == 1900 and mixer.to_pwm(1, -1.0) == 1100
    assert mixer.to_pwm(0, 1.0) == 1100  # reversed thruster


@given(st.floats(allow_nan=True, allow_infinity=True), st.floats(allow_nan=True, allow_infinity=True),
       st.floats(allow_nan=True, allow_infinity=True))
def test_any_demand_gives_pulses_inside_the_limits(surge, yaw, pitch):
    cmd = Mixer().mix(surge, yaw, pitch)
    assert all(1100 <= p <= 1900 for p in cmd.pwm_us)


def test_bad_pwm_limits_are_refused():
    with pytest.raises(ConfigError, match="pwm_min_us"):
        PwmConfig(pwm_min_us=1600)


def test_malformed_thruster_file_is_named(tmp_path):
    path = tmp_path / "t.yaml"
    path.write_text("thrusters: [{name: a}]\n")
    with pytest.raises(ConfigError, match=str(path)):
        MixerConfig.from_yaml(path)
