"""What guidance does when its inputs fail, and properties that must hold whatever they do."""

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from auv_dock_guidance.control.cascade import Attitude, CascadeConfig, Target
from auv_dock_guidance.control.guidance import Guidance, GuidanceConfig, State

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


def test_a_camera_outage_close_to_the_dock_recovers_by_backing_off_not_by_waiting():
    """1.6 m out the ring fills the frame: SEARCH (no thrust until the ring is confirmed) would wait for a
    sighting that cannot come while the current carries the vehicle about. It backs off until it sees."""
    g = Guidance()
    t = 0.0
    while g.state is not State.TERMINAL:
        g.frame_processed(t)
        g.update(t, Target(t, 1.8, 0.02, 0.0), Attitude(t, 0, 0, 0))
        t += 0.05
        assert t < 3.0
    for _ in range(30):  # telemetry, no frames
        g.update(t, None, Attitude(t, 0, 0, 0))
        t += 0.05
    assert g.state is State.ABORT
    outs = []
    for _ in range(60):  # frames again, the ring out of view
        g.frame_processed(t)
        outs.append(g.update(t, None, Attitude(t, 0, 0, 0)))
        t += 0.05
    recovery = next(o.transition for o in outs if o.transition)
    assert recovery.state is State.RETRY and "back off" in recovery.reason
    assert outs[-1].state is State.RETRY and outs[-1].demands.speed_setpoint_mps < 0  # in reverse


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


def test_clock_jumping_forward_makes_everything_stale():
    g = Guidance()
    t = drive_to_track(g)
    ahead = g.update(t + 3600.0, None, Attitude(t, 0, 0, 0))
    assert ahead.command.pwm_us == NEUTRAL and ahead.state is State.ABORT


def test_after_the_clock_steps_back_a_lost_marker_still_ends_tracking_in_time():
    g = Guidance()
    t = drive_to_track(g) - 100.0  # NTP steps the wall clock back
    outs = []
    for _ in range(int(g.config.track_lost_timeout_s / 0.05) + 4):  # frames and telemetry, no marker
        g.frame_processed(t)
        outs.append(g.update(t, None, Attitude(t, 0, 0, 0)))
        t += 0.05
    assert g.clock_steps_back == 1
    assert outs[-1].state is State.SEARCH and outs[-1].command.pwm_us == NEUTRAL
    assert "marker lost" in next(o.transition.reason for o in outs if o.transition)


def test_after_the_clock_steps_back_a_silent_camera_still_aborts_in_time():
    g = Guidance()
    t = drive_to_track(g) - 100.0
    driving = 0
    for _ in range(60):  # telemetry, no frames
        out = g.update(t, None, Attitude(t, 0, 0, 0))
        driving += out.command.pwm_us != NEUTRAL
        t += 0.05
    assert out.state is State.ABORT
    assert driving * 0.05 <= g.config.camera_timeout_s + 0.05


def test_telemetry_from_before_a_backward_clock_step_is_not_fresh():
    g = Guidance()
    t = drive_to_track(g)
    last_attitude = Attitude(t, 0, 0, 0)  # the navigation falls silent as the clock steps back
    out = g.update(t - 100.0, Target(t - 100.0, 8.0, 0.5, 0.2), last_attitude)
    assert out.state is State.ABORT and out.command.pwm_us == NEUTRAL
    assert "telemetry" in out.transition.reason


def test_repeated_out_of_order_and_future_detections_are_refused_and_counted():
    g = Guidance()
    t = drive_to_track(g)
    attitude = Attitude(t, 0, 0, 0)
    assert g.update(t, Target(t, 8.0, 0.5, 0.2), attitude).rejected is None
    assert g.update(t, Target(t, 8.0, 0.5, 0.2), attitude).rejected == "repeated stamp"
    assert "older than the previous" in g.update(t, Target(t - 0.3, 8.0, 0.5, 0.2), attitude).rejected
    assert "5.000 s in the future" in g.update(t, Target(t + 5.0, 8.0, 0.5, 0.2), attitude).rejected
    assert "finite" in g.update(t, Target(t, math.nan, 0.5, 0.2), attitude).rejected
    assert g.update(t + 0.05, Target(t + 0.05, 8.0, 0.5, 0.2), attitude).rejected is None  # the stream goes on


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


