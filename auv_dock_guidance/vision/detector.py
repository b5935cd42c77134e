"""The LED-ring detector: one camera frame in, one Detection out.

Two stages keep the 1080p frame cheap without losing precision:

1. Search, on a quarter-size copy: subtract a local background (morphological opening,
   wider than the LED strip, so surface light gradients and backscatter do not count),
   keep what stands above the noise floor, and take the largest bright regions.
2. Refinement, at full or near-full resolution in a window around each region: the
   paper's pipeline. Bilateral filter, improved (Scharr) Canny edges, the adaptive
   threshold steered by the region's apparent size, closed contours, the gates and the
   paper's choice rule (largest, lowest on ties), and the minimum enclosing circle.

Beyond the paper, the chosen contour is also fitted where a circle is a circle: its
points are undistorted to the normalized plane, an ellipse is fitted to the outer
outline and, for a resolved ring, to its inner outline too. The mean of the two is the
LED centre line, unbiased by halo or threshold, and the ellipse centre is mapped back
to image pixels. Points on the image border or beyond the lens model's fold are left
out of the fit. A ring the frame cuts gets a circle through its visible arc (LED
centres, or the strip's outer edge): the bearing that turns the vehicle towards it,
and a rougher range.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import cv2
import numpy as np

from auv_dock_guidance.errors import ConfigError
from auv_dock_guidance.geometry.camera import PAPER_FOCAL_PX, CameraModel
from auv_dock_guidance.geometry.pose import (
    Ellipse,
    MarkerPose,
    pose_from_circle,
    pose_from_point,
    ring_center_solution,
)
from auv_dock_guidance.vision.edges import BilateralParams, bilateral, improved_canny
from auv_dock_guidance.vision.image_input import as_bgr_or_gray8, intensity
from auv_dock_guidance.vision.selection import (
    CandidateShape,
    SelectionConfig,
    choose,
    is_ring,
    rejection_reason,
)
from auv_dock_guidance.vision.threshold import AdaptiveThreshold, ThresholdConfig


@dataclass(frozen=True)
class DetectorConfig:
    """Detector settings; every field is documented in README.md (Detector parameters)."""

    marker_radius_m: float = 0.35  # radius of the LED ring's centre line
    max_range_m: float = 40.0  # smaller apparent rings are glints or distant lamps
    search_scale: float = 0.25  # size of the search copy
    search_background_px: int = 31  # opening width on the search copy (wider than the strip)
    max_candidates: int = 6  # regions refined per frame and grouping width
    search_floor_grey: float = 3.0  # search keeps what stands this far above the local background...
    search_floor_noise_sigmas: float = 4.0  # ...and this many noise deviations (on the small copy)
    search_gaps_px: tuple[int, ...] = (0, 32, 96)  # LED gaps bridged when grouping (full-res px)
    refine_radius_px: float = 90.0  # refine at a resolution where the ring is about this large
    bilateral: BilateralParams = BilateralParams(diameter=5, sigma_color=30.0, sigma_space=3.0)
    tracking: bool = False  # look near the last marker first; search the whole frame when lost
    full_search_every: int = 15  # while tracking, still search the whole frame this often (frames)
    canny_low: float = 0.04  # hysteresis thresholds as shares of the region's contrast, per px
    canny_high: float = 0.10
    threshold: ThresholdConfig = field(default_factory=ThresholdConfig)
    selection: SelectionConfig = field(default_factory=SelectionConfig)

    def __post_init__(self) -> None:
        if not (self.marker_radius_m > 0 and math.isfinite(self.marker_radius_m)):
            raise ConfigError(f"marker_radius_m {self.marker_radius_m} must be a positive number")
        if not self.max_range_m > 0:
            raise ConfigError(f"max_range_m {self.max_range_m} must be positive")
        if not 0.05 <= self.search_scale <= 1.0:
            raise ConfigError(f"search_scale {self.search_scale} must be in [0.05, 1]")
        if self.search_background_px < 3 or self.max_candidates < 1 or self.refine_radius_px < 16:
            raise ConfigError("search_background_px >= 3, max_candidates >= 1, refine_radius_px >= 16")
        if self.full_search_every < 1:
            raise ConfigError(f"full_search_every {self.full_search_every} must be at least 1")
        if not 0 < self.canny_low <= self.canny_high:
            raise ConfigError(f"need 0 < canny_low <= canny_high, got {self.canny_low}, {self.canny_high}")


@dataclass(frozen=True)
class Detection:
    """The marker in one frame. Pixel values are in the recorded (distorted) image."""

    found: bool
    u: float = math.nan  # image of the ring centre
    v: float = math.nan
    radius_px: float = math.nan  # ring radius on the undistorted image, in pixels
    threshold: float = math.nan  # grey level that segmented the chosen region
    reason: str = ""  # why nothing was found
    is_ring: bool = False  # the dark centre was resolved
    ellipse: Ellipse | None = None  # the fit on the normalized plane
    mec_u: float = math.nan  # the paper's minimum enclosing circle (distorted pixels)
    mec_v: float = math.nan
    mec_radius_px: float = math.nan
    candidates: int = 0  # regions that passed the gates
    pose: MarkerPose | None = None  # range, offsets and bearing; None without a valid fit
    ring_normal: tuple[float, float, float] | None = None  # dock axis (optical frame), tilt-aware fit
    fit_sigma: float = math.nan  # standard error of the fitted centre, each coordinate (normalized units)
    visible_arc_deg: float = 360.0  # how much of the ring's circle the fit saw (less where the frame cuts it)


@dataclass
class _Region:
    shape: CandidateShape
    threshold: float
    outer: np.ndarray  # (N, 2) full-resolution distorted pixels; all LED outlines when dotted
    hole: np.ndarray | None
    dotted: bool = False  # separate LEDs on a common ellipse
    led_centers: np.ndarray | None = None  # (N, 2) full-resolution pixels, when dotted


class Detector:
    """Stateful across the frames of one sequence (the adaptive threshold); call reset() between."""

    def __init__(self, camera: CameraModel | None = None, config: DetectorConfig = DetectorConfig()) -> None:
        self.camera = camera
        self.config = config
        self.threshold = AdaptiveThreshold(config.threshold)
        self._last: Detection | None = None  # the previous frame's marker, for tracking
        self._frames = 0

    def reset(self) -> None:
        self.threshold.reset()
        self._last = None
        self._frames = 0

    # ------------------------------------------------------------------ main entry
    def detect(self, image: np.ndarray) -> Detection:
        image = self._checked(image)
        detection = None
        self._frames += 1
        tracking = self.config.tracking and self._last is not None
        if tracking and self._frames % self.config.full_search_every != 0:
            assert self._last is not None
            detection = self._detect_in(image, [self._track_window(image, self._last)])
            if not detection.found:
                detection = None  # lost: search the whole frame
        if detection is None:
            detection = self._detect_in(image, self._search(image))
        self._remember(detection)
        return detection

    def _remember(self, detection: Detection) -> None:
        """Carry a frame's outcome to the next: the threshold share (steered by the ring's size
        as the paper's camera would see it) and the window to track."""
        self.threshold.update(detection.radius_px / self._lens_scale if detection.found else None)
        self._last = detection if detection.found else None

    def fit_camera(self, width: int, height: int) -> str | None:
        """Follow images that are a uniform resize of the camera model (binned, scaled down
        for recording); returns what changed, for the caller to say once, or None.

        Raises CameraModelError when the size cannot come from this camera.
        """
        camera = self.camera
        if camera is None or (width, height) == (camera.width, camera.height):
            return None
        self.camera = camera.for_image(width, height)
        return (f"images are {width}x{height}, the camera model {camera.width}x{camera.height}: "
                f"model scaled by {width / camera.width:.4g}")

    @property
    def _lens_scale(self) -> float:
        """Apparent sizes through this camera relative to the paper's, whose 1080p frames the
        pixel sizes of the defaults (search copy, LED gaps, threshold reference) are for."""
        return self.camera.focal_px / PAPER_FOCAL_PX if self.camera is not None else 1.0

    def _checked(self, image: np.ndarray) -> np.ndarray:
        image = as_bgr_or_gray8(image)
        if self.camera is not None and image.shape[:2] != (self.camera.height, self.camera.width):
            raise ConfigError(
                f"image is {image.shape[1]}x{image.shape[0]} but the camera model is "
                f"{self.camera.width}x{self.camera.height}"
            )
        return image

    def _detect_in(self, image: np.ndarray, boxes: list[tuple[tuple[int, int, int, int], float]]) -> Detection:
        """Refine each window, choose among what passed the gates (paper Fig. 5), fit the choice."""
        regions: list[_Region] = []
        rejected: list[str] = []
        for box, radius_estimate in boxes:
            for region in self._refine(image, box, radius_estimate, rejected):
                seen = next((i for i, other in enumerate(regions) if _same_region(region, other)), None)
                if seen is None:
                    regions.append(region)
                elif is_ring(region.shape, self.config.selection) and not is_ring(regions[seen].shape,
                                                                                    self.config.selection):
                    regions[seen] = region  # a wider window saw the whole ring where a narrow one saw an arc
        best = choose([r.shape for r in regions], self.config.selection)
        if best is None:
            reason = "no bright region" if not boxes else "rejected: " + "; ".join(sorted(set(rejected))[:3])
            return Detection(found=False, reason=reason)
        return self._fit(regions[best], len(regions), image.shape[:2])

    def _track_window(self, image: np.ndarray, last: Detection) -> tuple[tuple[int, int, int, int], float]:
        """A window around the last detection, wide enough for the ring to move between frames."""
        h, w = image.shape[:2]
        r = max(last.radius_px, last.mec_radius_px if math.isfinite(last.mec_radius_px) else 0.0)
        half = 1.5 * r + 24
        box = (max(0, int(last.u - half)), max(0, int(last.v - half)),
               min(w, int(math.ceil(last.u + half))), min(h, int(math.ceil(last.v + half))))
        return box, r

    # ------------------------------------------------------------------ stage 1
    def _search(self, image: np.ndarray) -> list[tuple[tuple[int, int, int, int], float]]:
        """Bright regions on a small copy: (full-resolution box, radius estimate) each.

        Regions are grouped at several gap widths, so the separate LEDs of a ring come out
        as one region at the width that bridges their spacing. The light is cut at two
        levels: just above the noise (faint, far rings) and halfway to the brightest light
        in view, where the LEDs come apart from dimmer light they touch (a web of caustics,
        glow on structure) that would otherwise make one region of the whole frame.
        """
        c = self.config
        lens = self._lens_scale
        s = min(1.0, c.search_scale / lens)  # the ring keeps its size in the search copy, whatever the lens
        small = image if s == 1.0 else cv2.resize(image, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
        gray = intensity(small)
        k = c.search_background_px | 1
        kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (k, k))
        background = cv2.blur(cv2.morphologyEx(gray, cv2.MORPH_OPEN, kernel), (k, k))
        tophat = cv2.subtract(gray, background)
        sample = tophat[::2, ::2]
        typical = float(np.median(sample))
        noise = 1.4826 * float(np.median(np.abs(sample.astype(np.float32) - typical)))
        # Search wide: a low floor finds faint, far rings; the refinement's floor decides.
        floor = typical + max(c.search_floor_grey, c.search_floor_noise_sigmas * noise)
        bright = floor + 0.5 * (float(tophat.max()) - floor)
        h, w = image.shape[:2]
        min_radius = 0.7 * max(c.selection.min_radius_px, self._min_radius_px())  # smaller: no ring we accept
        boxes: list[tuple[tuple[int, int, int, int], float]] = []
        low, high = (cv2.threshold(tophat, level, 255, cv2.THRESH_BINARY)[1] for level in (floor, bright))
        for mask, gap_px in [*itertools.product([low], c.search_gaps_px), (high, 0), (high, 32)]:
            kernel_size = int(round(gap_px * lens * s)) | 1
            grouped = mask if kernel_size <= 1 else cv2.dilate(
                mask, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (kernel_size, kernel_size))
            )
            count, labels, stats, _ = cv2.connectedComponentsWithStats(grouped, connectivity=8)
            found = []
            for i in range(1, count):
                x, y, bw, bh = (int(v) for v in stats[i, :4])
                x0, y0, x1, y1 = (x - 1) / s, (y - 1) / s, (x + bw + 1) / s, (y + bh + 1) / s
                radius = max(1.0, 0.5 * max(x1 - x0, y1 - y0) - 0.5 * (kernel_size - 1) / s)
                if radius >= min_radius:
                    peak = float(tophat[y:y + bh, x:x + bw][labels[y:y + bh, x:x + bw] == i].max())
                    found.append((peak, radius, (x0, y0, x1, y1)))
            found.sort(reverse=True)  # brightest first: a web of caustics or glow must not crowd the LEDs out
            for _, radius, (x0, y0, x1, y1) in found[: c.max_candidates]:
                margin = 0.25 * radius + 12 + 0.5 * kernel_size / s
                box = (
                    max(0, int(x0 - margin)),
                    max(0, int(y0 - margin)),
                    min(w, int(math.ceil(x1 + margin))),
                    min(h, int(math.ceil(y1 + margin))),
                )
                if not _covered(box, radius, boxes):
                    boxes.append((box, radius))
        return boxes

    # ------------------------------------------------------------------ stage 2
    def _refine(
        self, image: np.ndarray, box: tuple[int, int, int, int], radius_estimate: float, rejected: list[str]
    ) -> list[_Region]:
        c = self.config
        x0, y0, x1, y1 = box
        scale = min(1.0, c.refine_radius_px / max(radius_estimate, 1.0))
        roi = image[y0:y1, x0:x1]
        if scale < 1.0:
            roi = cv2.resize(roi, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        gray = intensity(roi)
        if min(gray.shape) < 4:
            return []
        smooth = bilateral(gray, c.bilateral)
        border = np.concatenate([smooth[0], smooth[-1], smooth[:, 0], smooth[:, -1]])
        background = float(np.median(border))
        noise = max(0.5, 1.4826 * float(np.median(np.abs(border - background))))
        _, peak, _, _ = cv2.minMaxLoc(cv2.GaussianBlur(smooth, (3, 3), 0))
        fraction = self.threshold.fraction_for(radius_estimate / self._lens_scale)
        level = self.threshold.level(background, peak, noise, fraction)
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
        regions: list[_Region] = []
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
    ) -> list[_Region]:
        """Closed regions of one window's mask that pass the gates, in full-resolution units."""
        x0, y0 = origin
        contours, hierarchy = cv2.findContours(mask, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
        if hierarchy is None:
            return []
        min_radius_full = self._min_radius_px()
        selection = self.config.selection
        regions: list[_Region] = []
        outlines: list[tuple[np.ndarray, _Region]] = []  # every closed outline, a candidate of its own
        dot_of: dict[int, int] = {}  # outline -> its index among the blobs without a hole
        dots: list[_Dot] = []
        for idx, contour in enumerate(contours):
            if hierarchy[0][idx][3] != -1:
                continue  # a hole; handled with its outer contour
            area = _pixel_area(contour)
            hole = _largest_child(contours, hierarchy[0], idx)
            hole_area = _pixel_area(hole) - cv2.arcLength(hole, True) if hole is not None else 0.0
            pts = contour[:, 0, :]
            support = float(np.count_nonzero(near_edge[pts[:, 1], pts[:, 0]])) / len(pts)
            if hole_area < selection.min_hole_fraction * area:
                dot_of[len(outlines)] = len(dots)
                dots.append((pts, area, support))
            outer_full = _to_full(pts, scale, x0, y0)
            if _on_border(outer_full, frame_size).any():  # the shape the frame left, not the cut one
                axis_ratio, arc_deg = self._cut_shape(outer_full, frame_size)
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
            hole_full = _to_full(hole[:, 0, :], scale, x0, y0) if hole is not None else None
            outlines.append((contour, _Region(shape, level, outer_full, hole_full)))
        in_rings: set[int] = set()
        for ring in _dot_rings(dots):
            outline_full = _to_full(ring.outline, scale, x0, y0)
            if ring.led_centers is None and _on_border(outline_full, frame_size).any():
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
            centers = None if ring.led_centers is None else _to_full(ring.led_centers, scale, x0, y0)
            region = _Region(shape, level, outline_full, None, dotted=True, led_centers=centers)
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
                ellipse_residual=self._outline_residual(region.outer, frame_size))
            self._keep(region, min_radius_full, regions, rejected)
        return regions

    def _keep(self, region: _Region, min_radius_px: float, regions: list[_Region], rejected: list[str]) -> bool:
        """Add the region if it passes the gates, else note why not; whether it was added."""
        reason = rejection_reason(region.shape, self.config.selection, min_radius_px)
        if reason is None:
            regions.append(region)
        else:
            rejected.append(reason)
        return reason is None

    def _min_radius_px(self) -> float:
        focal = self.camera.focal_px if self.camera is not None else 0.0
        return focal * self.config.marker_radius_m / self.config.max_range_m

    # ------------------------------------------------------------------ fit
    def _fit(self, region: _Region, candidates: int, frame_size: tuple[int, int]) -> Detection:
        (mu, mv), mr = cv2.minEnclosingCircle(region.outer.astype(np.float32))
        common: dict[str, Any] = dict(
            found=True, threshold=region.threshold, candidates=candidates,
            mec_u=float(mu), mec_v=float(mv), mec_radius_px=float(mr),
        )
        cut = bool(_on_border(region.outer, frame_size).any())
        if cut and region.led_centers is not None:  # LED centres lie on the ring itself
            outer_fit = self._fit_ellipse(region.led_centers, circle=True)
        else:
            outer_fit = self._fit_ellipse(_longest_inner_run(region.outer, frame_size), circle=cut)
        if outer_fit is None:  # too little of the outline is usable (image border, lens fold)
            return Detection(u=float(mu), v=float(mv), radius_px=float(mr), **common)
        outer = outer_fit[0]
        common["fit_sigma"] = outer_fit[1]
        if cut:  # part of a ring tells its bearing, not its tilt: no ring reading
            common["visible_arc_deg"] = self._cut_shape(region.outer, frame_size)[1]
            return self._circle_detection(outer, common)
        inner, cue_noise = None, 0.0
        if region.hole is not None and is_ring(region.shape, self.config.selection):
            inner_fit = self._fit_ellipse(region.hole)
            if inner_fit is not None and inner_fit[0].semi_major < outer.semi_major:
                inner = inner_fit[0]
                cue_noise = math.hypot(inner_fit[1], outer_fit[1])
                common["fit_sigma"] = 0.5 * cue_noise  # the centre line is the mean of the two outlines
        marker_radius = self.config.marker_radius_m
        if inner is None and not region.dotted:  # a solid blob: its outline is all we have
            return self._circle_detection(outer, common)
        if inner is None:  # separate LEDs: their outlines straddle the centre line
            centre_line = outer
            solution = ring_center_solution(centre_line, marker_radius, led_points=self._led_points(region))
        else:  # a continuous strip: the centre line lies midway between its two outlines
            centre_line = Ellipse(
                center_x=0.5 * (outer.center_x + inner.center_x),
                center_y=0.5 * (outer.center_y + inner.center_y),
                semi_major=0.5 * (outer.semi_major + inner.semi_major),
                semi_minor=0.5 * (outer.semi_minor + inner.semi_minor),
                angle_rad=outer.angle_rad,
            )
            solution = ring_center_solution(centre_line, marker_radius, outer, inner, cue_noise)
        if solution is None:
            pose = pose_from_circle((centre_line.center_x, centre_line.center_y), centre_line.semi_major, marker_radius)
            normal = None
        else:
            pose = pose_from_point(solution[0])
            axis = solution[1]
            normal = None if axis is None else (float(axis[0]), float(axis[1]), float(axis[2]))
        x, y = pose.offset_x_m / pose.range_m, pose.offset_y_m / pose.range_m
        u, v, focal = self._center_pixels(x, y)
        return Detection(
            u=u, v=v, radius_px=centre_line.semi_major * focal, is_ring=True, ellipse=centre_line,
            pose=pose, ring_normal=normal, **common,
        )

    def _circle_detection(self, outline: Ellipse, common: dict[str, Any]) -> Detection:
        """The paper's reading of an outline: its centre, and the range from its largest radius."""
        u, v, focal = self._center_pixels(outline.center_x, outline.center_y)
        return Detection(
            u=u, v=v, radius_px=outline.semi_major * focal, ellipse=outline, **common,
            pose=pose_from_circle((outline.center_x, outline.center_y), outline.semi_major,
                                  self.config.marker_radius_m),
        )

    def _outline_residual(self, points_px: np.ndarray, frame_size: tuple[int, int], samples: int = 96) -> float:
        """How far an outline is from an ellipse: rms radial distance / mean radius (0 when unknown).

        On the undistorted plane, where a circle seen from any angle is an ellipse (the lens
        bends a large ring near the frame's edge away from one). Points on the frame's
        border are left out, and of a strip the frame cuts open only its longer (outer) edge
        counts: a ring cut by the edge is still an ellipse.
        """
        points = self._undistorted(_longest_inner_run(points_px, frame_size), samples)
        if len(points) < 8:
            return 0.0
        ellipse = _ellipse_through(points)
        if ellipse is None:
            return 0.0
        size = math.sqrt(ellipse.semi_major * ellipse.semi_minor)
        residual = _radial_residual(ellipse, points.astype(np.float64)) / size
        return float(np.sqrt(np.mean(residual * residual)))

    def _cut_shape(self, points_px: np.ndarray, frame_size: tuple[int, int], samples: int = 96) -> tuple[float, float]:
        """(axis ratio of its ellipse, degrees of a circle it covers) of the longest stretch of
        an outline off the frame's border: the shape of what the frame left of a ring."""
        points = self._undistorted(_longest_inner_run(points_px, frame_size), samples)
        if len(points) < 8:
            return 0.0, 0.0
        ellipse = _ellipse_through(points)
        ratio = ellipse.semi_minor / ellipse.semi_major if ellipse is not None else 0.0
        return ratio, _arc_degrees(points)

    def _undistorted(self, points_px: np.ndarray, samples: int) -> np.ndarray:
        """About ``samples`` of the points on the normalized plane, in focal-length pixels."""
        points = points_px[:: max(1, len(points_px) // samples)]
        if self.camera is None:
            return points.astype(np.float64)
        xy, valid = self.camera.pixels_to_normalized(points)
        return xy[valid] * self.camera.focal_px

    def _led_points(self, region: _Region) -> np.ndarray | None:
        """LED image centres on the normalized plane (those that undistort validly)."""
        if region.led_centers is None or self.camera is None:
            return None
        xy, valid = self.camera.pixels_to_normalized(region.led_centers)
        return xy[valid]

    def _center_pixels(self, x: float, y: float) -> tuple[float, float, float]:
        """A normalized point as distorted image pixels, and the focal length used."""
        if self.camera is None:
            return x, y, 1.0
        uv = self.camera.normalized_to_pixels(np.array([x, y]))
        return float(uv[0]), float(uv[1]), self.camera.focal_px

    def _fit_ellipse(self, points_px: np.ndarray | None, circle: bool = False) -> tuple[Ellipse, float] | None:
        """Ellipse through outline points on the normalized plane (pixel plane without a camera),
        and the standard error of its centre (normalized units).

        ``circle``: fit a circle instead, for an arc the frame cut; five ellipse parameters
        from half an outline wander (the radius, hence the range, by tens of percent).

        Outline errors are correlated along the outline (scallops of separate LEDs, pixel
        steps), so the points count as one independent sample per few pixels of outline.
        """
        if points_px is None:
            return None
        if self.camera is not None:
            inside = ~_on_border(points_px, (self.camera.height, self.camera.width))
            xy, valid = self.camera.pixels_to_normalized(points_px[inside])
            xy = xy[valid]
            focal = self.camera.focal_px
        else:
            xy, focal = points_px.astype(float), 1.0
        if len(xy) < (5 if circle else 8):
            return None
        if circle:
            ellipse: Ellipse | None = _circle_through(xy)
        else:
            fitted = _ellipse_through(xy * focal)  # fitted in pixel units, where cv2's tolerances are set
            ellipse = None if fitted is None else Ellipse(
                fitted.center_x / focal, fitted.center_y / focal, fitted.semi_major / focal,
                fitted.semi_minor / focal, fitted.angle_rad)
        if ellipse is None or not (math.isfinite(ellipse.semi_major) and ellipse.semi_minor > 0):
            return None
        residual = _radial_residual(ellipse, xy)
        rms = float(np.sqrt(np.mean(residual * residual)))
        independent = max(4.0, len(xy) / 8.0)
        return ellipse, rms * math.sqrt(2.0 / independent)


def _largest_child(contours: Sequence[np.ndarray], hierarchy: np.ndarray, parent: int) -> np.ndarray | None:
    child = hierarchy[parent][2]
    best, best_area = None, 0.0
    while child != -1:
        area = cv2.contourArea(contours[child])
        if area > best_area:
            best, best_area = contours[child], area
        child = hierarchy[child][0]
    return best


def _to_full(points: np.ndarray, scale: float, x0: int, y0: int) -> np.ndarray:
    """Window pixel indices at ``scale`` -> full-resolution pixel coordinates (pixel centres)."""
    pts = points.astype(np.float64)
    return (pts + 0.5) / scale - 0.5 + np.array([x0, y0], dtype=np.float64)


def _same_region(a: _Region, b: _Region) -> bool:
    """Two windows can overlap and see one region twice."""
    ca, cb = a.outer.mean(axis=0), b.outer.mean(axis=0)
    return float(np.hypot(*(ca - cb))) < 0.3 * max(a.shape.radius_px, b.shape.radius_px)


def _covered(box: tuple[int, int, int, int], radius: float,
             boxes: list[tuple[tuple[int, int, int, int], float]]) -> bool:
    """A window adds nothing when another nearly the same, or one at most twice as large that
    contains it, is already refined."""
    return any(
        _overlap(box, other) > 0.7
        or (other[0] <= box[0] and other[1] <= box[1] and other[2] >= box[2] and other[3] >= box[3]
            and other_radius <= 2.0 * radius)
        for other, other_radius in boxes
    )


def _overlap(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> float:
    """Intersection over union of two boxes (x0, y0, x1, y1)."""
    ix = max(0, min(a[2], b[2]) - max(a[0], b[0]))
    iy = max(0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = ix * iy
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / union if union > 0 else 0.0


def _pixel_area(contour: np.ndarray) -> float:
    """Pixels inside an outline, counted so that a one-pixel blob has area 1, not 0."""
    return cv2.contourArea(contour) + 0.5 * cv2.arcLength(contour, True) + 1.0


_Dot = tuple[np.ndarray, float, float]  # outline (N, 2), area, edge support


class _SegmentRing(NamedTuple):
    """Separate LEDs, or arcs, of one ring among a window's blobs (window pixels)."""

    members: tuple[int, ...]  # the blobs it is made of
    outline: np.ndarray  # all their outline points
    led_centers: np.ndarray | None  # None for arcs
    edge_support: float
    area: float  # of the ellipse through them
    axis_ratio: float
    center_row: float
    residual: float  # rms distance from the ellipse relative to its size


def _dot_rings(dots: list[_Dot], min_dots: int = 6) -> list[_SegmentRing]:
    """Rings of separate LEDs, or of arcs, among the blobs of one window, one per chain of neighbours.

    Blobs are chained when they come closer than 2.5 typical neighbour gaps, so a ring
    and its reflection, or a ring and a lamp cluster, are fitted apart, while LEDs that
    motion blur smeared together still chain.
    """
    clusters = [list(range(len(dots)))] if len(dots) == 1 else _chains(dots)
    rings = []
    for members in clusters:
        group = [dots[m] for m in members]
        ring = _dot_ring(group, min_dots) or _arc_ring(group)
        if ring is not None:
            rings.append(ring._replace(members=tuple(members[m] for m in ring.members)))
    return rings


def _chains(dots: list[_Dot], max_dots: int = 300) -> list[list[int]]:
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
    chains: list[list[int]] = []
    for start in range(len(order)):
        if chain[start] >= 0:
            continue
        chain[start] = len(chains)
        members, todo = [], [start]
        while todo:
            i = todo.pop()
            members.append(order[i])
            for j in np.flatnonzero(linked[i]):
                if chain[j] < 0:
                    chain[j] = chain[start]
                    todo.append(int(j))
        chains.append(members)
    return chains


def _dot_ring(dots: list[_Dot], min_dots: int) -> _SegmentRing | None:
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
    return _SegmentRing(
        members=tuple(members), outline=np.concatenate([dots[m][0] for m in members]),
        led_centers=centroids[members], edge_support=float(np.mean([dots[m][2] for m in members])),
        area=math.pi * d1 * d2 / 4.0,
        axis_ratio=min(d1, d2) / max(d1, d2), center_row=float(cy), residual=rms,
    )


def _arc_ring(dots: list[_Dot], min_coverage: float = 0.6) -> _SegmentRing | None:
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
    ellipse = _ellipse_through(points)
    if ellipse is None or ellipse.semi_minor <= 1.0:
        return None
    a, b = ellipse.semi_major, ellipse.semi_minor
    offset = np.abs(_radial_residual(ellipse, points)) / math.sqrt(a * b)
    area = sum(d[1] for d in dots)
    ellipse_area = math.pi * a * b
    angles = np.arctan2(points[:, 1] - ellipse.center_y, points[:, 0] - ellipse.center_x)
    covered = len(set(((angles + math.pi) / (2 * math.pi) * 36).astype(int) % 36)) / 36.0
    if area > 0.5 * ellipse_area or float(np.mean(offset)) > 0.25 or covered < min_coverage:
        return None
    return _SegmentRing(
        members=tuple(range(len(dots))), outline=points.astype(np.int32), led_centers=None,
        edge_support=float(np.mean([d[2] for d in dots])), area=ellipse_area, axis_ratio=b / a,
        center_row=float(ellipse.center_y), residual=float(np.std(offset)),
    )


def _mean_level(smooth: np.ndarray, mask: np.ndarray, contours: list[np.ndarray]) -> float:
    """Mean grey level of the segmented pixels inside these outlines (holes excluded)."""
    x, y, w, h = cv2.boundingRect(np.concatenate(contours))
    inside = np.zeros((h, w), np.uint8)
    cv2.drawContours(inside, contours, -1, 255, -1, offset=(-x, -y))
    inside &= mask[y:y + h, x:x + w]
    return float(cv2.mean(smooth[y:y + h, x:x + w], mask=inside)[0])


def _on_border(points: np.ndarray, frame_size: tuple[int, int]) -> np.ndarray:
    """Which full-resolution points lie on the frame's outermost pixels."""
    h, w = frame_size
    return (points[:, 0] <= 1.0) | (points[:, 0] >= w - 2.0) | (points[:, 1] <= 1.0) | (points[:, 1] >= h - 2.0)


def _longest_inner_run(outline: np.ndarray, frame_size: tuple[int, int]) -> np.ndarray:
    """The longest stretch of a closed outline between visits to the frame's border.

    A strip the frame cuts is outlined by its outer edge, the border, its inner edge and
    the border again: two concentric arcs no single ellipse fits. The outer one is the
    longer. An outline that never touches the border is returned whole.
    """
    inside = ~_on_border(outline, frame_size)
    if inside.all() or not inside.any():
        return outline[inside]
    start = int(np.argmin(inside))  # roll so the outline begins on the border: runs do not wrap
    rolled, flags = np.roll(outline, -start, axis=0), np.roll(inside, -start)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], flags.astype(np.int8), [0]))))
    starts, ends = edges[0::2], edges[1::2]
    longest = int(np.argmax(ends - starts))
    return rolled[starts[longest]:ends[longest]]


