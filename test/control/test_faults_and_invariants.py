"""What guidance does when its inputs fail, and properties that must hold whatever they do."""

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from auv_dock_guidance.control.cascade import Attitude, Target
from auv_dock_guidance.control.guidance import Guidance, State

NEUTRAL = (1500, 1500, 1500, 1500)


def drive_to_track(g: Guidance, until: float = 1.0, dt: float = 0.05) -> float:
    t = 0.0
    while t < until:
        g.frame_processed(t)
        g.update(t, Target(t, 8.0, 0.5, 0.2), Attitude(t, 0, 0, 0))
        t += dt
    assert g.state is State.TRACK
    return t


def test_camera_silence_while_tracking_aborts_then_recovers_when_frames_return():
    g = Guidance()
    t = drive_to_track(g)
    outs = []
    for _ in range(40):  # 2 s of telemetry but no frames
        outs.append(g.update(t, None, Attitude(t, 0, 0, 0)))
        t += 0.05
    aborted = [o for o in outs if o.transition and o.transition.state is State.ABORT]
    assert aborted and "camera" in aborted[0].transition.reason
    assert outs[-1].command.pwm_us == NEUTRAL
    # first neutral came within the camera timeout (+ one tick) of the last frame
    first_neutral = next(i for i, o in enumerate(outs) if o.command.pwm_us == NEUTRAL)
    assert first_neutral * 0.05 <= g.config.camera_timeout_s + 0.05
    recovered = []
    for _ in range(60):  # frames again
        g.frame_processed(t)
        out = g.update(t, None, Attitude(t, 0, 0, 0))
        recovered += [out.transition] if out.transition else []
        t += 0.05
    assert g.state is State.SEARCH
    assert "camera healthy again" in recovered[-1].reason


def test_telemetry_loss_aborts_and_recovers():
    g = Guidance()
    t = drive_to_track(g)
    out = g.update(t + 1.0, Target(t + 1.0, 8.0, 0.0, 0.0), Attitude(t, 0, 0, 0))
    assert out.state is State.ABORT and out.command.pwm_us == NEUTRAL
    t += 1.0
    for _ in range(60):
        g.frame_processed(t)
        g.update(t, None, Attitude(t, 0, 0, 0))
        t += 0.05
    assert g.state is State.SEARCH


def test_clock_jumping_back_or_forward_never_commands_thrust_on_stale_data():
    g = Guidance()
    t = drive_to_track(g)
    back = g.update(t - 100.0, None, Attitude(t, 0, 0, 0))  # clock jumped back
    assert all(1100 <= p <= 1900 for p in back.command.pwm_us)
    ahead = g.update(t + 3600.0, None, Attitude(t, 0, 0, 0))  # and far ahead: everything is stale
    assert ahead.command.pwm_us == NEUTRAL and ahead.state is State.ABORT


def test_attitude_limit_abort_needs_a_re_arm():
    g = Guidance()
    t = drive_to_track(g)
    g.update(t, None, Attitude(t, math.radians(35), 0, 0))
    for i in range(100):
        g.frame_processed(t + i * 0.05)
        g.update(t + i * 0.05, None, Attitude(t + i * 0.05, 0, 0, 0))
    assert g.state is State.ABORT
    g.reset()
    assert g.state is State.SEARCH


events = st.lists(
    st.tuples(
        st.floats(0.0, 0.3),  # time step
        st.one_of(st.none(), st.tuples(st.floats(0.3, 30.0), st.floats(-5, 5), st.floats(-5, 5))),  # detection
        st.floats(0.0, 1.5),  # telemetry age
        st.booleans(),  # frame processed
        st.floats(-1.0, 1.0),  # pitch
    ),
    min_size=1, max_size=120,
)


@settings(max_examples=150, deadline=None)
@given(events)
def test_safety_invariants_hold_for_any_sequence_of_inputs(sequence):
    g = Guidance()
    t = 0.0
    previous = g.state
    for step, detection, telemetry_age, frame, pitch in sequence:
        t += step
        if frame:
            g.frame_processed(t)
        target = Target(t, detection[0], detection[1], detection[2]) if detection else None
        out = g.update(t, target, Attitude(t - telemetry_age, 0.0, pitch, 0.0))
        assert all(1100 <= p <= 1900 for p in out.command.pwm_us)
        if out.command.pwm_us != NEUTRAL:
            assert telemetry_age <= g.config.telemetry_timeout_s  # fresh telemetry
            assert out.state in (State.TRACK, State.TERMINAL)  # a confirmed marker
        assert not (previous is State.SEARCH and out.state is State.TERMINAL)
        previous = out.state
