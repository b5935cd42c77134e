"""The guidance state machine around the cascaded controller and the mixer.

States:

* SEARCH: no confirmed marker. Neutral thrust (the main controller keeps the vehicle level).
* TRACK: the marker is confirmed (``confirm_frames`` frames in a row with it; a frame
  without it, reported by ``marker_missed()``, starts the count again); the cascade
  steers towards it at the scheduled speed.
* TERMINAL: close range (below ``terminal_range_m`` in ``terminal_confirm_frames``
  detections in a row: one wild detection far out must not end the approach). The ring
  fills the frame or leaves it, so a lost marker is expected: the last good attitude goal
  is held, turns stay rate limited, and the vehicle keeps going at terminal speed.
  Detections closer than ``blind_range_m`` or jumping more than
  ``terminal_max_bearing_jump_rad`` from the last good one (a partial ring) are not acted on,
  except that down to ``close_fix_range_m`` a ring the frame cuts top and bottom still fixes
  the track's position where it agrees with it: its side arcs give a good bearing, and the
  blind run after it (a current error of 2 cm/s drifts 2-4 cm over the last 1.15 m) is shorter.
  Detections in TERMINAL correct the track's position only, not its current: their errors are
  as large as the motion left, and taken as drift they steered the blind run.
  Lost while still farther than ``blind_range_m`` (where it should be in view) for
  ``terminal_lost_timeout_s``: ABORT.
  No detection at all for ``terminal_blind_timeout_s``: ABORT (the blind run should be
  over by then, whatever the speed).
* TRACK may sidestep (``Plan.sidestep``): back off sideways in reverse, the dock in view,
  when the approach line is out of reach; counted in ``sidesteps``.
* RETRY: the approach path predicted that the entry would miss (too far off the centre
  close in): instead of ramming, back off to a point on the approach line further out
  (in reverse with the nose on the dock, or turned round and blind on the track where
  reversing there would lose the dock from view), face the dock, and TRACK again once it
  is seen. Without a detection for ``retry_blind_timeout_s``: SEARCH. More than
  ``max_retries``: ABORT, unless the last try's predicted miss is within
  ``last_try_tolerance_m`` (clear of the rim, if with less margin): then it goes in.
* DOCKED: the main controller reports the latch, or in TERMINAL the dead-reckoned run
  since the last sighting covers the last range plus a margin (on the approach path: the
  tracked nose, own motion and drift, is that margin past the entrance).
* ABORT: marker lost too long, search timed out, telemetry stale or no camera frame
  while driving (TRACK, TERMINAL), attitude out of limits. Neutral thrust. An ABORT for
  lost telemetry or camera returns to SEARCH once both have been healthy for
  ``recovery_s`` (to RETRY when the track puts the dock closer than ``terminal_range_m``:
  SEARCH would wait for a ring too close to be seen whole); the others wait for
  ``reset()`` (re-arm).

Steering: the paper's bearing homing (nose on the dock), or, with ``velocity_steering``
and/or ``axis_alignment``, the approach path (``approach.py``): the dock tracked in the
level frame with the current estimated from the drift (``tracker.py``), the dock's axis
from the ring normals (``axis.py``), the velocity steered onto the axis and crabbed into
the current, and the pitch bringing the vehicle to the dock's depth ahead (level while
backing off). The dock's depth is a constant: each detection gives it (the dock below, in
the level frame, plus the navigation's depth), and the estimate is the median of the
recent ones weighed by closeness, so one bad ring close in does not move it.

Only TRACK, TERMINAL and RETRY ever command thrust, and only with fresh telemetry and a live
camera (when the caller reports frames with ``frame_processed``). Fresh means neither
older nor newer than the limit: after the clock steps back, every earlier stamp lies in
the future and is not fresh. Detections must move forward in time: a repeated or
out-of-order stamp is refused, with the reason in ``GuidanceOutput.rejected``.

Time is the caller's clock (ROS time, which is wall time and can step). A step forward
makes everything stale (neutral, ABORT). A step back would freeze every timer for as
long as the step, so the remembered times move back with it and the loops restart:
timers measure elapsed time whatever the clock does.

SEARCH can only reach TERMINAL through TRACK. Every transition is returned once, with
its reason, for the caller to log.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from enum import StrEnum

import numpy as np

from auv_dock_guidance.control.approach import ApproachConfig, ApproachPlanner, Plan, Situation, Verdict
from auv_dock_guidance.control.axis import AxisConfig, AxisEstimator
from auv_dock_guidance.control.cascade import Attitude, CascadeConfig, CascadeController, Demands, Target
from auv_dock_guidance.control.mixer import Mixer, MixerConfig, ThrusterCommand
from auv_dock_guidance.control.tracker import DockFix, DockTracker, TrackerConfig, dock_from_camera, level_from_body
from auv_dock_guidance.errors import ConfigError
from auv_dock_guidance.stamps import StampGate


class State(StrEnum):
    SEARCH = "SEARCH"
    TRACK = "TRACK"
    TERMINAL = "TERMINAL"
    RETRY = "RETRY"
    DOCKED = "DOCKED"
    ABORT = "ABORT"


_DOCK_DEPTH_MEMORY = 40  # detections the dock's depth is taken from (2-4 s of frames)
CAMERA_SILENT = "no camera frame"  # how the reason of an ABORT for a silent camera begins


@dataclass(frozen=True)
class GuidanceConfig:
    confirm_frames: int = 3  # detections in a row before TRACK
    terminal_range_m: float = 2.5
    terminal_confirm_frames: int = 2  # detections in a row below terminal_range_m before TERMINAL (one is an outlier)
    track_lost_timeout_s: float = 2.0  # TRACK without a detection this long -> SEARCH
    blind_range_m: float = 1.15  # below this the ring leaves the frame (the paper's lens: a 0.35 m ring at 1.12 m)
    close_fix_range_m: float = 0.75  # down to this a ring the frame cuts fixes the track sideways (>= blind: off)
    terminal_lost_timeout_s: float = 3.0  # lost this long in TERMINAL while farther than blind_range_m -> ABORT
    terminal_blind_timeout_s: float = 12.0  # no detection at all this long in TERMINAL -> ABORT
    search_timeout_s: float = 120.0  # SEARCH this long -> ABORT
    terminal_max_bearing_jump_rad: float = math.radians(4)  # larger jumps between frames in TERMINAL are ignored
    dock_margin_m: float = 0.3  # dead-reckoned run past the last range that counts as docked
    telemetry_timeout_s: float = 0.5
    camera_timeout_s: float = 1.0  # no processed frame this long while driving: ABORT
    recovery_s: float = 2.0  # a camera or telemetry ABORT clears after this long healthy
    detection_max_age_s: float = 0.5  # an older detection is not acted on
    max_roll_rad: float = math.radians(20)
    max_pitch_rad: float = math.radians(40)
    velocity_steering: bool = True  # track the dock in the level frame, estimate the current, crab into it
    axis_alignment: bool = True  # line up with the dock's axis (from the ring normals) before the entry
    max_retries: int = 3  # backing off this many times and still missing: ABORT...
    last_try_tolerance_m: float = 0.18  # ...unless the predicted miss is within this (clear of the rim): go in
    retry_blind_timeout_s: float = 40.0  # RETRY without a detection this long (turned round to get back) -> SEARCH
    faced_unseen_timeout_s: float = 4.0  # RETRY facing where the track puts the dock, not seeing it this long -> SEARCH
    speed_time_constant_s: float = 1.0  # how fast the vehicle's speed through the water follows its thrust
    sideslip_per_turn_s: float = 1.1  # a turning hull slides outwards: sway = this x speed x turn rate (m / damping)
    sideslip_time_constant_s: float = 2.0  # ...reached this slowly ((m + added mass) / sway damping)
    cascade: CascadeConfig = field(default_factory=CascadeConfig)
    mixer: MixerConfig = field(default_factory=MixerConfig)
    approach: ApproachConfig = field(default_factory=ApproachConfig)
    tracker: TrackerConfig = field(default_factory=TrackerConfig)
    axis: AxisConfig = field(default_factory=AxisConfig)

    def __post_init__(self) -> None:
        positive = (
            self.terminal_range_m, self.track_lost_timeout_s, self.terminal_lost_timeout_s, self.search_timeout_s,
            self.terminal_blind_timeout_s, self.retry_blind_timeout_s, self.faced_unseen_timeout_s,
            self.telemetry_timeout_s, self.detection_max_age_s, self.max_roll_rad, self.max_pitch_rad,
            self.blind_range_m, self.close_fix_range_m, self.camera_timeout_s, self.recovery_s,
            self.speed_time_constant_s,
            self.last_try_tolerance_m, self.sideslip_time_constant_s,
        )
        if not all(math.isfinite(v) and v > 0 for v in positive) or min(
                self.confirm_frames, self.terminal_confirm_frames) < 1 or self.dock_margin_m < 0:
            raise ConfigError("guidance timeouts, ranges and limits must be positive numbers, confirm_frames and "
                              "terminal_confirm_frames >= 1")
        if self.max_retries < 0:
            raise ConfigError(f"max_retries {self.max_retries} must be 0 or more")

    @property
    def follows_path(self) -> bool:
        """Steering by the approach path rather than by the bearing alone."""
        return self.velocity_steering or self.axis_alignment


@dataclass(frozen=True)
class Transition:
    time_s: float
    previous: State
    state: State
    reason: str


@dataclass(frozen=True)
class GuidanceOutput:
    state: State
    command: ThrusterCommand
    demands: Demands | None
    transition: Transition | None
    rejected: str | None = None  # why the new detection was refused (bad input), if it was
    plan: Plan | None = None  # the approach path's heading and speed, when steering by it


class Guidance:
    """One control tick at a time: ``update(now, new_target, attitude)``.

    Ticks may come faster than camera frames (the inner loop); ``target`` is None on
    ticks without a new frame, which is not a miss.
    """

    def __init__(self, config: GuidanceConfig = GuidanceConfig()) -> None:
        self.config = config
        self.cascade = CascadeController(config.cascade)
        self.mixer = Mixer(config.mixer)
        self.planner = ApproachPlanner(config.approach)
        self.tracker = DockTracker(_tracker_config(config))
        self.axis = AxisEstimator(config.axis)
        self.clock_steps_back = 0
        self.retries = 0
        self.sidesteps = 0
        self._clock_s: float | None = None  # the newest clock reading seen
        self.reset()

    def reconfigure(self, config: GuidanceConfig) -> None:
        """New limits and gains at run time; the state stays, the loops restart from zero."""
        self.config = config
        self.cascade = CascadeController(config.cascade)
        self.mixer = Mixer(config.mixer)
        self.planner = ApproachPlanner(config.approach)
        self.tracker = DockTracker(_tracker_config(config))
        self.axis = AxisEstimator(config.axis)

    def reset(self) -> None:
        """Back to SEARCH (re-arm after ABORT or DOCKED)."""
        self.state = State.SEARCH
        self.cascade.reset()
        self.tracker = DockTracker(_tracker_config(self.config))
        self.axis = AxisEstimator(self.config.axis)
        self.planner.reset()
        self.retries = 0
        self.sidesteps = 0
        self._sidestepping = False
        self._water_speed = 0.0  # the vehicle's own speed through the water, from its thrust
        self._sway = 0.0  # its sideways speed through the water (starboard +), from its turn rate
        self._surge = 0.0  # the surge share of the last command
        self._since: float | None = None  # time the current state began
        self._streak = 0
        self._close_streak = 0  # detections in a row below the terminal range
        self._last_target: Target | None = None  # the last detection steered by
        self._last_seen_s: float | None = None  # the last detection of any kind
        self._last_frame_s: float | None = None  # the last processed frame (None: not reported)
        self._abort_kind: str | None = None  # "camera" or "telemetry" aborts clear by themselves
        self._healthy_since: float | None = None
        self._run_since_sighting = 0.0
        self._last_update_s: float | None = None
        self._target_gate = StampGate()
        self._dock_depths: list[tuple[float, float]] = []  # the entrance centre's depth by recent detections, range
        self._dock_depth_m: float | None = None  # their weighted median
        self._entry_checked = False  # the entry was predicted since the vehicle came within the commit distance
        self._faced_since: float | None = None  # RETRY: facing the dock by the track since

    def _follow_clock(self, now_s: float) -> None:
        """Move every remembered time back with a backward clock step, so timers keep counting."""
        last, self._clock_s = self._clock_s, now_s
        if last is None or now_s >= last:
            return
        step = now_s - last
        self.clock_steps_back += 1
        for name in ("_since", "_last_seen_s", "_last_frame_s", "_healthy_since", "_last_update_s", "_faced_since"):
            value = getattr(self, name)
            if value is not None:
                setattr(self, name, value + step)
        self._target_gate.reset()
        self.cascade.reset()  # its PIDs would hold their output until the clock caught up
        self.tracker.reset()

    def _maybe_recover(self, now_s: float, attitude: Attitude | None) -> Transition | None:
        """Leave an ABORT caused by lost telemetry or camera once both have been healthy a while."""
        if self._abort_kind is None:
            return None
        healthy = attitude is not None and not self._camera_silent(now_s)
        if not healthy:
            self._healthy_since = None
            return None
        self._healthy_since = self._healthy_since if self._healthy_since is not None else now_s
        if now_s - self._healthy_since < self.config.recovery_s:
            return None
        kind, self._abort_kind, self._healthy_since = self._abort_kind, None, None
        self._since, self._streak = now_s, 0
        self.cascade.reset()
        reason = f"{kind} healthy again for {self.config.recovery_s:.1f} s"
        fix = self.tracker.fix() if self.config.follows_path else None
        close = self._camera_distance_m(fix) if fix is not None else None
        if close is not None and close < self.config.terminal_range_m:
            # SEARCH waits for the ring in view, and this close it is not (it fills the frame or left it):
            # back off along the track until it is.
            self.state = State.RETRY
            return Transition(now_s, State.ABORT, State.RETRY,
                              f"{reason}; the track puts the dock {close:.1f} m ahead, too close to see: back off")
        self.state = State.SEARCH
        return Transition(now_s, State.ABORT, State.SEARCH, reason)

    def _camera_distance_m(self, fix: DockFix) -> float:
        """From the camera to the dock by the track (own motion and drift since the last sighting)."""
        return max(0.0, math.hypot(*fix.position_m) - self.config.tracker.camera_ahead_m)

    def _plausible_in_terminal(self, target: Target) -> bool:
        """Close in, the ring leaves the frame and a partial ring gives a wild bearing: ignore those."""
        c = self.config
        if target.range_m < c.blind_range_m:
            return False
        last = self._last_target
        if last is None:
            return True
        jump = max(abs(target.bearing_yaw_rad - last.bearing_yaw_rad),
                   abs(target.bearing_pitch_rad - last.bearing_pitch_rad))
        return jump <= c.terminal_max_bearing_jump_rad

    def marker_missed(self) -> None:
        """A camera frame came without the marker: confirmation starts again."""
        self._streak = self._close_streak = 0

    def frame_processed(self, now_s: float) -> None:
        """The detector processed a frame (marker or not): the camera is alive."""
        self._follow_clock(now_s)
        self._last_frame_s = now_s

    def _camera_silent(self, now_s: float) -> bool:
        last = self._last_frame_s
        return last is not None and now_s - last > self.config.camera_timeout_s

    @property
    def last_target(self) -> Target | None:
        return self._last_target

    def update(
        self, now_s: float, target: Target | None, attitude: Attitude | None, docked_signal: bool = False
    ) -> GuidanceOutput:
        """Advance to ``now_s`` with the newest detection (None if none arrived) and attitude."""
        c = self.config
        self._follow_clock(now_s)
        dt = 0.0 if self._last_update_s is None else max(0.0, now_s - self._last_update_s)
        self._last_update_s = now_s
        if self._since is None:
            self._since = now_s
        rejected = None
        if target is not None:
            rejected = self._refusal(now_s, target)
            target = None if rejected else target
        if target is not None:
            self._last_seen_s = now_s
            if self._last_frame_s is not None:  # the caller reports frames: a detection is one
                self._last_frame_s = now_s
        close_fix = None
        if target is not None and self.state is State.TERMINAL and not self._plausible_in_terminal(target):
            close_fix = target if c.close_fix_range_m <= target.range_m < c.blind_range_m else None
            target = None  # seen, but a partial ring: hold the last good goal
        if attitude is not None and (
                not attitude.is_valid() or not _fresh(now_s, attitude.stamp_s, c.telemetry_timeout_s)):
            attitude = None
        plan = None
        if c.follows_path and attitude is not None:
            self._own_motion(dt, attitude)
            if close_fix is not None:  # the position only, and only where it agrees with the track
                self.tracker.update(close_fix, attitude, may_restart=False, learn_drift=False)
            if target is not None and not self._observe(target, attitude):
                target = None  # another light far off the track: not acted on
            # The entry is checked with each new detection, and once on crossing the commit distance
            # even without one (the ring may be out of sight just then).
            plan = self._plan(attitude, predict_entry=target is not None or not self._entry_checked,
                              dock_in_view=self._seen_within(now_s, c.track_lost_timeout_s))
            if plan is not None:
                self._entry_checked = plan.along_m < c.approach.commit_m and (
                    self._entry_checked or plan.predicted_miss_m is not None or plan.verdict is Verdict.WOULD_MISS)
            sidestepping = plan is not None and plan.sidestep and self.state is State.TRACK
            self.sidesteps += sidestepping and not self._sidestepping
            self._sidestepping = sidestepping
        before = self.state
        transition = self._next_state(now_s, target, attitude, docked_signal, plan)
        if self.state in (State.ABORT, State.DOCKED) or attitude is None or self._camera_silent(now_s):
            self._surge = 0.0
            return GuidanceOutput(self.state, self.mixer.neutral(), None, transition, rejected)
        if target is not None:
            self._last_target = target
            self._run_since_sighting = 0.0
            self.cascade.on_target(target, attitude)
        if self.state is State.SEARCH:
            # No thrust without a confirmed marker: the main controller keeps the vehicle level.
            self.cascade.reset()
            self._surge = 0.0
            return GuidanceOutput(self.state, self.mixer.neutral(), None, transition, rejected)
        seen = self._last_target.range_m - self._run_since_sighting if self._last_target else None
        if plan is not None:
            if (self.state is State.RETRY) != (before is State.RETRY):
                plan = self._plan(attitude, predict_entry=False,
                                  dock_in_view=self._seen_within(now_s, c.track_lost_timeout_s))
            assert plan is not None  # the tracker has a fix once anything was seen
            self.cascade.steer(plan.yaw_rad, 0.0 if self.state is State.RETRY else plan.pitch_rad)
            speed = plan.speed_mps
        else:
            speed = self.cascade.speed_for_range(seen)
        demands = self.cascade.update(attitude, now_s, speed)
        self._run_since_sighting += max(0.0, speed) * dt
        command = self.mixer.mix(demands.surge, demands.yaw, demands.pitch)
        surge_column = self.mixer.config.allocation
        column = [row[0] for row in surge_column]
        self._surge = sum(t * a for t, a in zip(command.thrust, column, strict=True)) / max(
            sum(a * a for a in column), 1e-9)
        return GuidanceOutput(self.state, command, demands, transition, rejected, plan)

    def _own_motion(self, dt: float, attitude: Attitude) -> None:
        """The vehicle's motion through the water since the last tick (its thrust, heading and turn rate) moves
        the track on. The sideslip of a turn, left out, reads as current: 0.03 m/s in a 3 deg/s turn at
        0.6 m/s, enough to put the blind last metre 5 cm off."""
        c = self.config
        full = c.cascade.full_thrust_speed_mps
        steady = math.copysign(full * math.sqrt(abs(self._surge)), self._surge)
        self._water_speed += (steady - self._water_speed) * min(1.0, dt / c.speed_time_constant_s)
        slide = -c.sideslip_per_turn_s * self._water_speed * attitude.yaw_rate_rad_s
        self._sway += (slide - self._sway) * min(1.0, dt / c.sideslip_time_constant_s)
        run, aside = self._water_speed * dt * math.cos(attitude.pitch_rad), self._sway * dt
        cy, sy = math.cos(attitude.yaw_rad), math.sin(attitude.yaw_rad)
        self.tracker.predict(dt, (run * cy - aside * sy, run * sy + aside * cy))

    def _observe(self, target: Target, attitude: Attitude) -> bool:
        """Correct the track, the dock's depth and its axis with a detection. False for one the tracker
        rejects at a range far off its own: acting on it sent a vehicle 2.5 m out back (a lamp read 36 m
        off). Other rejected ones are acted on: where the track lags a gusty current they are the dock."""
        # In the last metres a ring's errors (a range read 10-25 % off as LEDs leave the frame) are as large as
        # the motion left, and taken as drift they steer the blind run: there the detections fix the position only.
        taken = self.tracker.update(target, attitude, learn_drift=self.state is not State.TERMINAL)
        if not taken and self.tracker.far_off(target, attitude):
            return False
        camera_below = float(level_from_body(attitude)[2, 0]) * self.config.tracker.camera_ahead_m
        seen_below = float(dock_from_camera(target, attitude)[2]) + camera_below
        self._dock_depths = [*self._dock_depths[-(_DOCK_DEPTH_MEMORY - 1):],
                             (attitude.depth_m + seen_below, max(target.range_m, 1.0))]
        self._dock_depth_m = self._weighted_median_depth()
        if self.config.axis_alignment and target.axis_optical is not None:
            fix = self.tracker.fix()
            tracked_range_m = math.hypot(*fix.position_m) if fix is not None else None
            self.axis.observe(target, target.axis_optical, attitude, tracked_range_m)
        return True

    def _weighted_median_depth(self) -> float:
        """Median of the recent detections' dock depths, each weighed by the inverse square of its range
        (the depth error grows with range). Seed 145: one ring at 2.5 m put the dock 19 cm deeper than
        it was; taken as it came, it sent the vehicle in 34 cm low."""
        ordered = sorted(self._dock_depths)
        weights = np.array([1.0 / r**2 for _, r in ordered])
        middle = int(np.searchsorted(np.cumsum(weights), 0.5 * float(np.sum(weights))))
        return ordered[min(middle, len(ordered) - 1)][0]

    def _seen_within(self, now_s: float, limit_s: float) -> bool:
        return self._last_seen_s is not None and now_s - self._last_seen_s <= limit_s

    def _plan(self, attitude: Attitude, predict_entry: bool, dock_in_view: bool) -> Plan | None:
        fix = self.tracker.fix()
        if fix is None:
            return None
        axis = self.axis.estimate() if self.config.axis_alignment else None
        situation = Situation(
            position_m=fix.position_m, current_mps=fix.current_mps, heading_rad=attitude.yaw_rad,
            water_speed_mps=self._water_speed, axis_yaw_rad=axis.yaw_rad if axis is not None else None,
            camera_ahead_m=self.config.tracker.camera_ahead_m,
            nominal_speed_mps=self.cascade.speed_for_range(self._camera_distance_m(fix)),
            axis_known=axis is not None and axis.known, dock_in_view=dock_in_view,
            dock_below_m=None if self._dock_depth_m is None else self._dock_depth_m - attitude.depth_m,
        )
        return self.planner.plan(situation, backing_off=self.state is State.RETRY, predict_entry=predict_entry)

    def _refusal(self, now_s: float, target: Target) -> str | None:
        """Why a new detection must not be acted on, or None."""
        limit = self.config.detection_max_age_s
        if not target.is_valid():
            return f"not a finite position in front of the camera ({target})"
        if not _fresh(now_s, target.stamp_s, limit):
            age = now_s - target.stamp_s
            when = f"{age:.3f} s ago" if age > 0 else f"{-age:.3f} s in the future"
            return f"stamped {when} (limit {limit} s either way)"
        return self._target_gate.admit(target.stamp_s)

    def _last_try_goes_in(self, plan: Plan) -> bool:
        """With no retry left, an entry predicted off the centre but clear of the rim goes ahead: the
        tolerance that sends the vehicle back for a better line is a margin, and an ABORT ends the docking."""
        c = self.config
        tolerance = c.last_try_tolerance_m
        return self.retries >= c.max_retries and plan.predicted_miss_m is not None \
            and abs(plan.predicted_miss_m) <= tolerance and (plan.depth_left_m or 0.0) <= tolerance

    def _next_state(
        self, now_s: float, target: Target | None, attitude: Attitude | None, docked_signal: bool,
        plan: Plan | None = None,
    ) -> Transition | None:
        c = self.config
        previous = self.state
        if target is not None:
            self._streak += 1
            self._close_streak = self._close_streak + 1 if target.range_m < c.terminal_range_m else 0
        lost_for = now_s - self._last_seen_s if self._last_seen_s is not None else math.inf
        if target is not None:
            lost_for = 0.0
        elif lost_for > c.track_lost_timeout_s:
            self._streak = 0
        reason = None
        new_state = previous
        if previous is State.DOCKED:
            return None
        if previous is State.ABORT:
            return self._maybe_recover(now_s, attitude)
        driving = (State.TRACK, State.TERMINAL, State.RETRY)
        would_miss = plan is not None and plan.verdict is Verdict.WOULD_MISS and lost_for <= c.track_lost_timeout_s \
            and not self._last_try_goes_in(plan)
        if attitude is None:
            if previous in driving:
                new_state, reason = State.ABORT, "telemetry from the main controller is stale or invalid"
                self._abort_kind = "telemetry"
            else:
                self._streak = 0  # no tracking without navigation
        elif self._camera_silent(now_s) and previous in driving:
            new_state = State.ABORT
            reason = f"{CAMERA_SILENT} for {now_s - (self._last_frame_s or now_s):.1f} s"
            self._abort_kind = "camera"
        elif abs(attitude.roll_rad) > c.max_roll_rad or abs(attitude.pitch_rad) > c.max_pitch_rad:
            new_state = State.ABORT
            reason = f"attitude out of limits (roll {math.degrees(attitude.roll_rad):.0f} deg, " \
                     f"pitch {math.degrees(attitude.pitch_rad):.0f} deg)"
        elif docked_signal and previous in driving:
            new_state, reason = State.DOCKED, "main controller reports the dock latch closed"
        elif previous is State.SEARCH:
            if self._streak >= c.confirm_frames:
                new_state, reason = State.TRACK, f"marker confirmed in {self._streak} frames"
            elif now_s - (self._since or now_s) > c.search_timeout_s:
                new_state, reason = State.ABORT, f"no marker for {c.search_timeout_s:.0f} s"
        elif would_miss and previous in (State.TRACK, State.TERMINAL):
            assert plan is not None  # would_miss needs one
            miss = "not closing" if plan.predicted_miss_m is None else f"{plan.predicted_miss_m:+.2f} m off the centre"
            if plan.depth_left_m:
                miss += f", {plan.depth_left_m:.2f} m off the dock's depth"
            if self.retries >= c.max_retries:
                new_state, reason = State.ABORT, f"entry would miss ({miss}) after {self.retries} retries"
            else:
                self.retries += 1
                new_state = State.RETRY
                reason = f"entry would miss ({miss}) {plan.along_m:.1f} m out: back off, retry {self.retries}"
        elif previous is State.RETRY:
            facing = plan is not None and plan.verdict is Verdict.BACKED_OFF
            self._faced_since = (self._faced_since if self._faced_since is not None else now_s) if facing else None
            faced_for = now_s - self._faced_since if self._faced_since is not None else 0.0
            if lost_for > c.retry_blind_timeout_s:
                new_state, reason = State.SEARCH, f"marker lost for {lost_for:.1f} s while backing off"
            elif min(faced_for, lost_for) > c.faced_unseen_timeout_s:
                new_state, reason = State.SEARCH, (f"facing where the track puts the dock for {faced_for:.1f} s "
                                                   "without seeing it: the dead reckoning drifted")
            elif plan is not None and plan.verdict is Verdict.BACKED_OFF and lost_for <= c.track_lost_timeout_s:
                new_state, reason = State.TRACK, f"backed off to {plan.along_m:.1f} m: approach again"
        elif previous is State.TRACK:
            if target is not None and self._close_streak >= c.terminal_confirm_frames:
                new_state, reason = State.TERMINAL, (f"range {target.range_m:.2f} m below {c.terminal_range_m} m "
                                                     f"in {self._close_streak} frames")
            elif lost_for > c.track_lost_timeout_s:
                new_state, reason = State.SEARCH, f"marker lost for {lost_for:.1f} s"
        elif previous is State.TERMINAL:
            last_range = self._last_target.range_m if self._last_target else 0.0
            if target is None and plan is not None and plan.along_m <= -c.dock_margin_m:
                new_state = State.DOCKED  # the tracked nose (own motion and drift since the last sighting)
                reason = f"nose {-plan.along_m:.2f} m past the entrance by the track since the last sighting"
            elif target is None and plan is None and self._run_since_sighting >= last_range + c.dock_margin_m:
                new_state = State.DOCKED
                reason = f"ran {self._run_since_sighting:.2f} m past the last sighting at {last_range:.2f} m"
            elif lost_for > c.terminal_lost_timeout_s and last_range - self._run_since_sighting > c.blind_range_m:
                new_state = State.ABORT
                reason = (f"marker lost for {lost_for:.1f} s about {last_range - self._run_since_sighting:.2f} m "
                          "out, where it should be in view")
            elif lost_for > c.terminal_blind_timeout_s:
                new_state = State.ABORT
                reason = f"no detection for {lost_for:.1f} s and still not docked"
        if new_state is previous or reason is None:
            return None
        self.state = new_state
        self._since = now_s
        self._faced_since = None
        if new_state is State.SEARCH:
            self._streak = 0
        return Transition(now_s, previous, new_state, reason)


def _tracker_config(config: GuidanceConfig) -> TrackerConfig:
    """Without velocity steering the track follows each detection and estimates no drift."""
    if config.velocity_steering:
        return config.tracker
    return replace(config.tracker, estimate_current=False)


def _fresh(now_s: float, stamp_s: float, limit_s: float) -> bool:
    """Neither older nor newer than the limit: a stamp from the future is from before a clock step."""
    return abs(now_s - stamp_s) <= limit_s