def _ellipse_through(points: np.ndarray) -> Ellipse | None:
    """cv2.fitEllipse as an Ellipse (semi-axes, angle of the major axis); None when degenerate."""
    (cx, cy), (d1, d2), angle = cv2.fitEllipse(points.astype(np.float32))
    if not (min(d1, d2) > 0 and math.isfinite(d1 + d2)):
        return None
    return Ellipse(cx, cy, max(d1, d2) / 2.0, min(d1, d2) / 2.0,
                   math.radians(angle) if d1 >= d2 else math.radians(angle + 90.0))


def _circle_through(xy: np.ndarray) -> Ellipse:
    """Least-squares circle (Kasa's algebraic fit) as an ellipse with equal axes."""
    a = np.column_stack([2.0 * xy, np.ones(len(xy))])
    b = (xy * xy).sum(axis=1)
    (cx, cy, c), *_ = np.linalg.lstsq(a, b, rcond=None)
    radius = math.sqrt(max(0.0, c + cx * cx + cy * cy))
    return Ellipse(float(cx), float(cy), radius, radius, 0.0)


def _arc_degrees(xy: np.ndarray) -> float:
    """How much of its least-squares circle an open outline covers, in degrees."""
    circle = _circle_through(xy)
    angles = np.sort(np.arctan2(xy[:, 1] - circle.center_y, xy[:, 0] - circle.center_x))
    gaps = np.diff(np.concatenate((angles, [angles[0] + 2.0 * math.pi])))
    return math.degrees(2.0 * math.pi - float(gaps.max()))


