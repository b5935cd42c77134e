"""Ring assembly from pieces: separate LEDs, or arcs of a strip, on one ellipse.

The pieces are the blobs of one refinement window that have no hole of their own.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import cv2
import numpy as np

from auv_dock_guidance.vision.outline import ellipse_through, radial_residual

Dot = tuple[np.ndarray, float, float]  # outline (N, 2), area, edge support


class SegmentRing(NamedTuple):
    """Separate LEDs, or arcs, of one ring among a window's blobs (window pixels)."""

    members: tuple[int, ...]  # the blobs it is made of
    outline: np.ndarray  # all their outline points
    led_centers: np.ndarray | None  # None for arcs
    edge_support: float
    area: float  # of the ellipse through them
    axis_ratio: float
    center_row: float
    residual: float  # rms distance from the ellipse relative to its size


def dot_rings(dots: list[Dot], min_dots: int = 6) -> list[SegmentRing]:
    """Rings of separate LEDs, or of arcs, among the blobs of one window, one per chain of neighbours.

    Blobs are chained when they come closer than 2.5 typical neighbour gaps, so a ring
    and its reflection, or a ring and a lamp cluster, are fitted apart, while LEDs that
    motion blur smeared together still chain.
    """
    clusters = [list(range(len(dots)))] if len(dots) == 1 else chains(dots)
    rings = []
    for members in clusters:
        group = [dots[m] for m in members]
        ring = dot_ring(group, min_dots) or arc_ring(group)
        if ring is not None:
            rings.append(ring._replace(members=tuple(members[m] for m in ring.members)))
    return rings


def chains(dots: list[Dot], max_dots: int = 300) -> list[list[int]]:
    """Indices of blobs chained by gaps under 2.5 typical neighbour gaps, chain by chain.

    The gap between two blobs is their centres' distance less their equivalent radii.
    Only the ``max_dots`` largest take part (noise can make thousands of specks).
    """
    if not dots:
        return []
    order = sorted(range(len(dots)), key=lambda i: dots[i][1], reverse=True)[:max_dots]
    centroids = np.array([dots[i][0].mean(axis=0) for i in order], dtype=np.float64)
    radii = np.sqrt(np.array([dots[i][1] for i in order]) / math.pi)
    gap = np.hypot(*(centroids[:, None, :] - centroids[None, :, :]).transpose(2, 0, 1))
    gap -= radii[:, None] + radii[None, :]
    np.fill_diagonal(gap, np.inf)
    linked = gap <= 2.5 * max(1.0, float(np.median(gap.min(axis=1)))) + 2.0
    chain = [-1] * len(order)
    found: list[list[int]] = []
    for start in range(len(order)):
        if chain[start] >= 0:
            continue
        chain[start] = len(found)
        members, todo = [], [start]
        while todo:
            i = todo.pop()
            members.append(order[i])
            for j in np.flatnonzero(linked[i]):
                if chain[j] < 0:
                    chain[j] = chain[start]
                    todo.append(int(j))
        found.append(members)
    return found


def dot_ring(dots: list[Dot], min_dots: int) -> SegmentRing | None:
    """Separate LEDs on one ellipse (members are indices into ``dots``).

    Blobs of similar size are fitted with an ellipse through their centroids; blobs far off
    it are dropped and the fit repeated. The group counts as a ring when enough LEDs remain
    and they go most of the way round (at least 5 of 8 sectors), so a few scattered glints
    cannot pose as one.
    """
    if len(dots) < min_dots:
        return None
    areas = np.array([d[1] for d in dots])
    median = float(np.median(areas))
    members = [i for i, a in enumerate(areas) if median / 5.0 <= a <= median * 5.0]
    centroids = np.array([d[0].mean(axis=0) for d in dots], dtype=np.float64)
    for _ in range(3):
        if len(members) < min_dots:
            return None
        (cx, cy), (d1, d2), angle = cv2.fitEllipse(centroids[members].astype(np.float32))
        if not (min(d1, d2) > 0 and math.isfinite(d1 + d2)):
            return None
        t = math.radians(angle)
        rel = centroids[members] - (cx, cy)
        xr = (rel[:, 0] * math.cos(t) + rel[:, 1] * math.sin(t)) / (d1 / 2)
        yr = (-rel[:, 0] * math.sin(t) + rel[:, 1] * math.cos(t)) / (d2 / 2)
        residual = np.abs(np.hypot(xr, yr) - 1.0)
        keep = [m for m, r in zip(members, residual, strict=True) if r < 0.15]
        rms = float(np.sqrt(np.mean(residual[residual < 0.15] ** 2))) if keep else 1.0
        if len(keep) == len(members):
            break
        members = keep
    if len(members) < min_dots:
        return None
    angles = np.arctan2(centroids[members, 1] - cy, centroids[members, 0] - cx)
    sectors = len(set(((angles + math.pi) / (2 * math.pi) * 8).astype(int) % 8))
    if sectors < 5:
        return None
    return SegmentRing(
        members=tuple(members), outline=np.concatenate([dots[m][0] for m in members]),
        led_centers=centroids[members], edge_support=float(np.mean([dots[m][2] for m in members])),
        area=math.pi * d1 * d2 / 4.0,
        axis_ratio=min(d1, d2) / max(d1, d2), center_row=float(cy), residual=rms,
    )


def arc_ring(dots: list[Dot], min_coverage: float = 0.6) -> SegmentRing | None:
    """Arcs of one ring, broken by dim or dead LEDs or partly hidden: outlines on one ellipse.

    The outline points of a thin band lie on both sides of its centre line, so an ellipse
    fitted to all of them is the centre line. The group counts as a ring when the band is
    thin against the ellipse (it does not fill it, as a lamp's disc does), its distance
    from the ellipse is about the same all round (the band's half width), and it covers
    most of the circumference (10-degree bins), so a few scattered glints that happen to
    lie on some conic cannot pose as one. Its centre row and size are the ellipse's.
    """
    points = np.concatenate([d[0] for d in dots]).astype(np.float64)
    if len(points) < 16:
        return None
    ellipse = ellipse_through(points)
    if ellipse is None or ellipse.semi_minor <= 1.0:
        return None
    a, b = ellipse.semi_major, ellipse.semi_minor
    offset = np.abs(radial_residual(ellipse, points)) / math.sqrt(a * b)
    area = sum(d[1] for d in dots)
    ellipse_area = math.pi * a * b
    angles = np.arctan2(points[:, 1] - ellipse.center_y, points[:, 0] - ellipse.center_x)
    covered = len(set(((angles + math.pi) / (2 * math.pi) * 36).astype(int) % 36)) / 36.0
    if area > 0.5 * ellipse_area or float(np.mean(offset)) > 0.25 or covered < min_coverage:
        return None
    return SegmentRing(
        members=tuple(range(len(dots))), outline=points.astype(np.int32), led_centers=None,
        edge_support=float(np.mean([d[2] for d in dots])), area=ellipse_area, axis_ratio=b / a,
        center_row=float(ellipse.center_y), residual=float(np.std(offset)),
    )
