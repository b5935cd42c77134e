"""Ring assembly from LED centroids: lights evenly spaced on an ellipse.

A ring of N LEDs seen from any angle is, to first order, an affine image of a circle:
the LED of slot s lies at ``c + a cos(s d) + b sin(s d)`` with ``d = 2 pi / N``, where c
is the image of the ring's centre and a, b are two conjugate half-diameters. Three
neighbouring LEDs (slots -1, 0, 1) fix c, a and b exactly, so every triple of
neighbouring lights predicts where all the ring's other LEDs must be, the centre
included even when it lies outside the frame. A hypothesis counts the lights found
where it predicts them (within a share of the LED spacing) among the slots that fall
inside the frame, and is refitted by least squares on all of them. It is a ring when
enough of the expected LEDs are there: single lights and pairs make no triple, and a
fixture, a caustic loop or the funnel's corners do not put lights at N even steps. Of
rings that could share lights, the one whose palest member glows most in colour is
taken: coloured LEDs glow in their colour, while a spot on what they light (a white
corner of the funnel beside blue LEDs) adds mostly that surface's white.

With the LED count unknown, each triple's own curvature suggests the step, and the
counts around it are tried; an unknown count needs more LEDs in view to be believed.
Once the dock's whole rings have shown its count (the detector's vote), that count and its
neighbours are tried, and the others only when they make no ring.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from auv_dock_guidance.vision.leds import COLOURED_GLOW_SATURATION, LedBlob, glow_saturation
from auv_dock_guidance.vision.levels import median

MIN_LEDS_KNOWN_COUNT = 3  # a corner: three neighbouring LEDs of a ring of known count
MIN_LEDS_UNKNOWN_COUNT = 5  # without the count, fewer could be any lights that happen to lie on a circle...
MIN_COLOURED_LEDS_UNKNOWN_COUNT = 4  # ...unless they all glow clearly in colour (lamps and glints are white)
MIN_OCCUPANCY = 0.75  # share of the LEDs expected in view that must be found (some may be dead or hidden)...
MIN_OCCUPANCY_TOLD = 0.6  # ...with the count given, from TOLD_RING_LEDS found: LEDs blooming into a lit funnel
TOLD_RING_LEDS = 6  # or under a lamp's glare are lost to the search, and six at N even steps are no chance
MATCH_TOLERANCE = 0.3  # of the local LED spacing: how far a light may be from where three LEDs predict it
FIT_TOLERANCE = 0.15  # the same, from the model fitted to all the ring's LEDs
MAX_RESIDUAL = 0.1  # rms distance of the LEDs from the fitted model / LED spacing: centroid scatter only
MAX_CIRCLE_RESIDUAL = 0.2  # the same from a circle through few LEDs: scatter and a tilt up to about 35 deg
MAX_COUNT_UNKNOWN = 32  # beyond this many LEDs they merge into a strip; the outline path takes them
SEED_LIGHTS = 16  # the strongest lights that seed hypotheses (all of them can confirm one)
MAX_SPACING_SIZES = 30.0  # LEDs further apart than this many of their radii: specks that happen to line up
# (not asked of bumps on a lit region's outline: their size is the LED's part outside the rim, not the LED's;
# nor of MIN_LEDS_UNKNOWN_COUNT or more LEDs at the even steps of a count the user gave, or the dock's rings
# showed farther out: a sparse ring of small LEDs close in, six 1 cm domes round a 0.35 m ring, is 70 of
# their radii apart)
ALIKE = 2.5  # the LEDs of one ring are alike: size and brightness within this factor of their median
GLOW_SATURATION_RATIO = 1.6  # a ring whose palest glow is this much paler than another ring's: what LEDs light
REFITS = 12  # hypotheses refitted per LED count, those the most lights confirm
InView = Callable[[np.ndarray], np.ndarray]  # (M, 2) positions -> (M,) inside the frame
_MIN_TURN_DEG, _MAX_TURN_DEG = 8.0, 90.0  # the ring's turn at each LED: 360/N, bent by tilt


@dataclass(frozen=True)
class LedRing:
    """LEDs of one ring: which lights, at which slots of the N, and the affine model through them."""

    members: tuple[int, ...]  # indices into the blobs
    slots: tuple[int, ...]  # slot of each member, 0..count-1
    count: int  # N
    center: tuple[float, float]  # c: the image of the ring's centre (the plane the blobs were given on)
    axis_a: tuple[float, float]  # a, b: conjugate half-diameters
    axis_b: tuple[float, float]
    expected: int  # slots whose LED falls inside the frame
    residual: float  # rms distance of the members from their slots / mean LED spacing
    light: float = 0.0  # the members' peaks added up
    glow_saturation: float = float("nan")  # how coloured the palest member's glow is (NaN: not told)

    @property
    def occupancy(self) -> float:
        return len(self.members) / max(1, self.expected)

    @property
    def whole(self) -> bool:
        """Every slot lies in view."""
        return self.expected >= self.count

    def slot_positions(self) -> np.ndarray:
        return _positions(np.array(self.center), np.array(self.axis_a), np.array(self.axis_b), self.count)

    def gap_positions(self) -> np.ndarray:
        """Half way round the ring between each pair of neighbouring slots."""
        return _positions(np.array(self.center), np.array(self.axis_a), np.array(self.axis_b), self.count, 0.5)

    def semi_axes(self) -> tuple[float, float]:
        """Semi-major and semi-minor axes of the ellipse spanned by a and b."""
        m = np.column_stack([self.axis_a, self.axis_b])
        singular = np.linalg.svd(m, compute_uv=False)
        return float(singular[0]), float(singular[1])


def assemble_rings(points: np.ndarray, blobs: list[LedBlob], in_view: InView | None,
                   led_count: int | None, max_rings: int = 3, likely_count: int | None = None) -> list[LedRing]:
    """Rings of evenly spaced lights among the blobs, best first, each light in one ring at most.

    A ring whose glow is far less coloured than the most coloured ring's is dropped: it is
    made of what the LEDs light (the rim and corners of a white funnel), not of LEDs; a
    reflection of the ring in the surface keeps the LEDs' colour and stays.

    ``points`` are the blobs' centres (N, 2) on the plane to fit on (undistorted pixels);
    ``in_view(xy)`` tells which predicted positions lie inside the frame (None: all do).
    ``led_count``: N when the user gave it; None when unknown. ``likely_count``: with it
    unknown, the count the dock's rings have shown so far: only it and its neighbours are
    tried while they make rings (a ring of another count is a misreading of the dock or
    another light), every count once they make none. The thresholds stay those of an unknown count.
    """
    free = np.ones(len(blobs), bool)
    rings: list[LedRing] = []
    likely = None if led_count else likely_count
    while len(rings) < max_rings:
        ring = _best_ring(points, blobs, free, in_view, led_count, likely)
        if ring is None and likely and not rings:
            likely = None
            ring = _best_ring(points, blobs, free, in_view, led_count, likely)
        if ring is None:
            break
        rings.append(ring)
        free[list(ring.members)] = False
    saturations = [r.glow_saturation for r in rings if not np.isnan(r.glow_saturation)]
    if saturations and max(saturations) >= COLOURED_GLOW_SATURATION:
        rings = [r for r in rings if not r.glow_saturation * GLOW_SATURATION_RATIO < max(saturations)]
    return rings


def _best_ring(points: np.ndarray, blobs: list[LedBlob], free: np.ndarray, in_view: InView | None,
               led_count: int | None, likely_count: int | None = None) -> LedRing | None:
    triples = _triples(points, blobs, free)
    if not len(triples):
        return None
    if led_count:
        by_count = {led_count: triples}
    else:
        low, high = _counts_to_try(points, triples)
        counts = range(int(low.min()), int(high.max()) + 1)
        if likely_count:  # the vote can settle one off the dock's count (an LED gained or lost in a bloom)
            counts = range(max(int(low.min()), likely_count - 1), min(int(high.max()), likely_count + 1) + 1)
        by_count = {n: triples[(low <= n) & (n <= high)] for n in counts}
    # Largest counts first: a ring holds at most one LED per slot, so a count below the best
    # ring's LEDs cannot beat it and is not tried. Of rings that rank alike, the one of the
    # smaller count is kept, as trying the counts upwards would keep it.
    best: LedRing | None = None
    for count in sorted(by_count, reverse=True):
        group = by_count[count]
        if not len(group) or (best is not None and count < len(best.members)):
            continue
        fewest = len(best.members) if best is not None else 0
        for ring in _hypotheses(points, blobs, free, group, count, in_view, led_count is not None, fewest,
                                count_settled=count == likely_count):
            if best is None or _better(ring, best) or (count < best.count and not _better(best, ring)):
                best = ring
    return best


def _better(a: LedRing, b: LedRing) -> bool:
    """More LEDs; then the more coloured glow of its palest member (a ring of lights beats a
    ring that takes in a spot they light) and more light; then the closer fit (the same
    lights read as rings of different counts)."""
    def rank(ring: LedRing) -> tuple[int, float, float, float]:
        glow = -1.0 if np.isnan(ring.glow_saturation) else ring.glow_saturation
        return len(ring.members), glow, ring.light, -ring.residual

    return rank(a) > rank(b)


def _triples(points: np.ndarray, blobs: list[LedBlob], free: np.ndarray) -> np.ndarray:
    """(j, i, k) among the strongest free lights: j and k on either side of i at similar
    distances, of a size similar to i's, bending as a ring of 6 or more LEDs does."""
    index = np.flatnonzero(free)  # isolated lights first: lights in a glow must not crowd them out
    index = index[np.lexsort(([-blobs[i].strength for i in index], [not blobs[i].isolated for i in index]))]
    index = index[:SEED_LIGHTS]
    if len(index) < 3:
        return np.empty((0, 3), np.int64)
    p = points[index]
    radius = np.array([blobs[i].radius_px for i in index])
    peak = np.array([blobs[i].peak for i in index])
    offset = p[None, :, :] - p[:, None, :]  # [i, j] = p_j - p_i
    distance = np.hypot(offset[..., 0], offset[..., 1])
    usable = _alike(radius) & _alike(peak) & (distance >= radius[:, None] + radius[None, :])
    np.fill_diagonal(usable, False)
    i, j, k = np.nonzero(usable[:, :, None] & usable[:, None, :])
    keep = j < k
    i, j, k = i[keep], j[keep], k[keep]
    dj, dk = distance[i, j], distance[i, k]
    keep = np.maximum(dj, dk) <= 2.0 * np.minimum(dj, dk)
    i, j, k, dj, dk = i[keep], j[keep], k[keep], dj[keep], dk[keep]
    cosine = np.sum(offset[i, j] * offset[i, k], axis=1) / (dj * dk)
    turn = 180.0 - np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
    keep = (turn >= _MIN_TURN_DEG) & (turn <= _MAX_TURN_DEG)
    return np.column_stack([index[j[keep]], index[i[keep]], index[k[keep]]])


