"""The detector's settings (every field is documented in README.md, Detector parameters)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from auv_dock_guidance.errors import ConfigError
from auv_dock_guidance.geometry.camera import PAPER_FOCAL_PX, CameraModel
from auv_dock_guidance.vision.edges import BilateralParams
from auv_dock_guidance.vision.selection import SelectionConfig
from auv_dock_guidance.vision.threshold import ThresholdConfig


@dataclass(frozen=True)
class DetectorConfig:
    """Detector settings; every field is documented in README.md (Detector parameters)."""

    marker_radius_m: float = 0.35  # radius of the LED ring's centre line
    led_count: int | None = None  # LEDs on the ring; 0: a continuous strip; None: not known
    led_bgr: tuple[float, float, float] | None = None  # the LEDs' colour (blue, green, red in 0-1), if known
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
    full_search_every: int = 15  # while tracking, start a search of the whole frame (a slice per frame) this often
    track_window_radii: float = 1.5  # tracking window half-width in ring radii (plus room for motion)
    all_counts_every: int = 10  # LED count learned: every count is tried (and votes) on one frame in this many
    canny_low: float = 0.04  # hysteresis thresholds as shares of the region's contrast, per px
    canny_high: float = 0.10
    threshold: ThresholdConfig = field(default_factory=ThresholdConfig)
    selection: SelectionConfig = field(default_factory=SelectionConfig)

    def __post_init__(self) -> None:
        if not (self.marker_radius_m > 0 and math.isfinite(self.marker_radius_m)):
            raise ConfigError(f"marker_radius_m {self.marker_radius_m} must be a positive number")
        if self.led_count is not None and not (self.led_count == 0 or 4 <= self.led_count <= 360):
            raise ConfigError(f"led_count {self.led_count} must be 0 (a continuous strip) or from 4 to 360")
        if self.led_bgr is not None and (len(self.led_bgr) != 3 or not all(0.0 <= c <= 1.0 for c in self.led_bgr)
                                         or max(self.led_bgr) <= 0.0):
            raise ConfigError(f"led colour {self.led_bgr} must be three shares from 0 to 1 (blue, green, red)")
        if not self.max_range_m > 0:
            raise ConfigError(f"max_range_m {self.max_range_m} must be positive")
        if not 0.05 <= self.search_scale <= 1.0:
            raise ConfigError(f"search_scale {self.search_scale} must be in [0.05, 1]")
        if self.search_background_px < 3 or self.max_candidates < 1 or self.refine_radius_px < 16:
            raise ConfigError("search_background_px >= 3, max_candidates >= 1, refine_radius_px >= 16")
        if self.full_search_every < 1 or self.all_counts_every < 1:
            raise ConfigError(f"full_search_every {self.full_search_every} and all_counts_every "
                              f"{self.all_counts_every} must be at least 1")
        if not 0.5 <= self.track_window_radii <= 20.0:
            raise ConfigError(f"track_window_radii {self.track_window_radii} must be in [0.5, 20]")
        if not 0 < self.canny_low <= self.canny_high:
            raise ConfigError(f"need 0 < canny_low <= canny_high, got {self.canny_low}, {self.canny_high}")


def lens_scale(camera: CameraModel | None) -> float:
    """Apparent sizes through this camera relative to the paper's, whose 1080p frames the
    pixel sizes of the defaults (search copy, LED gaps, threshold reference) are for."""
    return camera.focal_px / PAPER_FOCAL_PX if camera is not None else 1.0


def min_ring_radius_px(config: DetectorConfig, camera: CameraModel | None) -> float:
    """The ring's apparent radius at ``max_range_m`` (0 without a camera)."""
    focal = camera.focal_px if camera is not None else 0.0
    return focal * config.marker_radius_m / config.max_range_m
