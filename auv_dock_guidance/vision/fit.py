"""Fit where a circle is a circle: the chosen region's ellipse on the normalized plane, and the
ring's centre, range and bearing from it.

For a continuous strip an ellipse is fitted to its outer and to its inner outline; their
mean is the LED centre line, unbiased by halo or threshold. A lit funnel as bright as the
strip on one side fills part of the hole: its outline then fits an ellipse many times worse
than the outer one does and would squash the centre line (a head-on ring read 20-30 deg
tilted). The outer ellipse, scaled to where most of the hole's outline lies, is then the
inner outline, unless that hole is small: a funnel lit all round leaves only its dark hub
and struts, and the blob is read as a solid one. For separate LEDs or arcs the
ellipse goes through all their outlines. A ring the frame cuts gets a circle through
what is visible (LED centres, or the strip's outer edge): the bearing that turns the
vehicle towards it, and a rougher range. A solid blob (a hole a lit funnel filled) has
only its outline, but that too is read in perspective: seen off the optical axis it is
stretched outwards by 1/cos(bearing), and the paper's z = R / r read it short. The
tilt-aware centre comes from `geometry/pose.py` (`ring_center_solution`).
"""

from __future__ import annotations

import math
from typing import Any

import cv2
import numpy as np

from auv_dock_guidance.geometry.camera import CameraModel
from auv_dock_guidance.geometry.pose import Ellipse, MarkerPose, pose_from_circle, pose_from_point, ring_center_solution
from auv_dock_guidance.vision.config import DetectorConfig
from auv_dock_guidance.vision.detection import Detection
from auv_dock_guidance.vision.normalized import center_pixels, cut_shape, fit_ellipse, normalized_points, plane_points
from auv_dock_guidance.vision.outline import longest_inner_run, on_border
from auv_dock_guidance.vision.refine import Region
from auv_dock_guidance.vision.selection import is_ring

_MAX_INNER_MISFIT = 2.5  # an inner outline fitting an ellipse this many times worse than the outer is not the edge
_INNER_EDGE_QUANTILE = 0.75  # of the hole's outline, relative to the outer ellipse: a filled part lies further in
_MIN_UNFILLED_HOLE = 0.2  # of the outline's area: a smaller misfitting hole is the lit funnel's hub and struts


def fit_region(region: Region, candidates: int, frame_size: tuple[int, int], camera: CameraModel | None,
               config: DetectorConfig) -> Detection:
    """The Detection of the chosen region."""
    (mu, mv), mr = cv2.minEnclosingCircle(region.outer.astype(np.float32))
    common: dict[str, Any] = dict(
        found=True, threshold=region.threshold, candidates=candidates,
        mec_u=float(mu), mec_v=float(mv), mec_radius_px=float(mr),
        range_approximate=camera is not None and camera.approximate,
    )
    cut = bool(on_border(region.outer, frame_size).any())
    if cut and region.led_centers is not None:  # LED centres lie on the ring itself
        outer_fit = fit_ellipse(camera, region.led_centers, circle=True)
    else:
        outer_fit = fit_ellipse(camera, longest_inner_run(region.outer, frame_size), circle=cut)
    if outer_fit is None:  # too little of the outline is usable (image border, lens fold)
        return Detection(u=float(mu), v=float(mv), radius_px=float(mr), **common)
    outer = outer_fit[0]
    common["fit_sigma"] = outer_fit[1]
    marker_radius = config.marker_radius_m
    if cut:  # part of a ring tells its bearing, not its tilt: no ring reading
        common["visible_arc_deg"] = cut_shape(camera, region.outer, frame_size)[1]
        return circle_detection(camera, outer, marker_radius, common)
    inner, inner_scale, cue_noise = None, None, 0.0
    if region.hole is not None and is_ring(region.shape, config.selection):
        inner_fit = fit_ellipse(camera, region.hole)
        if inner_fit is not None and inner_fit[0].semi_major < outer.semi_major:
            if inner_fit[1] <= _MAX_INNER_MISFIT * outer_fit[1]:
                inner = inner_fit[0]
                cue_noise = math.hypot(inner_fit[1], outer_fit[1])
                common["fit_sigma"] = 0.5 * cue_noise  # the centre line is the mean of the two outlines
            elif region.shape.hole_fraction >= _MIN_UNFILLED_HOLE:  # a lit funnel filled part of the hole
                inner_scale = inner_edge_scale(outer, plane_points(camera, region.hole))
    if inner_scale is not None:  # the outer outline's shape, midway to the hole's edge; its centre offset tells nothing
        centre_line = scaled(outer, 0.5 * (1.0 + inner_scale))
        solution = ring_center_solution(centre_line, marker_radius)
    elif inner is None and not region.dotted:  # a solid blob: its outline, seen in perspective, is all we have
        solution = ring_center_solution(outer, marker_radius)
        if solution is None:
            return circle_detection(camera, outer, marker_radius, common)
        return _detection_at(pose_from_point(solution[0]), outer, camera, common)
    elif inner is None:  # separate LEDs: their outlines straddle the centre line
        centre_line = outer
        solution = ring_center_solution(centre_line, marker_radius,
                                        led_points=normalized_points(camera, region.led_centers))
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
    return _detection_at(pose, centre_line, camera, common, is_ring=True, ring_normal=normal)


def _detection_at(pose: MarkerPose, outline: Ellipse, camera: CameraModel | None, common: dict[str, Any],
                  **reading: Any) -> Detection:
    """A Detection of a marker centre found in 3-D: its image where that centre projects."""
    u, v, focal = center_pixels(camera, pose.offset_x_m / pose.range_m, pose.offset_y_m / pose.range_m)
    return Detection(u=u, v=v, radius_px=outline.semi_major * focal, ellipse=outline, pose=pose, **common, **reading)


def circle_detection(camera: CameraModel | None, outline: Ellipse, marker_radius_m: float,
                     common: dict[str, Any]) -> Detection:
    """The paper's reading of an outline: its centre, and the range from its largest radius."""
    u, v, focal = center_pixels(camera, outline.center_x, outline.center_y)
    return Detection(
        u=u, v=v, radius_px=outline.semi_major * focal, ellipse=outline, **common,
        pose=pose_from_circle((outline.center_x, outline.center_y), outline.semi_major, marker_radius_m),
    )


def scaled(ellipse: Ellipse, factor: float) -> Ellipse:
    """The ellipse grown or shrunk about its centre: a concentric circle on the same plane, nearly."""
    return Ellipse(ellipse.center_x, ellipse.center_y, ellipse.semi_major * factor, ellipse.semi_minor * factor,
                   ellipse.angle_rad)


def inner_edge_scale(outer: Ellipse, points: np.ndarray) -> float | None:
    """The strip's inner edge as a share of the outer ellipse: where most of the hole's outline
    lies, since the part a lit funnel filled lies further in. None when the hole is not inside."""
    if len(points) < 8:
        return None
    c, s = math.cos(outer.angle_rad), math.sin(outer.angle_rad)
    d = points - np.array([outer.center_x, outer.center_y])
    size = np.hypot((d[:, 0] * c + d[:, 1] * s) / outer.semi_major, (-d[:, 0] * s + d[:, 1] * c) / outer.semi_minor)
    factor = float(np.quantile(size, _INNER_EDGE_QUANTILE))
    return factor if 0.0 < factor < 1.0 else None
