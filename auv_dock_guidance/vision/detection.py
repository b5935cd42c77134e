"""What the detector says about one frame."""

from __future__ import annotations

import math
from dataclasses import dataclass

from auv_dock_guidance.geometry.pose import Ellipse, MarkerPose


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
    range_approximate: bool = False  # uncalibrated camera: range and offsets scale with a guessed focal length
    leds: tuple[tuple[float, float], ...] = ()  # centroids of the ring's LEDs (pixels), when assembled from them
    led_count: int = 0  # N of the ring they were assembled into (0: not from LEDs)
    partial: bool = False  # less than half the ring in view (a corner): a bearing more than a position
    bloomed: bool = False  # LEDs merged into one glow: placed by its outline, so the range reads short, no tilt
    count_disputed: bool = False  # LEDs assembled with another count than the dock's (learned): no tilt to trust