def _enough_isolated(ring: LedRing, blobs: list[LedBlob]) -> bool:
    """Lights in a glow (a ring blooming into one halo, a lit funnel behind it) count towards
    a ring, but a few lights on a circle must each stand clear, and a longer run must hold
    at least one that does: spots on a lit surface do not fall at N even steps round a light."""
    isolated = sum(blobs[m].isolated for m in ring.members)
    return isolated >= (MIN_LEDS_KNOWN_COUNT if len(ring.members) < MIN_LEDS_UNKNOWN_COUNT else 1)


def _alike(values: np.ndarray) -> np.ndarray:
    """Pairs whose values are within ALIKE of each other (matrix)."""
    return np.maximum(values[:, None], values[None, :]) <= ALIKE * np.minimum(values[:, None], values[None, :])


def _least_told(values: np.ndarray) -> float:
    """Smallest of the values that are told (not NaN); NaN when none is."""
    told = values[~np.isnan(values)]
    return float(np.min(told)) if len(told) else float("nan")


def _counts_to_try(points: np.ndarray, triples: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per triple, the range of LED counts its turn suggests: a circle through three neighbouring
    LEDs turns by 360/N at each; tilt bends that by up to about the axis ratio either way."""
    j, i, k = points[triples[:, 0]], points[triples[:, 1]], points[triples[:, 2]]
    u, w = j - i, k - i
    cosine = np.sum(u * w, axis=1) / (np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1))
    turn = np.pi - np.arccos(np.clip(cosine, -1.0, 1.0))  # exterior angle = central angle of one step
    estimate = 2.0 * np.pi / np.maximum(turn, 1e-3)
    low = np.maximum(6, np.floor(0.7 * estimate)).astype(int)
    high = np.minimum(MAX_COUNT_UNKNOWN, np.ceil(1.45 * estimate)).astype(int)
    return low, high


def _positions(center: np.ndarray, a: np.ndarray, b: np.ndarray, count: int, phase: float = 0.0) -> np.ndarray:
    """Slot positions (..., count, 2) of affine rings with centres c and half-diameters a, b (..., 2);
    ``phase``: a share of a step round the ring past each slot."""
    angle = 2.0 * np.pi * (np.arange(count) + phase) / count
    return (center[..., None, :] + a[..., None, :] * np.cos(angle)[:, None]
            + b[..., None, :] * np.sin(angle)[:, None])


def _hypotheses(points: np.ndarray, blobs: list[LedBlob], free: np.ndarray, triples: np.ndarray, count: int,
                in_view: InView | None, count_known: bool, fewest: int = 0,
                count_settled: bool = False) -> list[LedRing]:
    """Rings of ``count`` LEDs grown from the triples and confirmed by the lights (none of
    fewer than ``fewest`` LEDs: a ring that many LEDs strong is known already). ``count_settled``:
    the count is the one the dock's rings have shown (`assemble_rings`' ``likely_count``).

    Each triple (slots -1, 0, 1, in either direction round the ring) must first lie on a
    circle at three even steps of the N: few LEDs are fitted as a ring seen nearly face on
    (a circle: centre, radius and turn), which three points over-determine, so a triple of
    lights at other steps (every other LED taken for neighbours) or off any such arc is
    dropped; a tilted ring still passes within the tolerance. It is then grown outwards one
    step at a time on both sides: the ring through the LEDs found so far (the circle while
    fewer than four, then the affine ring, which follows the tilt) predicts the next slot,
    and the nearest light within a share of the local spacing is taken for it. One step of
    extrapolation at a time keeps the prediction close; of several lights there, the
    brightest (a light beats what it lights); a slot without a light (dead, hidden, out of
    the frame) is passed over.
    """
    index = np.flatnonzero(free)
    if len(triples) == 0 or len(index) < 3:
        return []
    triples = np.concatenate([triples, triples[:, ::-1]])  # both directions round the ring
    light = np.array([blobs[i].peak for i in index])
    design = _affine_design(count)  # (count, 3)
    circle = _circle_design(count)  # (count, 2, 4)
    weight = np.zeros((len(triples), count))
    found = np.full((len(triples), count), -1, np.int64)  # light index per slot
    for slot, column in ((count - 1, 0), (0, 1), (1, 2)):
        weight[:, slot] = 1.0
        found[:, slot] = triples[:, column]
    by_slot = points[found]
    arcs = _fit_circles(weight, by_slot, circle, _triple_normal(count))
    on_arc = _circle_residual(arcs, weight, by_slot, circle) <= MAX_CIRCLE_RESIDUAL
    weight, found = weight[on_arc], found[on_arc]
    hypotheses = len(found)
    if not hypotheses:
        return []
    free_points = points[index]
    # Each hypothesis's circle or affine ring is refitted only when it took a light (a row's fit
    # does not depend on the other rows), and its slots predicted once per fit. Most steps no
    # hypothesis finds anything: the steps up to the next one where some hypothesis takes a
    # light are matched in one batch, and growth goes on after it.
    circles, affine = np.zeros((hypotheses, 4)), np.zeros((hypotheses, 3, 2))
    predicted = np.zeros((hypotheses, count, 2))
    visits, before, distance_end = _growth_steps(count)
    spacing = np.zeros((hypotheses, len(visits)))
    stale = np.ones(hypotheses, bool)
    sizes = np.count_nonzero(weight, axis=1)  # lights each hypothesis holds...
    untaken = ~(found[:, :, None] == index[None, None, :]).any(axis=1)  # ...and (H, F) those it does not
    step = 0
    while step < len(visits):
        if stale.any() and (step == 0 or distance_end[step - 1] == step):  # refits wait for the next distance
            few = sizes < 4
            if (rows := stale & few).any():
                circles[rows] = _fit_circles(weight[rows], points[np.maximum(found[rows], 0)], circle)
            if (rows := stale & ~few).any():
                affine[rows] = _fit_affine(weight[rows], points[np.maximum(found[rows], 0)], design)
            predicted[stale] = _slot_predictions(few[stale], circles[stale], affine[stale], circle, design)
            spacing[stale] = _distance(predicted[stale][:, visits], predicted[stale][:, before])
            stale[:] = False
        end = distance_end[step] if stale.any() else len(visits)
        gap = _distance(predicted[:, visits[step:end], None, :], free_points)  # (H, steps, F)
        within = untaken[:, None, :] & (gap <= MATCH_TOLERANCE * spacing[:, step:end, None])
        brightest = np.argmax(np.where(within, light, -1.0), axis=2)  # (H, steps)
        hit = np.take_along_axis(within, brightest[:, :, None], axis=2)[:, :, 0] & (found[:, visits[step:end]] < 0)
        taking = np.flatnonzero(hit.any(axis=0))
        if not len(taking):
            step = end
            continue
        first = int(taking[0])
        hit = hit[:, first]
        took = brightest[hit, first]
        step += first
        found[hit, visits[step]] = index[took]
        weight[hit, visits[step]] = 1.0
        untaken[hit, took] = False
        stale |= hit
        sizes += hit
        step += 1
    minimum = MIN_LEDS_KNOWN_COUNT if count_known else MIN_COLOURED_LEDS_UNKNOWN_COUNT
    sizes = (found >= 0).sum(axis=1)
    seen: set[tuple[int, ...]] = set()
    starts = []
    for h in np.argsort(-sizes, kind="stable"):
        if sizes[h] < minimum or len(seen) >= REFITS:
            break
        slots = np.flatnonzero(found[h] >= 0)
        members = tuple(sorted(int(m) for m in found[h, slots]))
        if members in seen:
            continue
        seen.add(members)
        starts.append((found[h, slots], slots))
    rings = []
    for ring in _Refitter(points, blobs, free, count, in_view, count_known, count_settled).refit(starts, fewest):
        if ring is None:
            continue
        coloured = ring.glow_saturation >= COLOURED_GLOW_SATURATION  # False when not told (NaN)
        if len(ring.members) >= (minimum if count_known or coloured else MIN_LEDS_UNKNOWN_COUNT) \
                and _enough_isolated(ring, blobs):
            rings.append(ring)
    return rings


def _slot_predictions(few: np.ndarray, circles: np.ndarray, affine: np.ndarray, circle: np.ndarray,
                      design: np.ndarray) -> np.ndarray:
    """Where each hypothesis puts every slot (H, count, 2): its circle while it has few LEDs
    (``few``), else its affine ring. Each slot is predicted as on its own (a (1, 3) row times
    the affine ring; the circle's contraction per slot), so the numbers are those of one slot at a time."""
    on_affine = np.matmul(design[None, :, None, :], affine[:, None, :, :])[:, :, 0, :]
    return np.where(few[:, None, None], np.einsum("sri,hi->hsr", circle, circles), on_affine)


@lru_cache(maxsize=64)
def _growth_steps(count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The slots growth visits, in order (one step further out on each side in turn), the slot
    before each on its side, and the index of the step after each step's distance."""
    visits: list[int] = []
    before: list[int] = []
    distance_end: list[int] = []
    for distance in range(2, count // 2 + 1):
        sides = [(distance % count, distance - 1), ((-distance) % count, (1 - distance) % count)]
        for slot, previous in sides[: 1 if 2 * distance == count else 2]:
            visits.append(slot)
            before.append(previous)
        distance_end += [len(visits)] * (len(visits) - len(distance_end))
    return _read_only(np.array(visits)), _read_only(np.array(before)), _read_only(np.array(distance_end))


@lru_cache(maxsize=64)
def _affine_design(count: int) -> np.ndarray:
    """Rows (1, cos, sin) of each slot: the affine ring c + a cos + b sin is linear in c, a, b."""
    return _read_only(np.column_stack([np.ones(count), _unit_circle(np.arange(count), count)]))


@lru_cache(maxsize=64)
def _homogeneous_circle(count: int) -> np.ndarray:
    """Rows (cos, sin, 1) of each slot: the unit circle's slots on the plane a homography maps."""
    return _read_only(np.column_stack([_unit_circle(np.arange(count), count), np.ones(count)]))


def _read_only(array: np.ndarray) -> np.ndarray:
    """A cached array nobody may change."""
    array.setflags(write=False)
    return array


def _distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances between 2-D points along the last axis (broadcast): np.linalg.norm(a - b, axis=-1)
    to the bit, without its overhead nor the differences' array of pairs."""
    dx = a[..., 0] - b[..., 0]
    dy = a[..., 1] - b[..., 1]
    return np.sqrt(dx * dx + dy * dy)


def _next(array: np.ndarray, axis: int, step: int = 1) -> np.ndarray:
    """np.roll(array, -step, axis) for arrays along ``axis``: each slot's neighbour ``step`` further on."""
    later, first = [slice(None)] * array.ndim, [slice(None)] * array.ndim
    later[axis], first[axis] = slice(step, None), slice(None, step)
    return np.concatenate([array[tuple(later)], array[tuple(first)]], axis=axis)


@lru_cache(maxsize=64)
def _triple_normal(count: int) -> np.ndarray:
    """The circle fit's normal matrix (1, 4, 4) of lights at slots -1, 0 and 1, every triple's:
    made once per count (a row's matrix does not depend on the other rows)."""
    weight = np.zeros((1, count))
    weight[0, [count - 1, 0, 1]] = 1.0
    circle = _circle_design(count)
    return _read_only(np.einsum("hs,sri,srj->hij", weight, circle, circle))


@lru_cache(maxsize=64)
def _circle_design(count: int) -> np.ndarray:
    """(count, 2, 4): the x and y rows of each slot for a circle seen face on, linear in its
    centre and (A, B) = radius * (cos, sin) of its turn: x = cx + A cos - B sin, y = cy + A sin + B cos."""
    cos, sin = _unit_circle(np.arange(count), count).T
    ones, zeros = np.ones(count), np.zeros(count)
    return _read_only(np.stack([np.column_stack([ones, zeros, cos, -sin]), np.column_stack([zeros, ones, sin, cos])],
                               axis=1))


def _fit_affine(weight: np.ndarray, points: np.ndarray, design: np.ndarray) -> np.ndarray:
    """Least-squares affine rings (H, 3, 2) through each hypothesis's lights (``points`` (H, count, 2) by slot)."""
    return np.linalg.solve(np.einsum("hs,si,sj->hij", weight, design, design) + 1e-9 * np.eye(3),
                           np.einsum("hs,si,hsj->hij", weight, design, points))


def _fit_circles(weight: np.ndarray, points: np.ndarray, circle: np.ndarray,
                 normal: np.ndarray | None = None) -> np.ndarray:
    """Least-squares circles (H, 4) through each hypothesis's lights (``points`` (H, count, 2) by slot);
    ``normal``: the normal equations' matrix when known already (it follows from the weights alone)."""
    if normal is None:
        normal = np.einsum("hs,sri,srj->hij", weight, circle, circle)
    target = np.einsum("hs,sri,hsr->hi", weight, circle, points)
    return np.linalg.solve(normal + 1e-9 * np.eye(4), target[..., None])[..., 0]


def _circle_residual(circles: np.ndarray, weight: np.ndarray, points: np.ndarray, circle: np.ndarray) -> np.ndarray:
    """Rms distance of each hypothesis's lights from its circle's slots, over the LED spacing."""
    predicted = np.einsum("sri,hi->hsr", circle, circles)
    squared = (np.sum((predicted - points) ** 2, axis=2) * weight).sum(axis=1) / np.maximum(weight.sum(axis=1), 1)
    count = circle.shape[0]
    spacing = 2.0 * np.hypot(circles[:, 2], circles[:, 3]) * np.sin(np.pi / count)
    return np.sqrt(squared) / np.maximum(spacing, 1e-9)


def _match_positions(points: np.ndarray, light: np.ndarray, free: np.ndarray, predicted: np.ndarray,
                     tolerance: float, in_view: InView | None) -> list[tuple[np.ndarray, np.ndarray, int]]:
    """Per hypothesis (predicted slot positions (H, count, 2)): the brightest light within
    ``tolerance`` of the local spacing of each slot, their slots, and the slots expected in view."""
    spacing = _distance(_next(predicted, 1), predicted)
    local = np.minimum(spacing, _next(spacing, 1, spacing.shape[1] - 1))  # (H, count): the smaller of both sides
    index = np.flatnonzero(free)
    gap = _distance(predicted[:, :, None, :], points[index])  # (H, count, F)
    within = gap <= tolerance * local[:, :, None]
    nearest = np.argmax(np.where(within, light[index][None, None, :], -1.0), axis=2)
    found = np.take_along_axis(within, nearest[:, :, None], axis=2)[:, :, 0]
    visible = np.ones_like(found) if in_view is None else in_view(predicted.reshape(-1, 2)).reshape(found.shape)
    results = []
    for h in range(len(predicted)):
        slots = np.flatnonzero(found[h])
        lights = index[nearest[h, slots]]
        lights, first = np.unique(lights, return_index=True)  # one light, one slot
        results.append((lights, slots[first], int(np.count_nonzero(visible[h] | found[h]))))
    return results


class _Refitter:
    """Refits of one count's hypotheses among the same free lights (`refit`).

    Refits of different hypotheses often converge on the same lights, and a refit that
    has settled fits the same lights again: the model and the lights it matches are kept
    per (lights, slots), and which lights are alike per set of lights, so each is worked
    out once; the matches of a round are made for all hypotheses at once.
    """

    def __init__(self, points: np.ndarray, blobs: list[LedBlob], free: np.ndarray, count: int,
                 in_view: InView | None, count_known: bool, count_settled: bool = False) -> None:
        self.points, self.blobs, self.free, self.count, self.in_view = points, blobs, free, count, in_view
        self.count_known = count_known
        self.count_settled = count_settled
        self.peak = np.array([b.peak for b in blobs])
        self.radius = np.array([b.radius_px for b in blobs])
        self.on_outline = np.array([b.on_outline for b in blobs], bool)
        self._fits: dict[tuple[bytes, bytes], tuple[np.ndarray, np.ndarray | None] | None] = {}
        self._matches: dict[tuple[bytes, bytes], tuple[np.ndarray, np.ndarray, int]] = {}
        self._alike_lights: dict[bytes, np.ndarray] = {}

    def refit(self, starts: list[tuple[np.ndarray, np.ndarray]], fewest: int = 0) -> list[LedRing | None]:
        """Per start (lights, slots): the ring through the matched lights at their slots,
        re-matched as the model tightens (`_ring_fit`; from 5 LEDs the ring's perspective
        image, so the final residual is the centroids' scatter, not the model's), keeping
        only lights alike in size and brightness. None when the lights stray from the model
        by more than its tolerance, or when fewer than MIN_OCCUPANCY of the LEDs expected in
        view are left (MIN_OCCUPANCY_TOLD of a count given, from TOLD_RING_LEDS), or fewer than ``fewest`` lights."""
        current: list[tuple[np.ndarray, np.ndarray] | None] = list(starts)
        expected = [0] * len(starts)
        fitted: list[tuple[np.ndarray, np.ndarray | None] | None] = [None] * len(starts)
        for rematch in (True, True, False):
            if not rematch:  # the last round and the ring only drop lights: too few now is too few then
                current = [None if start is None or len(start[0]) < fewest else start for start in current]
            keys: list[tuple[bytes, bytes] | None] = [None] * len(starts)
            for i, start in enumerate(current):
                if start is None:
                    continue
                lights, slots = self._alike(*start)
                key = (lights.tobytes(), slots.tobytes())
                # The last round fits only the lights that fill enough of the slots in view to be a ring.
                occupancy = len(lights) / max(1, expected[i])
                enough = len(lights) >= 3 and (rematch or occupancy >= self._least_occupancy(len(lights)))
                fitted[i] = self._fit(key, lights, slots) if enough else None
                current[i], keys[i] = ((lights, slots), key) if fitted[i] is not None else (None, None)
            if rematch:
                self._match([(told, fit[0]) for told, fit in zip(keys, fitted, strict=True)
                             if told is not None and fit is not None and told not in self._matches])
                for i, told in enumerate(keys):
                    if told is not None:
                        lights, slots, expected[i] = self._matches[told]
                        current[i] = (lights, slots)
        return [None if start is None or fit is None else self._ring(*start, expected[i], fit)
                for i, (start, fit) in enumerate(zip(current, fitted, strict=True))]

    def _least_occupancy(self, lights: int) -> float:
        """Share of the LEDs expected in view a ring must hold: less of a count the user gave, once enough are found."""
        return MIN_OCCUPANCY_TOLD if self.count_known and lights >= TOLD_RING_LEDS else MIN_OCCUPANCY

    def _match(self, models: list[tuple[tuple[bytes, bytes], np.ndarray]]) -> None:
        """The lights at the slots of each model not matched yet, all in one batch."""
        unique = dict(models)
        if unique:
            matched = _match_positions(self.points, self.peak, self.free, np.stack(list(unique.values())),
                                       FIT_TOLERANCE, self.in_view)
            self._matches.update(zip(unique, matched, strict=True))

    def _ring(self, lights: np.ndarray, slots: np.ndarray, expected: int,
              fitted: tuple[np.ndarray, np.ndarray | None]) -> LedRing | None:
        """The ring of a finished refit (enough of the slots filled), or None (see `refit`)."""
        model, homography = fitted
        points = self.points[lights]
        spacing = float(np.mean(_distance(_next(model, 0), model)))
        sparse_ring_told = (self.count_known or self.count_settled) and len(lights) >= MIN_LEDS_UNKNOWN_COUNT
        if (spacing > MAX_SPACING_SIZES * median(self.radius[lights]) and not sparse_ring_told
                and not self.on_outline[lights].all()):
            return None
        residual = float(np.sqrt(np.mean(np.sum((points - model[slots]) ** 2, axis=1)))) / max(spacing, 1e-9)
        (center, a, b), tolerance = _ring_fit(points, slots, self.count)
        if residual > tolerance:
            return None
        if homography is not None:  # from 5 LEDs: the centre where the perspective image puts it
            projected = homography @ np.array([0.0, 0.0, 1.0])
            center = projected[:2] / projected[2]
        blobs = self.blobs
        return LedRing(
            members=tuple(int(x) for x in lights), slots=tuple(int(s) for s in slots), count=self.count,
            center=(float(center[0]), float(center[1])), axis_a=(float(a[0]), float(a[1])),
            axis_b=(float(b[0]), float(b[1])), expected=expected, residual=residual,
            light=float(sum(blobs[i].peak for i in lights)),
            glow_saturation=_least_told(np.array([glow_saturation(blobs[i].glow_bgr) for i in lights])),
        )

    def _fit(self, key: tuple[bytes, bytes], lights: np.ndarray,
             slots: np.ndarray) -> tuple[np.ndarray, np.ndarray | None] | None:
        if key not in self._fits:
            self._fits[key] = _slot_model(self.points[lights], slots, self.count)
        return self._fits[key]

    def _alike(self, lights: np.ndarray, slots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The lights within ALIKE of the members' median size and brightness (told once per set of lights)."""
        if len(lights) == 0:
            return lights, slots
        key = lights.tobytes()
        if key not in self._alike_lights:
            keep = np.ones(len(lights), bool)
            for values in (self.radius[lights], self.peak[lights]):
                middle = median(values)
                keep &= (values <= ALIKE * middle) & (values >= middle / ALIKE)
            self._alike_lights[key] = keep
        keep = self._alike_lights[key]
        return lights[keep], slots[keep]


def _unit_circle(slots: np.ndarray, count: int) -> np.ndarray:
    angle = 2.0 * np.pi * np.asarray(slots) / count
    return np.column_stack([np.cos(angle), np.sin(angle)])


def _affine(xy: np.ndarray, slots: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares c, a, b of ``c + a cos(s d) + b sin(s d)`` through the lights."""
    design = np.column_stack([np.ones(len(slots)), _unit_circle(slots, count)])
    (center, a, b), *_ = np.linalg.lstsq(design, xy, rcond=None)
    return center, a, b


def ring_model(xy: np.ndarray, slots: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centre and conjugate half-diameters (c, a, b) of the ring through lights at their slots."""
    return _ring_fit(xy, slots, count)[0]


def _ring_fit(xy: np.ndarray, slots: np.ndarray, count: int) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], float]:
    """The ring through lights at their slots, and how far (share of the spacing) its lights may
    stray from it: the affine ring from five lights, which follows any tilt, within centroid
    scatter; through fewer, where the affine ring fits three lights exactly, a circle (a ring
    seen nearly face on) within scatter and some tilt; four lights of a ring tilted beyond
    that are taken as an affine ring again, within scatter only."""
    if len(xy) >= 5:
        return _affine(xy, slots, count), MAX_RESIDUAL
    weight = np.zeros((1, count))
    by_slot = np.zeros((1, count, 2))
    weight[0, slots] = 1.0
    by_slot[0, slots] = xy
    design = _circle_design(count)
    circle = _fit_circles(weight, by_slot, design)
    cx, cy, a0, b0 = circle[0]
    if len(xy) == 4 and _circle_residual(circle, weight, by_slot, design)[0] > MAX_CIRCLE_RESIDUAL:
        return _affine(xy, slots, count), MAX_RESIDUAL
    return (np.array([cx, cy]), np.array([a0, b0]), np.array([-b0, a0])), MAX_CIRCLE_RESIDUAL


def _homography(xy: np.ndarray, slots: np.ndarray, count: int) -> np.ndarray | None:
    """The plane-to-image homography of the unit circle's slots (least squares, DLT)."""
    homography, _ = cv2.findHomography(_unit_circle(slots, count), xy, 0)
    return None if homography is None or not np.all(np.isfinite(homography)) else homography


def _slot_model(xy: np.ndarray, slots: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray | None] | None:
    """Where the model through these lights puts all ``count`` slots (count, 2), and its
    homography when it is the ring's perspective image (from 5 lights)."""
    if len(xy) >= 5:
        homography = _homography(xy, slots, count)
        if homography is None:
            return None
        image = _homogeneous_circle(count) @ homography.T
        if np.any(np.abs(image[:, 2]) < 1e-9) or np.ptp(np.sign(image[:, 2])) > 0:
            return None  # the ring would cross the horizon: not a ring seen from in front
        return image[:, :2] / image[:, 2:], homography
    center, a, b = ring_model(xy, slots, count)
    return _positions(center, a, b, count), None
