"""Stage 2: the paper's pipeline in one window, and the regions in it that pass the gates.

Bilateral filter, improved (Scharr) Canny edges, the adaptive threshold steered by the
region's apparent size, closed contours. Every closed outline is a candidate of its own;
blobs without a hole are also assembled into rings of separate LEDs or arcs
(`segments.py`). The window is scaled so the ring is about ``refine_radius_px`` large.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from auv_dock_guidance.geometry.camera import CameraModel
from auv_dock_guidance.vision.config import DetectorConfig, lens_scale, min_ring_radius_px
from auv_dock_guidance.vision.edges import bilateral, improved_canny
from auv_dock_guidance.vision.image_input import intensity
from auv_dock_guidance.vision.levels import detrended_deviation, pixel_median
from auv_dock_guidance.vision.normalized import cut_shape, outline_residual
from auv_dock_guidance.vision.outline import on_border, pixel_area, to_full
from auv_dock_guidance.vision.search import Box
from auv_dock_guidance.vision.segments import Dot, dot_rings
from auv_dock_guidance.vision.selection import CandidateShape, is_ring, rejection_reason
from auv_dock_guidance.vision.threshold import AdaptiveThreshold


@dataclass
class Region:
    """A candidate for the marker, in full-resolution distorted pixels."""

    shape: CandidateShape
    threshold: float
    outer: np.ndarray  # (N, 2) full-resolution distorted pixels; all LED outlines when dotted
    hole: np.ndarray | None
    dotted: bool = False  # separate LEDs on a common ellipse
    led_centers: np.ndarray | None = None  # (N, 2) full-resolution pixels, when dotted


class Refiner:
    """Refines windows of one frame with the detector's settings, threshold state and camera."""

    def __init__(self, config: DetectorConfig, threshold: AdaptiveThreshold, camera: CameraModel | None) -> None:
        self.config = config
        self.threshold = threshold
        self.camera = camera
        self.lens_scale = lens_scale(camera)
        self.min_radius_px = min_ring_radius_px(config, camera)

    def refine(self, image: np.ndarray, box: Box, radius_estimate: float, rejected: list[str]) -> list[Region]:
        c = self.config
        x0, y0, x1, y1 = box
        scale = min(1.0, c.refine_radius_px / max(radius_estimate, 1.0))
        roi = image[y0:y1, x0:x1]
        if round(min(roi.shape[:2]) * scale) < 4:  # a sliver at the frame's edge (as resize rounds: 0 px raised)
            return []
        if scale < 1.0:
            roi = cv2.resize(roi, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        gray = intensity(roi)
        smooth = bilateral(gray, c.bilateral)
        # A near ring's window spans the water's fall-off in light from the surface down: that is
        # not noise (it put the floor above white), but the floor stands above the window's
        # brightest side, or the top of an empty window's fall-off reads as a light.
        sides = [smooth[0], smooth[-1], smooth[:, 0], smooth[:, -1]]
        background = pixel_median(np.concatenate(sides))
        noise = max(0.5, 1.4826 * detrended_deviation(sides))
        _, peak, _, _ = cv2.minMaxLoc(cv2.GaussianBlur(smooth, (3, 3), 0))
        fraction = self.threshold.fraction_for(radius_estimate / self.lens_scale)
        level = self.threshold.level(background, peak, noise, fraction,
                                     floor_above=max(pixel_median(side) for side in sides))
        if peak <= level:
            rejected.append("too faint")
            return []
        contrast = peak - background
        edges = improved_canny(gray, c.canny_low * contrast, c.canny_high * contrast, smoothed=smooth)
        near_edge = cv2.dilate(edges, np.ones((5, 5), np.uint8))
        # Close small gaps first; a faint ring that noise broke into arcs gets a wider
        # closing, scaled to its size, when the narrow one found no ring.
        _, mask = cv2.threshold(smooth, level, 255, cv2.THRESH_BINARY)
        wide = max(5, int(0.2 * radius_estimate * scale)) | 1
        regions: list[Region] = []
        for close in (3, wide) if wide > 3 else (3,):
            kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (close, close))
            closed = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, kernel)
            found = self._regions(closed, near_edge, smooth, background, image.shape[:2], scale, (x0, y0), level,
                                  rejected)
            if any(is_ring(r.shape, c.selection) for r in found) or not regions:
                regions = found
            if any(is_ring(r.shape, c.selection) for r in regions):
                break
        return regions

    def _regions(
        self, mask: np.ndarray, near_edge: np.ndarray, smooth: np.ndarray, background: float,
        frame_size: tuple[int, int], scale: float, origin: tuple[int, int], level: float, rejected: list[str],
    ) -> list[Region]:
        """Closed regions of one window's mask that pass the gates, in full-resolution units."""
        x0, y0 = origin
        contours, hierarchy = cv2.findContours(mask, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
        if hierarchy is None:
            return []
        min_radius_full = self.min_radius_px
        selection = self.config.selection
        regions: list[Region] = []
        outlines: list[tuple[np.ndarray, Region]] = []  # every closed outline, a candidate of its own
        dot_of: dict[int, int] = {}  # outline -> its index among the blobs without a hole
        dots: list[Dot] = []
        for idx, contour in enumerate(contours):
            if hierarchy[0][idx][3] != -1:
                continue  # a hole; handled with its outer contour
            area = pixel_area(contour)
            hole = _largest_child(contours, hierarchy[0], idx)
            hole_area = pixel_area(hole) - cv2.arcLength(hole, True) if hole is not None else 0.0
            pts = contour[:, 0, :]
            support = float(np.count_nonzero(near_edge[pts[:, 1], pts[:, 0]])) / len(pts)
            if hole_area < selection.min_hole_fraction * area:
                dot_of[len(outlines)] = len(dots)
                dots.append((pts, area, support))
            outer_full = to_full(pts, scale, x0, y0)
            if on_border(outer_full, frame_size).any():  # the shape the frame left, not the cut one
                axis_ratio, arc_deg = cut_shape(self.camera, outer_full, frame_size)
            else:
                (_, _), (d1, d2), _ = cv2.minAreaRect(contour)
                axis_ratio, arc_deg = min(d1, d2) / max(d1, d2, 1e-6), 360.0
            _, mec_r = cv2.minEnclosingCircle(outer_full.astype(np.float32))
            shape = CandidateShape(
                area_px=area / (scale * scale),
                center_v=float(outer_full[:, 1].mean()),
                radius_px=float(mec_r),
                axis_ratio=axis_ratio,
                hole_fraction=hole_area / area,
                edge_support=support,
                arc_deg=arc_deg,
            )
            hole_full = to_full(hole[:, 0, :], scale, x0, y0) if hole is not None else None
            outlines.append((contour, Region(shape, level, outer_full, hole_full)))
        in_rings: set[int] = set()
        for ring in dot_rings(dots):
            outline_full = to_full(ring.outline, scale, x0, y0)
            if ring.led_centers is None and on_border(outline_full, frame_size).any():
                continue  # arcs the frame cuts (a reflection at the top edge) are open, not broken
            members = [dots[m][0][:, None, :] for m in ring.members]
            shape = CandidateShape(
                area_px=ring.area / (scale * scale),
                center_v=(ring.center_row + 0.5) / scale - 0.5 + y0,
                radius_px=math.sqrt(ring.area / math.pi / max(ring.axis_ratio, 1e-6)) / scale,
                axis_ratio=ring.axis_ratio,
                hole_fraction=1.0,
                edge_support=ring.edge_support,
                contrast=_mean_level(smooth, mask, members) - background,
                ellipse_residual=ring.residual,
            )
            centers = None if ring.led_centers is None else to_full(ring.led_centers, scale, x0, y0)
            region = Region(shape, level, outline_full, None, dotted=True, led_centers=centers)
            if self._keep(region, min_radius_full, regions, rejected):
                in_rings.update(ring.members)
        for i, (contour, region) in enumerate(outlines):
            if dot_of.get(i) in in_rings:
                continue  # an arc or LED of a ring is not a candidate of its own
            reason = rejection_reason(region.shape, selection, min_radius_full)  # the cheap gates first
            if reason is not None:
                rejected.append(reason)
                continue
            region.shape = dataclasses.replace(
                region.shape, contrast=_mean_level(smooth, mask, [contour]) - background,
                ellipse_residual=outline_residual(self.camera, region.outer, frame_size))
            self._keep(region, min_radius_full, regions, rejected)
        return regions

    def _keep(self, region: Region, min_radius_px: float, regions: list[Region], rejected: list[str]) -> bool:
        """Add the region if it passes the gates, else note why not; whether it was added."""
        reason = rejection_reason(region.shape, self.config.selection, min_radius_px)
        if reason is None:
            regions.append(region)
        else:
            rejected.append(reason)
        return reason is None


def add_region(regions: list[Region], region: Region, config: DetectorConfig) -> None:
    """Add a refined region unless another window already saw it; a wider window that saw the
    whole ring where a narrow one saw an arc replaces the arc."""
    seen = next((i for i, other in enumerate(regions) if _same_region(region, other)), None)
    if seen is None:
        regions.append(region)
    elif is_ring(region.shape, config.selection) and not is_ring(regions[seen].shape, config.selection):
        regions[seen] = region


def _same_region(a: Region, b: Region) -> bool:
    """Two windows can overlap and see one region twice."""
    ca, cb = a.outer.mean(axis=0), b.outer.mean(axis=0)
    return float(np.hypot(*(ca - cb))) < 0.3 * max(a.shape.radius_px, b.shape.radius_px)


def _largest_child(contours: Sequence[np.ndarray], hierarchy: np.ndarray, parent: int) -> np.ndarray | None:
    child = hierarchy[parent][2]
    best, best_area = None, 0.0
    while child != -1:
        area = cv2.contourArea(contours[child])
        if area > best_area:
            best, best_area = contours[child], area
        child = hierarchy[child][0]
    return best


def _mean_level(smooth: np.ndarray, mask: np.ndarray, contours: list[np.ndarray]) -> float:
    """Mean grey level of the segmented pixels inside these outlines (holes excluded)."""
    x, y, w, h = cv2.boundingRect(np.concatenate(contours))
    inside = np.zeros((h, w), np.uint8)
    cv2.drawContours(inside, contours, -1, 255, -1, offset=(-x, -y))
    inside &= mask[y:y + h, x:x + w]
    return float(cv2.mean(smooth[y:y + h, x:x + w], mask=inside)[0])
