"""The approach path: which heading and speed bring the nose into the entrance along the dock's axis.

Geometry in the level navigation frame, from the tracked position relative to the dock,
the current estimate and the dock's axis (or, while the axis is not known, the line of
sight: pure bearing homing, but on the velocity). The vehicle follows a line through the
entrance centre with a line-of-sight law (aim at a point ``lookahead`` ahead on the
line); the heading is what makes the velocity over ground point along that course in the
current (crab into it), and the speed through the water is raised until the crab fits
the heading limit for the entry.

When the cross current is stronger than the fastest vehicle can crab into within the
entry limit, the heading is held at the limit and the line itself is turned until the
resulting drift carries the nose into the centre: the vehicle enters at the heading
limit on a line a little off the axis, as an aircraft lands in a crosswind. The camera
must keep the dock in view, so the heading stays within ``fov_margin_deg`` of the dock's
bearing until the ring is too close to matter.

Close to the entrance the predicted crossing is checked: if it would miss, the verdict
is ``would_miss`` and guidance backs off (in reverse, nose on the dock) to a point on the
line further out, then tries again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from auv_dock_guidance.control.pid import wrap_angle
from auv_dock_guidance.errors import ConfigError


class Verdict(StrEnum):
    GO = "go"
    WOULD_MISS = "would_miss"
    BACKED_OFF = "backed_off"


@dataclass(frozen=True)
class ApproachConfig:
    max_speed_mps: float = 0.9  # through the water; full thrust gives 1.0 but turning needs headroom
    min_speed_mps: float = 0.15
    entry_crab_deg: float = 8.0  # heading limit against the dock's axis for the last metres
    far_crab_deg: float = 30.0  # largest crab far out (the dock must stay in view)
    crab_near_m: float = 4.0  # along the axis: the entry limit applies below this...
    crab_far_m: float = 10.0  # ...and the far limit beyond this
    heading_limit_growth_deg_per_m: float = 20.0  # the heading clamp against the axis widens with distance
    fov_margin_deg: float = 22.0  # the dock stays within this of the nose (the camera sees about 29 deg each way)
    fov_until_m: float = 2.0  # closer than this the ring leaves the frame anyway
    lookahead_share: float = 0.4  # lookahead = share of the distance along the line, within the limits
    lookahead_min_m: float = 1.0
    lookahead_max_m: float = 5.0
    line_margin_deg: float = 3.0  # in a cross current beyond the limit: the line turns this much past the drift
    commit_m: float = 3.0  # closer than this along the axis the crossing is predicted and checked
    entry_tolerance_m: float = 0.12  # predicted miss distance that makes the vehicle back off
    back_off_to_m: float = 8.0  # along the line
    back_off_speed_mps: float = 0.4  # over ground

    def __post_init__(self) -> None:
        positive = (self.max_speed_mps, self.entry_crab_deg, self.far_crab_deg, self.fov_margin_deg,
                    self.lookahead_min_m, self.lookahead_max_m, self.commit_m, self.entry_tolerance_m,
                    self.back_off_to_m, self.back_off_speed_mps, self.crab_near_m)
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


def _unit(yaw: float) -> tuple[float, float]:
    return math.cos(yaw), math.sin(yaw)


def _dot(a: tuple[float, float], b: tuple[float, float]) -> float:
    return a[0] * b[0] + a[1] * b[1]


def _clamp(value: float, low: float, high: float) -> float:
    return max(low, min(high, value))


class ApproachPlanner:
    def __init__(self, config: ApproachConfig = ApproachConfig()) -> None:
        self.config = config

    def plan(self, s: Situation, backing_off: bool) -> Plan:
        c = self.config
        h = _unit(s.heading_rad)
        nose = (s.position_m[0] + s.camera_ahead_m * h[0], s.position_m[1] + s.camera_ahead_m * h[1])
        distance = math.hypot(*nose)
        sight = math.atan2(-nose[1], -nose[0])  # from the nose to the dock
        axis_yaw = s.axis_yaw_rad if s.axis_yaw_rad is not None else sight
        a = _unit(axis_yaw)
        a_side = _unit(axis_yaw + math.pi / 2)
        along, cross = -_dot(nose, a), _dot(nose, a_side)
        line_yaw = axis_yaw + self._line_turn(axis_yaw, s.current_mps)
        if backing_off:
            return self._back_off(s, nose, sight, line_yaw, along, cross)
        line, line_side = _unit(line_yaw), _unit(line_yaw + math.pi / 2)
        on_line, off_line = -_dot(nose, line), _dot(nose, line_side)
        lookahead = _clamp(c.lookahead_share * on_line, c.lookahead_min_m, c.lookahead_max_m)
        course = line_yaw - math.atan2(off_line, lookahead)
        crab_limit = math.radians(c.entry_crab_deg + (c.far_crab_deg - c.entry_crab_deg) * _clamp(
            (along - c.crab_near_m) / (c.crab_far_m - c.crab_near_m), 0.0, 1.0))
        speed, yaw = self._crab(course, s.current_mps, s.nominal_speed_mps, crab_limit)
        limit = math.radians(c.entry_crab_deg + c.heading_limit_growth_deg_per_m * max(0.0, along - 2.0))
        yaw = axis_yaw + _clamp(wrap_angle(yaw - axis_yaw), -limit, limit)
        if distance > c.fov_until_m:
            fov = math.radians(c.fov_margin_deg)
            yaw = sight + _clamp(wrap_angle(yaw - sight), -fov, fov)
        predicted = self._predicted_miss(s, a, a_side, along, cross)
        verdict = Verdict.GO
        if along < c.commit_m and abs(predicted if predicted is not None else cross) > c.entry_tolerance_m and (
                predicted is not None or along < 1.0):  # not closing yet: only a vehicle beside the entrance
            verdict = Verdict.WOULD_MISS
        return Plan(wrap_angle(yaw), speed, verdict, along, cross, predicted)

    def _line_turn(self, axis_yaw: float, current: tuple[float, float]) -> float:
        """How far the approach line turns off the axis so that the drift at the heading limit ends in the centre."""
        c = self.config
        across = _dot(current, _unit(axis_yaw + math.pi / 2))
        limit = math.radians(c.entry_crab_deg)
        if abs(across) <= c.max_speed_mps * math.sin(limit):
            return 0.0
        into = -math.copysign(limit, across)  # nose into the current
        h = _unit(axis_yaw + into)
        ground = (c.max_speed_mps * h[0] + current[0], c.max_speed_mps * h[1] + current[1])
        drift = wrap_angle(math.atan2(ground[1], ground[0]) - axis_yaw)
        return drift + math.copysign(math.radians(c.line_margin_deg), drift)

    def _crab(self, course: float, current: tuple[float, float], nominal: float, crab_limit: float
              ) -> tuple[float, float]:
        """Speed through the water and heading that make the ground velocity point along ``course``."""
        c = self.config
        along = _dot(current, _unit(course))
        across = _dot(current, _unit(course + math.pi / 2))
        speed = max(nominal - along, abs(across) / math.sin(crab_limit), c.min_speed_mps)
        speed = min(speed, c.max_speed_mps)
        crab = math.asin(_clamp(across / speed, -1.0, 1.0))
        return speed, course - crab

    def _predicted_miss(self, s: Situation, a: tuple[float, float], a_side: tuple[float, float], along: float,
                        cross: float) -> float | None:
        """Off-centre distance where the nose would cross the entrance plane on the present velocity."""
        h = _unit(s.heading_rad)
        ground = (s.water_speed_mps * h[0] + s.current_mps[0], s.water_speed_mps * h[1] + s.current_mps[1])
        closing = _dot(ground, a)
        if closing <= 0.05:
            return None
        return cross + _dot(ground, a_side) * max(along, 0.0) / closing

    def _back_off(self, s: Situation, nose: tuple[float, float], sight: float, line_yaw: float, along: float,
                  cross: float) -> Plan:
        """In reverse, nose on the dock, to a point on the line further out."""
        c = self.config
        line = _unit(line_yaw)
        goal = (-c.back_off_to_m * line[0], -c.back_off_to_m * line[1])
        to_goal = (goal[0] - nose[0], goal[1] - nose[1])
        gap = math.hypot(*to_goal)
        verdict = Verdict.BACKED_OFF if gap < 1.0 or along >= c.back_off_to_m - 0.5 else Verdict.GO
        want = (c.back_off_speed_mps * to_goal[0] / max(gap, 1e-6), c.back_off_speed_mps * to_goal[1] / max(gap, 1e-6))
        water = (want[0] - s.current_mps[0], want[1] - s.current_mps[1])
        speed = -min(math.hypot(*water), c.max_speed_mps)
        yaw = math.atan2(-water[1], -water[0])
        fov = math.radians(c.fov_margin_deg)
        yaw = sight + _clamp(wrap_angle(yaw - sight), -fov, fov)
        return Plan(wrap_angle(yaw), speed, verdict, along, cross, None)
