import pytest

pytest.importorskip("pymavlink")

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from auv_dock_guidance.link.mavlink import MavlinkCodec


def test_rc_override_carries_the_demands_on_ardusub_channels():
    frame = MavlinkCodec().rc_override(surge=0.5, yaw=-0.25, pitch=1.0)
    (msg,) = mavlink.MAVLink(None).parse_buffer(frame)
    assert msg.get_type() == "RC_CHANNELS_OVERRIDE"
    assert msg.chan5_raw == 1700 and msg.chan4_raw == 1400 and msg.chan1_raw == 1900
    assert msg.chan3_raw == 65535  # heave left alone


def test_non_finite_demands_become_neutral():
    (msg,) = mavlink.MAVLink(None).parse_buffer(MavlinkCodec().rc_override(float("nan"), float("inf"), 0.0))
    assert msg.chan5_raw == 1500 and msg.chan4_raw == 1500


def test_attitude_and_depth_are_read_through_line_noise():
    # pymavlink resynchronizes on the next start byte (0xFD/0xFE); noise without one is skipped.
    autopilot = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    data = b"\x00\x11 line noise" + autopilot.attitude_encode(1000, 0.1, -0.2, 1.5, 0.0, 0.0, 0.3).pack(autopilot)
    data += autopilot.vfr_hud_encode(0.4, 0.4, 90, 50, -2.5, 0.0).pack(autopilot)
    state = MavlinkCodec().feed(data)
    assert state.yaw == pytest.approx(1.5) and state.pitch == pytest.approx(-0.2)
    assert state.depth == pytest.approx(2.5) and state.attitude_updates == 1