def test_a_blind_terminal_run_ends_even_when_it_never_covers_the_distance():
    # The paper's bearing homing, creeping ever slower (the approach path would see the drift and speed up).
    g = Guidance(GuidanceConfig(cascade=CascadeConfig(terminal_speed_mps=0.0), velocity_steering=False,
                                axis_alignment=False))
    t = drive_to_track(g)
    for _ in range(3):
        g.frame_processed(t)
        g.update(t, Target(t, 1.2, 0.0, 0.0), Attitude(t, 0, 0, 0))
        t += 0.05
    assert g.state is State.TERMINAL
    while g.state is State.TERMINAL and t < 60.0:  # the ring has left the frame
        g.frame_processed(t)
        out = g.update(t, None, Attitude(t, 0, 0, 0))
        t += 0.05
    assert out.state is State.ABORT and out.command.pwm_us == NEUTRAL
    assert "no detection for 12" in out.transition.reason


clock_steps = st.tuples(
    st.floats(0.0, 0.3),  # normal time step
    st.sampled_from(["tick"] * 8 + ["back", "ahead"]),  # now and then the wall clock steps
    st.floats(0.01, 300.0),  # by this much
)
detections = st.one_of(
    st.none(),
    st.tuples(st.floats(0.3, 30.0), st.floats(-5, 5), st.floats(-5, 5),
              st.floats(-1.0, 1.5),  # stamp age: future, fresh or stale
              st.booleans()),  # repeat the previous stamp
)
events = st.lists(
    st.tuples(clock_steps, detections,
              st.one_of(st.just(0.02), st.floats(-1.0, 1.5)),  # telemetry age (negative: from the future)
              st.booleans(),  # frame processed
              st.floats(-1.0, 1.0)),  # pitch
    min_size=1, max_size=120,
)


@settings(max_examples=1000, deadline=None)
@given(events)
def test_safety_invariants_hold_for_any_sequence_of_inputs(sequence):
    g = Guidance()
    c = g.config
    t = elapsed = 0.0  # elapsed: the time that really passed (a clock step back passes none)
    fresh_detection_at = -math.inf
    stamp = None
    previous = g.state
    for (step, clock, jump), detection, telemetry_age, frame, pitch in sequence:
        t += step if clock == "tick" else jump if clock == "ahead" else -jump
        elapsed += step if clock == "tick" else jump if clock == "ahead" else 0.0
        if frame:
            g.frame_processed(t)
        target = None
        if detection is not None:
            range_m, x, y, age, repeat = detection
            stamp = stamp if repeat and stamp is not None else t - age
            target = Target(stamp, range_m, x, y)
            if abs(t - stamp) <= c.detection_max_age_s:
                fresh_detection_at = elapsed
        out = g.update(t, target, Attitude(t - telemetry_age, 0.0, pitch, 0.0))
        assert all(1100 <= p <= 1900 for p in out.command.pwm_us)
        if out.command.pwm_us != NEUTRAL:
            assert out.state in (State.TRACK, State.TERMINAL, State.RETRY)  # a confirmed marker
            assert abs(telemetry_age) <= c.telemetry_timeout_s  # fresh telemetry
            hold = c.terminal_blind_timeout_s if out.state is State.TERMINAL else c.track_lost_timeout_s
            assert elapsed - fresh_detection_at <= hold + 1e-9  # a fresh detection, recently
        assert not (previous is State.SEARCH and out.state is State.TERMINAL)
        previous = out.state