def _radial_residual(ellipse: Ellipse, xy: np.ndarray) -> np.ndarray:
    """Approximate distance of points from an ellipse, in the ellipse's units."""
    c, s = math.cos(ellipse.angle_rad), math.sin(ellipse.angle_rad)
    rel = xy - (ellipse.center_x, ellipse.center_y)
    xr = (rel[:, 0] * c + rel[:, 1] * s) / ellipse.semi_major
    yr = (-rel[:, 0] * s + rel[:, 1] * c) / ellipse.semi_minor
    rho = np.hypot(xr, yr)
    return (rho - 1.0) * np.sqrt(ellipse.semi_major * ellipse.semi_minor)


class PaperBaseline(Detector):
    """The paper's pipeline applied literally to the whole full-resolution frame.

    Bilateral filter (d = 9) and improved Canny over all 1920x1080 pixels, the adaptive
    threshold, closed contours, largest/lowest choice and the same fits: the reference
    that `auv-dock bench` measures our search-and-refine and tracking modes against,
    for speed and for agreement.
    """

    def __init__(self, camera: CameraModel | None = None, config: DetectorConfig = DetectorConfig()) -> None:
        literal = dataclasses.replace(
            config, refine_radius_px=1e9, tracking=False,
            bilateral=BilateralParams(diameter=9, sigma_color=config.bilateral.sigma_color,
                                      sigma_space=config.bilateral.sigma_space),
        )
        super().__init__(camera, literal)

    def detect(self, image: np.ndarray) -> Detection:
        image = self._checked(image)
        h, w = image.shape[:2]
        radius = self._last.radius_px if self._last is not None else \
            self.config.threshold.reference_radius_px * self._lens_scale
        detection = self._detect_in(image, [((0, 0, w, h), radius)])
        self._remember(detection)
        return detection
