"""The approach path: which heading and speed bring the nose into the entrance along the dock's axis.

Geometry in the level navigation frame, from the tracked position relative to the dock,
the current estimate and the dock's axis (or, while the axis is not known, the line of
sight: pure bearing homing, but on the velocity). The vehicle follows a line through the
entrance centre with a line-of-sight law (aim at a point ``lookahead`` ahead on the
line); the heading is what makes the velocity over ground point along that course in the
current (crab into it), and the speed through the water is raised until the crab fits
the heading limit for the entry.

The crab plans for the entry limit less a reserve (``line_margin_deg``) that answers gusts
and late corrections. When the cross current is stronger than the fastest vehicle can crab
into within that, the heading is held there and the line itself is turned until the
resulting drift carries the nose into the centre: the vehicle enters within the heading
limit on a line a little off the axis, as an aircraft lands in a crosswind. The camera
must keep the dock in view, so the heading stays within ``fov_margin_deg`` of the dock's
bearing until the ring is too close to matter.

Keeping the dock in view limits how fast the vehicle can move round it: its ground
velocity may lead the line of sight by at most the view margin less the crab, so the
angle off the approach line seen from the dock shrinks by at most tan(lead) per e-fold
of range. A vehicle too far round (far off the axis close in, or downstream of a line
turned by a strong cross current) cannot reach the line in view before it must be on it
(``settle_m``). It then sidesteps: backs off in reverse with the nose on the dock, its
velocity led towards the line's side, until the line is in reach, and approaches again
(the dock never leaves the view).

The vertical is a line too: the dock's axis is level, so the pitch brings the vehicle to the
dock's depth ahead with the same line-of-sight law, and the speed through the water rises
when a current setting towards the dock leaves too little time for the climb; the entry
check also counts the depth error that would be left at the entrance.

Backing off after a predicted miss goes in reverse with the nose on the dock to a point
on the line further out. Where that point cannot be reached so (reversing there would
turn the dock out of view: far round the dock or in a strong cross current, where the
reverse pass ended metres off the line and the next approach failed the same way), the
vehicle turns round and drives to it blind on the track (own motion and the current
estimate), then turns to face the dock again. The first sightings then correct the track:
when they put the nose more than ``refound_gap_m`` off the line (the dead reckoning drifted),
it goes to the point again (at most ``max_back_off_legs`` legs), since an approach begun
metres beside the line misses the same way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from enum import StrEnum

from auv_dock_guidance.control.pid import wrap_angle
from auv_dock_guidance.errors import ConfigError


class _BackOff(StrEnum):
    REVERSE = "reverse"  # nose on the dock
    BLIND = "blind"  # turned round, on the track
    FACE = "face"  # at the back-off point, turning to the dock


class Verdict(StrEnum):
    GO = "go"
    WOULD_MISS = "would_miss"
    BACKED_OFF = "backed_off"


@dataclass(frozen=True)
class ApproachConfig:
    max_speed_mps: float = 0.9  # through the water; full thrust gives 1.0 but turning needs headroom
    min_speed_mps: float = 0.15
    entry_speed_mps: float = 0.7  # over ground for the last metres at least: a short blind run drifts little
    entry_crab_deg: float = 8.0  # heading limit against the dock's axis for the last metres (docked: within 15)
    far_crab_deg: float = 30.0  # largest crab far out (the dock must stay in view)
    crab_near_m: float = 6.0  # along the axis: the entry limit applies below this (settled before the commit)...
    crab_far_m: float = 12.0  # ...and the far limit beyond this
    heading_limit_growth_deg_per_m: float = 20.0  # the heading clamp against the axis widens with distance...
    heading_limit_from_m: float = 1.5  # ...beyond this far along the axis (closer it is the entry limit)
    fov_margin_deg: float = 26.0  # the dock stays within this of the nose (the lens sees about 34 deg each way)
    fov_until_m: float = 2.0  # closer than this the ring leaves the frame anyway
    fov_vertical_margin_deg: float = 14.0  # the dock stays within this of the nose vertically (about 20 each way)
    max_pitch_deg: float = 25.0  # largest pitch goal for reaching the dock's depth...
    climb_pitch_deg: float = 12.0  # ...of which the vehicle holds about this (its righting moment takes the rest)
    level_by_m: float = 1.0  # at the dock's depth this far before the entrance
    lookahead_share: float = 0.4  # lookahead = share of the distance along the line, within the limits
    lookahead_min_m: float = 1.0
    lookahead_max_m: float = 5.0
    pursuit_floor_m: float = 0.3  # nearer the entrance than the lookahead, aim at its centre; no closer than this
    line_margin_deg: float = 2.0  # of the entry limit kept in reserve (the crab plans for the rest): to correct with
    commit_m: float = 3.0  # closer than this along the axis the crossing is predicted and checked
    entry_tolerance_m: float = 0.06  # predicted miss distance that makes the vehicle back off
    entry_heading_limit_deg: float = 12.0  # predicted heading off the axis at the entry that makes it back off
    rollout_s: float = 20.0  # the prediction flies the law on for at most this long...
    rollout_step_s: float = 0.1  # ...in steps of this
    turn_rate_deg_s: float = 20.0  # how fast the heading follows its goal (the cascade's setpoint rate limit)...
    heading_time_constant_s: float = 0.8  # ...and the heading lags that setpoint (the attitude loop's response)
    speed_time_constant_s: float = 1.0
    back_off_to_m: float = 8.0  # along the line
    back_off_speed_mps: float = 0.4  # over ground
    reposition_beyond_view_deg: float = 10.0  # reversing to the back-off point needs the dock this far out of view...
    reposition_speed_mps: float = 0.7  # ...: turn round and drive blind at this speed over ground...
    reposition_to_m: float = 12.0  # ...to a point this far out on the line (a long final on the known axis)
    reposition_from_m: float = 4.0  # ...but not closer than this along the axis (the turn must clear the dock)
    upstream_margin_mps: float = 0.1  # the back-off point's line is turned for this much more cross current
    facing_deg: float = 10.0  # back at the point, the nose this close to the dock: backed off...
    refound_gap_m: float = 1.5  # ...unless the dock seen again puts the nose this far off the line: go again...
    max_back_off_legs: int = 3  # ...at most this many times per back-off
    side_room_m: float = math.inf  # beside the dock's axis, each side, to a wall (a pool's, less the hull)...
    back_off_room_share: float = 0.75  # ...back-off points lie within this share of it...
    wall_first_share: float = 0.5  # ...and beyond this share, reversing away from the wall comes before the view
    settle_m: float = 4.0  # on the approach line by this far out
    sidestep: bool = False  # back off sideways when the line is out of reach (else: approach, retry if it would miss)
    sidestep_shortfall_deg: float = 3.0  # sidestep when reaching the line in view falls short by more than this...
    sidestep_spare_deg: float = 2.0  # ...until it is in reach with this to spare
    sidestep_max_range_m: float = 25.0  # no sidestepping further out than this (the dock must stay detectable)
    sidestep_lead_deg: float = 18.0  # in reverse the dock is kept this far off the nose (heading control lags)

    def __post_init__(self) -> None:
        positive = (self.max_speed_mps, self.entry_crab_deg, self.far_crab_deg, self.fov_margin_deg,
                    self.lookahead_min_m, self.lookahead_max_m, self.commit_m, self.entry_tolerance_m,
                    self.back_off_to_m, self.back_off_speed_mps, self.crab_near_m, self.settle_m,
                    self.sidestep_max_range_m)
        if not all(math.isfinite(v) and v > 0 for v in positive) or self.crab_far_m <= self.crab_near_m:
            raise ConfigError("approach speeds, angles, distances and tolerances must be positive numbers, "
                              "crab_far_m > crab_near_m")


@dataclass(frozen=True)
class Plan:
    yaw_rad: float  # heading goal (navigation convention)
    speed_mps: float  # through the water; negative: in reverse
    verdict: Verdict
    along_m: float  # nose in front of the entrance, along the axis
    cross_m: float  # nose off the axis (starboard of the inbound path +)
    predicted_miss_m: float | None  # where the nose would cross the entrance plane, off the centre
    depth_left_m: float | None = None  # depth error that would be left at the entrance (checked with the miss)
    pitch_rad: float | None = None  # pitch goal for the dock's depth (nose up +); None: not known, the bearing's
    sidestep: bool = False  # backing off sideways to bring the approach line within reach
    blind: bool = False  # turned away from the dock, driving to the back-off point on the track


@dataclass(frozen=True)
class _Geometry:
    nose: tuple[float, float]  # relative to the entrance centre
    distance: float
    sight: float  # direction from the nose to the dock
    axis_yaw: float  # direction of travel into the dock (the line of sight while the axis is not known)
    along: float  # nose in front of the entrance, along the axis
    cross: float  # nose off the axis, starboard of the inbound path +
    line_yaw: float  # the approach line (the axis, turned in a cross current beyond the heading limit)


@dataclass(frozen=True)
class Situation:
    """What the planner needs, level navigation frame (x along yaw 0, y to starboard)."""

    position_m: tuple[float, float]  # vehicle reference point relative to the entrance centre
    current_mps: tuple[float, float]
    heading_rad: float
    water_speed_mps: float  # the vehicle's own speed through the water (estimate)
    axis_yaw_rad: float | None  # direction of travel into the dock; None: not known (line of sight)
    camera_ahead_m: float
    nominal_speed_mps: float  # the speed schedule's speed over ground at this range
    axis_known: bool = False  # the axis is told from its mirror image: sidesteps are allowed
    dock_below_m: float | None = None  # the entrance centre below the reference point; None: not seen yet
    dock_in_view: bool = True  # seen lately: the track is the camera's, not dead reckoning


def _unit(yaw: float) -> tuple[float, float]:
    return math.cos(yaw), math.sin(yaw)


def _dot(a: tuple[float, float], b: tuple[float, float]) -> float:
    return a[0] * b[0] + a[1] * b[1]


def _clamp(value: float, low: float, high: float) -> float:
    return max(low, min(high, value))


class ApproachPlanner:
    """Stateful only while sidestepping (``reset`` ends it)."""

    def __init__(self, config: ApproachConfig = ApproachConfig()) -> None:
        self.config = config
        self.reset()

    def reset(self) -> None:
        self._sidestepping = False
        self._back_off_phase = _BackOff.REVERSE
        self._back_off_legs = 0  # legs to the back-off point (the dock seen again may send it back)

    def plan(self, s: Situation, backing_off: bool, predict_entry: bool = True) -> Plan:
        """Heading and speed now; ``predict_entry`` also checks the crossing (when new information came)."""
        c = self.config
        geometry = self._geometry(s)
        if backing_off:
            self._sidestepping = False
            return self._back_off(s, geometry)
        self._back_off_phase = _BackOff.REVERSE
        self._back_off_legs = 0
        shortfall = self._shortfall(s, geometry)
        if shortfall is None:
            self._sidestepping = False
        elif self._sidestepping:
            self._sidestepping = shortfall > -math.radians(c.sidestep_spare_deg)
        else:
            self._sidestepping = shortfall > math.radians(c.sidestep_shortfall_deg)
        if self._sidestepping:
            return self._sidestep(s, geometry)
        if shortfall is not None and shortfall > -math.radians(c.sidestep_spare_deg + c.sidestep_shortfall_deg):
            s = replace(s, nominal_speed_mps=c.max_speed_mps)  # the line is barely in reach: the most lead there is
        yaw, speed = self._steer(s, geometry)
        along, cross = geometry.along, geometry.cross
        ground = self._ground_speed(s, yaw, speed)
        verdict, predicted, depth_left = Verdict.GO, None, None
        if along < c.commit_m and predict_entry:
            predicted = self._rolled_out_miss(s, yaw, speed)
            depth_left = self._depth_left(s, geometry, ground, speed)
            if predicted is None or abs(predicted) > c.entry_tolerance_m or depth_left > c.entry_tolerance_m:
                verdict = Verdict.WOULD_MISS
        return Plan(wrap_angle(yaw), speed, verdict, along, cross, predicted, depth_left,
                    self._pitch(s, geometry, ground, speed))

    def _pitch(self, s: Situation, g: _Geometry, ground: float, speed: float) -> float | None:
        """Pitch goal (nose up +) that brings the vehicle to the depth of the dock's level axis ahead: the
        line-of-sight law in the vertical. Pointing the nose at the dock instead closes a depth error
        only as fast as the range and arrives climbing or diving."""
        c = self.config
        if s.dock_below_m is None:
            return None
        sink = s.dock_below_m * ground / self._lookahead(g.along)  # m/s down, level at the lookahead
        limit = math.radians(c.max_pitch_deg)
        pitch = -math.asin(_clamp(sink / max(speed, c.min_speed_mps), -math.sin(limit), math.sin(limit)))
        if g.distance > c.fov_until_m:  # the dock stays in the frame
            elevation = -math.atan2(s.dock_below_m, g.distance)
            margin = math.radians(c.fov_vertical_margin_deg)
            pitch = _clamp(pitch, elevation - margin, elevation + margin)
        return pitch

    def _ground_speed(self, s: Situation, yaw: float, speed: float) -> float:
        h = _unit(yaw)
        ground = math.hypot(speed * h[0] + s.current_mps[0], speed * h[1] + s.current_mps[1])
        return max(ground, self.config.min_speed_mps)

    def _lookahead(self, distance: float) -> float:
        """Distance ahead on the line (or level axis) that the line-of-sight laws aim at."""
        c = self.config
        return _clamp(c.lookahead_share * distance, c.lookahead_min_m, c.lookahead_max_m)

    def _climb_per_metre(self) -> float:
        """Depth gained per metre travelled through the water at the pitch the vehicle holds."""
        return math.sin(math.radians(self.config.climb_pitch_deg))

    def _climb_speed(self, s: Situation, g: _Geometry) -> float:
        """Least speed through the water that reaches the dock's depth before the entry at the pitch the
        vehicle holds: a current setting towards the dock shortens the time there is for the climb."""
        c = self.config
        need = abs(s.dock_below_m or 0.0)
        if need < 0.05:
            return 0.0
        room = max(g.along - c.level_by_m, 0.0) * self._climb_per_metre() - need
        following = max(0.0, _dot(s.current_mps, _unit(g.axis_yaw)))
        return c.max_speed_mps if room <= 0.05 else need * following / room

    def _depth_left(self, s: Situation, g: _Geometry, ground: float, speed: float) -> float:
        """Depth error still left at the entrance. The vertical law climbs at the held pitch while the
        error exceeds that pitch's worth of lookahead, then closes it exponentially over the lookahead
        (a straight climb to the entrance passed seed 70, still 0.5 m low 3 m out: it entered pitched up
        8 deg, the nose 7.6 cm high). Asked a metre earlier, it sent pool approaches in a 0.2 m/s current
        back that would have docked, and the retries ran into the walls (pool 39/40 -> 35/40)."""
        need = abs(s.dock_below_m or 0.0)
        climb = self._climb_per_metre() * abs(speed) / ground  # per metre over ground, at the held pitch
        span = self._lookahead(g.along)
        saturated = max(0.0, need - climb * span) / max(climb, 1e-6)  # metres climbing at the held pitch
        if saturated >= g.along:
            return need - climb * g.along
        return min(need, climb * span) * math.exp(-(g.along - saturated) / span)

    def _geometry(self, s: Situation) -> _Geometry:
        h = _unit(s.heading_rad)
        nose = (s.position_m[0] + s.camera_ahead_m * h[0], s.position_m[1] + s.camera_ahead_m * h[1])
        sight = math.atan2(-nose[1], -nose[0])  # from the nose to the dock
        axis_yaw = s.axis_yaw_rad if s.axis_yaw_rad is not None else sight
        a, a_side = _unit(axis_yaw), _unit(axis_yaw + math.pi / 2)
        return _Geometry(nose, math.hypot(*nose), sight, axis_yaw, -_dot(nose, a), _dot(nose, a_side),
                         axis_yaw + self._line_turn(axis_yaw, s.current_mps))

    def _steer(self, s: Situation, g: _Geometry) -> tuple[float, float]:
        """Heading goal and speed through the water on the approach."""
        c = self.config
        line, line_side = _unit(g.line_yaw), _unit(g.line_yaw + math.pi / 2)
        on_line, off_line = -_dot(g.nose, line), _dot(g.nose, line_side)
        # Within the lookahead of the entrance the aim point would lie beyond it, leaving part of an offset
        # (a close fix's correction) open at the plane: aim at the centre itself (pure pursuit) instead.
        aim = min(self._lookahead(on_line), max(on_line, c.pursuit_floor_m))
        course = g.line_yaw - math.atan2(off_line, aim)
        held = c.entry_crab_deg - c.line_margin_deg  # the crab planned for; the rest of the limit corrects
        crab_limit = math.radians(held + (c.far_crab_deg - held) * _clamp(
            (g.along - c.crab_near_m) / (c.crab_far_m - c.crab_near_m), 0.0, 1.0))
        nominal = max(s.nominal_speed_mps, c.entry_speed_mps) if g.along < c.crab_near_m else s.nominal_speed_mps
        speed, yaw = self._crab(course, s.current_mps, nominal, crab_limit, self._climb_speed(s, g))
        widening = c.heading_limit_growth_deg_per_m * max(0.0, g.along - c.heading_limit_from_m)
        limit = math.radians(c.entry_crab_deg + widening)
        yaw = g.axis_yaw + _clamp(wrap_angle(yaw - g.axis_yaw), -limit, limit)
        if g.distance > c.fov_until_m:
            fov = math.radians(c.fov_margin_deg)
            yaw = g.sight + _clamp(wrap_angle(yaw - g.sight), -fov, fov)
        return yaw, speed

    def _rolled_out_miss(self, s: Situation, yaw: float, speed: float) -> float | None:
        """Off-centre distance where the nose crosses the entrance plane if this law flies on from here.

        A kinematic roll-out (the heading setpoint turning towards its goal at ``turn_rate_deg_s``,
        the heading lagging it by ``heading_time_constant_s``, speed following its goal with
        ``speed_time_constant_s``, the current estimate as it is);
        None if the nose does not reach the plane within ``rollout_s`` or the heading there is
        beyond the entry limit.
        """
        c = self.config
        dt = c.rollout_step_s
        turn = math.radians(c.turn_rate_deg_s) * dt
        heading, water = s.heading_rad, s.water_speed_mps
        setpoint, lag = heading, min(1.0, dt / c.heading_time_constant_s) if c.heading_time_constant_s > 0 else 1.0
        position = s.position_m
        s = replace(s, axis_yaw_rad=self._geometry(s).axis_yaw)  # the line of sight, if that is the axis, stays put
        for _ in range(int(c.rollout_s / dt)):
            now = replace(s, position_m=position, heading_rad=heading, water_speed_mps=water)
            g = self._geometry(now)
            if g.along <= 0.0:
                entry_heading = abs(wrap_angle(heading - g.axis_yaw))
                return g.cross if entry_heading <= math.radians(c.entry_heading_limit_deg) else None
            yaw, speed = self._steer(now, g)
            setpoint += _clamp(wrap_angle(yaw - setpoint), -turn, turn)
            heading += wrap_angle(setpoint - heading) * lag
            water += (speed - water) * min(1.0, dt / c.speed_time_constant_s)
            h = _unit(heading)
            position = (position[0] + dt * (water * h[0] + s.current_mps[0]),
                        position[1] + dt * (water * h[1] + s.current_mps[1]))
        return None

    def _line_turn(self, axis_yaw: float, current: tuple[float, float]) -> float:
        """How far the approach line turns off the axis so that the drift at the planned crab ends in the centre."""
        c = self.config
        across = _dot(current, _unit(axis_yaw + math.pi / 2))
        held = math.radians(c.entry_crab_deg - c.line_margin_deg)  # the rest of the limit corrects gusts and errors
        if abs(across) <= c.max_speed_mps * math.sin(held):
            return 0.0
        into = -math.copysign(held, across)  # nose into the current
        h = _unit(axis_yaw + into)
        ground = (c.max_speed_mps * h[0] + current[0], c.max_speed_mps * h[1] + current[1])
        return wrap_angle(math.atan2(ground[1], ground[0]) - axis_yaw)

    def _crab(self, course: float, current: tuple[float, float], nominal: float, crab_limit: float,
              least: float = 0.0) -> tuple[float, float]:
        """Speed through the water (at least ``least``) and heading that make the ground velocity point along
        ``course``."""
        c = self.config
        along = _dot(current, _unit(course))
        across = _dot(current, _unit(course + math.pi / 2))
        speed = max(nominal - along, abs(across) / math.sin(crab_limit), c.min_speed_mps, least)
        speed = min(speed, c.max_speed_mps)
        crab = math.asin(_clamp(across / speed, -1.0, 1.0))
        return speed, course - crab

    def _shortfall(self, s: Situation, g: _Geometry) -> float | None:
        """How far (angle seen from the dock) the approach line stays out of reach with the dock in view;
        negative: in reach with that to spare. None where sidestepping is not an option (axis not
        known, inside the commit distance, too far out)."""
        c = self.config
        line, line_side = _unit(g.line_yaw), _unit(g.line_yaw + math.pi / 2)
        on_line, off_line = -_dot(g.nose, line), _dot(g.nose, line_side)
        if not c.sidestep or not s.axis_known or on_line <= c.commit_m or g.distance > c.sidestep_max_range_m:
            return None
        off_angle = abs(math.atan2(off_line, on_line))
        lead = self._lead(s, g, -math.copysign(1.0, off_line), reverse=False)
        return off_angle - math.atan(lead) * math.log(max(on_line / c.settle_m, 1.0))

    def _lead(self, s: Situation, g: _Geometry, towards: float, reverse: bool) -> float:
        """tan of the largest angle by which the ground velocity can lead the line of sight (forward) or its
        opposite (reverse) towards one side (``towards`` +1: starboard), at full speed with the dock in view."""
        c = self.config
        h = _unit(self._lead_heading(g, towards, reverse))
        sign = -1.0 if reverse else 1.0
        ground = (sign * c.max_speed_mps * h[0] + s.current_mps[0], sign * c.max_speed_mps * h[1] + s.current_mps[1])
        moving = sign * _dot(ground, _unit(g.sight))
        across = towards * _dot(ground, _unit(g.sight + math.pi / 2))
        if moving <= 0.0:
            return math.inf if across > 0 else 0.0
        return max(0.0, across / moving)

    def _lead_heading(self, g: _Geometry, towards: float, reverse: bool) -> float:
        fov = math.radians(self.config.sidestep_lead_deg if reverse else self.config.fov_margin_deg)
        return g.sight + (-towards if reverse else towards) * fov

    def _sidestep(self, s: Situation, g: _Geometry) -> Plan:
        """In reverse at full speed, nose on the dock, the velocity led towards the approach line's side."""
        off_line = _dot(g.nose, _unit(g.line_yaw + math.pi / 2))
        yaw = self._lead_heading(g, -math.copysign(1.0, off_line), reverse=True)
        return Plan(wrap_angle(yaw), -self.config.max_speed_mps, Verdict.GO, g.along, g.cross, None, sidestep=True)

    def _back_off_line(self, s: Situation, g: _Geometry) -> float:
        """The line the back-off point lies on: turned as for a cross current ``upstream_margin_mps`` stronger
        than the estimate. The estimate after a turn or a blind leg runs low, and an approach begun downstream
        of the line cannot climb back against the current with the dock in view; from upstream it drifts
        down onto the line at no cost."""
        side = _unit(g.axis_yaw + math.pi / 2)
        extra = math.copysign(self.config.upstream_margin_mps, _dot(s.current_mps, side))
        current = (s.current_mps[0] + extra * side[0], s.current_mps[1] + extra * side[1])
        return g.axis_yaw + self._line_turn(g.axis_yaw, current)

    def _within_walls(self, point: tuple[float, float], g: _Geometry) -> tuple[float, float]:
        """``point`` moved across the dock's axis to within ``back_off_room_share`` of the side room."""
        side = _unit(g.axis_yaw + math.pi / 2)
        cross = _dot(point, side)
        allowed = self.config.back_off_room_share * self.config.side_room_m
        if abs(cross) <= allowed:
            return point
        shift = math.copysign(allowed, cross) - cross
        return point[0] + shift * side[0], point[1] + shift * side[1]

    def _turn_s(self, heading_rad: float, goal_rad: float) -> float:
        """Seconds the heading takes to turn to a goal at ``turn_rate_deg_s``."""
        return abs(wrap_angle(goal_rad - heading_rad)) / math.radians(self.config.turn_rate_deg_s)

    def _near_wall(self, s: Situation, g: _Geometry, to_goal: tuple[float, float], turning_s: float) -> bool:
        """Beyond ``wall_first_share`` of the side room, where the current sets the vehicle in ``turning_s``
        (turning round), with the back-off point inwards: reversing with the nose held on the dock lets a cross
        current carry the vehicle on towards the wall, and turning round to drive blind drifts it there while
        it turns (pool, 0.2 m/s: 1.15 m out, just inside the share, the turn and the blind leg ended on the wall)."""
        side = _unit(g.axis_yaw + math.pi / 2)
        cross = _dot(s.position_m, side) + turning_s * _dot(s.current_mps, side)
        return (abs(cross) > self.config.wall_first_share * self.config.side_room_m
                and _dot(to_goal, side) * cross < 0)

    def _back_off(self, s: Situation, g: _Geometry) -> Plan:
        """To a point on the line further out, then face the dock: in reverse with the nose on the dock, or
        blind where reversing there would take the dock out of view (see the module docstring)."""
        c = self.config
        line_yaw = self._back_off_line(s, g)
        line = _unit(line_yaw)
        blind = self._back_off_phase is _BackOff.BLIND
        out = c.reposition_to_m if blind else c.back_off_to_m
        goal = (-out * line[0], -out * line[1])
        if blind:  # up-current of the line by what the current carries the vehicle while it turns to the dock
            turning_s = self._turn_s(s.heading_rad, g.sight)
            goal = (goal[0] - turning_s * s.current_mps[0], goal[1] - turning_s * s.current_mps[1])
        goal = self._within_walls(goal, g)
        to_goal = (goal[0] - g.nose[0], goal[1] - g.nose[1])
        gap = math.hypot(*to_goal)
        if gap < 1.0 and self._back_off_phase is not _BackOff.FACE:
            self._back_off_phase = _BackOff.FACE
            self._back_off_legs += 1
        if self._back_off_phase is _BackOff.FACE:  # hold against the current along the nose while turning
            facing = abs(wrap_angle(s.heading_rad - g.sight)) < math.radians(c.facing_deg)
            off_line = abs(_dot(g.nose, _unit(line_yaw + math.pi / 2)))
            if facing and s.dock_in_view and off_line > c.refound_gap_m and self._back_off_legs < c.max_back_off_legs:
                # The dock seen again moved the track: the blind leg's dead reckoning drifted off the line
                # (a retry begun metres beside it misses the same way). Go to the point again.
                self._back_off_phase = _BackOff.REVERSE
                return self._back_off(s, g)
            return Plan(wrap_angle(g.sight), -_dot(s.current_mps, _unit(g.sight)),
                        Verdict.BACKED_OFF if facing else Verdict.GO, g.along, g.cross, None, blind=not facing)
        ground = min(c.reposition_speed_mps if blind else c.back_off_speed_mps, 0.5 * gap)
        want = (ground * to_goal[0] / gap, ground * to_goal[1] / gap)
        water = (want[0] - s.current_mps[0], want[1] - s.current_mps[1])
        reverse = math.atan2(-water[1], -water[0])
        fov = math.radians(c.fov_margin_deg)
        beyond_view = abs(wrap_angle(reverse - g.sight)) - fov
        turning_s = self._turn_s(s.heading_rad, reverse + math.pi)  # to drive blind
        wall_first = not blind and self._near_wall(s, g, to_goal, turning_s)  # reverse straight for the point
        if not wall_first and g.along >= c.reposition_from_m and (
                beyond_view > math.radians(c.reposition_beyond_view_deg) or g.along > c.back_off_to_m + 1.0):
            if not blind:  # from this tick on the blind goal and speed
                self._back_off_phase = _BackOff.BLIND
                return self._back_off(s, g)
        if blind:
            yaw = math.atan2(water[1], water[0])  # ahead only once turned that way (turn in place first)
            speed = min(math.hypot(*water), c.max_speed_mps) * max(0.0, math.cos(wrap_angle(yaw - s.heading_rad)))
            return Plan(yaw, speed, Verdict.GO, g.along, g.cross, None, blind=True)
        speed = -min(math.hypot(*water), c.max_speed_mps)
        if wall_first:
            return Plan(wrap_angle(reverse), speed, Verdict.GO, g.along, g.cross, None, blind=beyond_view > 0)
        yaw = g.sight + _clamp(wrap_angle(reverse - g.sight), -fov, fov)
        if beyond_view > 0:  # the camera limits the heading: make up with speed
            speed = -c.max_speed_mps
        return Plan(wrap_angle(yaw), speed, Verdict.GO, g.along, g.cross, None)
