"""The LED-ring detector: one camera frame in, one Detection out.

A short orchestrator over the stages, each a module of its own:

1. `search.py`: on a quarter-size copy, the bright regions worth a closer look;
2. `refine.py`: in a window around each, the paper's pipeline (bilateral filter, improved
   Canny, adaptive threshold, closed contours, gates), with rings assembled from separate
   LEDs or arcs by `segments.py`;
3. `selection.py`: the paper's choice among what passed the gates (largest, lowest on ties);
4. `fit.py`: the chosen region fitted where a circle is a circle, and the pose from it.

`Detector` carries the adaptive threshold and the tracked window from frame to frame.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from auv_dock_guidance.errors import ConfigError
from auv_dock_guidance.geometry.camera import ApproximateLens, CameraModel
from auv_dock_guidance.vision.config import DetectorConfig, lens_scale, min_ring_radius_px
from auv_dock_guidance.vision.detection import Detection
from auv_dock_guidance.vision.edges import BilateralParams
from auv_dock_guidance.vision.fit import fit_region
from auv_dock_guidance.vision.image_input import as_bgr_or_gray8
from auv_dock_guidance.vision.led_count import LedCountVote
from auv_dock_guidance.vision.led_fit import FrameView, LedRingCandidate, find_led_rings, led_detection
from auv_dock_guidance.vision.refine import Refiner, Region, add_region
from auv_dock_guidance.vision.search import Window, search, search_copy
from auv_dock_guidance.vision.selection import choose
from auv_dock_guidance.vision.threshold import AdaptiveThreshold
from auv_dock_guidance.vision.tracking import UNSTAMPED_FRAME_S, SpreadSearch, WindowTracker, in_window

__all__ = ["Detection", "Detector", "DetectorConfig", "PaperBaseline"]

_RESOLVED_SPACING_PX = 4.0  # LEDs closer than this on the search copy cannot be told apart


class Detector:
    """Stateful across the frames of one sequence (the adaptive threshold, the tracked window, the
    dock's LED count when not given); call reset() between."""

    def __init__(self, camera: CameraModel | None = None, config: DetectorConfig = DetectorConfig(),
                 lens: ApproximateLens | None = None) -> None:
        self.camera = camera
        self.lens = lens  # without a calibration: the camera is made from it and the first frame's size
        self.config = config
        self.threshold = AdaptiveThreshold(config.threshold)
        self._last: Detection | None = None  # the previous frame's marker
        self.tracker = WindowTracker()
        self._spread = SpreadSearch()  # the whole frame's search while tracking, a slice per frame
        self._view: FrameView | None = None  # the last whole frame's picture area and water, for windows
        self._frames = 0
        self.led_counts = LedCountVote()  # used only when the config gives no count

    def reset(self) -> None:
        self.threshold.reset()
        self.tracker.reset()
        self._spread.stop()
        self._view = None
        self._last = None
        self._frames = 0
        self.led_counts.reset()

    def detect(self, image: np.ndarray, stamp_s: float | None = None) -> Detection:
        """The marker in one frame; ``stamp_s`` (the frame's time) lets tracking allow for
        skipped frames (without it, frames count as evenly spaced at 30 fps)."""
        image = self._checked(image)
        detection = None
        self._frames += 1
        time_s = self._frames * UNSTAMPED_FRAME_S if stamp_s is None else stamp_s
        window = self.tracker.window(image.shape[:2], time_s, self.config.track_window_radii) \
            if self.config.tracking else None
        if window is not None:
            if self._frames % self.config.full_search_every == 0 and not self._spread.busy:
                self._spread.start(self.config, self._lens_scale, self._min_radius_px)
            candidates, copy = self._spread.step(image, window)
            rings = self._led_rings(image, copy) if copy is not None else self._led_rings_in(image, window)
            detection = self._detect_in(image, [window, *candidates], rings)
            if not detection.found:
                detection = None  # lost: search the whole frame
            elif not in_window(detection, window):
                self.tracker.reset()  # another candidate won: its track starts afresh, without a velocity
        if detection is None:
            self._spread.stop()
            copy = search_copy(image, self.config, self._lens_scale)
            windows = search(image, self.config, self._lens_scale, self._min_radius_px, copy)
            detection = self._detect_in(image, windows, self._led_rings(image, copy))
        self._remember(detection, time_s)
        return self._counted(detection)

    def _likely_count(self) -> int | None:
        """The count this frame's rings are assembled at (with its neighbours), when the config gives none:
        the learned one, except on one frame in ``all_counts_every``, which tries every count. Only
        those frames vote, so a count settled on a misreading far out (six of eleven LEDs, every other
        one, before the ring is resolved) gives way to the dock's once it shows, instead of keeping
        the search to itself."""
        if self.config.led_count is not None or self._frames % self.config.all_counts_every == 0:
            return None
        return self.led_counts.count

    def _counted(self, detection: Detection) -> Detection:
        """A whole ring of LEDs votes for the dock's count (when it is not given and the frame tried
        every count); one of another count than the dock's is marked (``count_disputed``)."""
        if self.config.led_count is not None or not detection.led_count or detection.visible_arc_deg < 360.0:
            return detection
        if self._likely_count() is None:
            self.led_counts.add(detection.led_count)
        if not self.led_counts.disputes(detection.led_count):
            return detection
        return dataclasses.replace(detection, count_disputed=True)

    def fit_camera(self, width: int, height: int) -> str | None:
        """Follow images that are a uniform resize of the camera model (binned, scaled down
        for recording), or make the approximate camera for them; returns what changed, for
        the caller to say once, or None.

        Raises CameraModelError when the size cannot come from this camera.
        """
        camera = self.camera
        if camera is None and self.lens is not None:
            self.camera = made = self.lens.camera_for(width, height)
            return (f"no calibration: approximate camera for {width}x{height} frames, focal length "
                    f"{made.fx:.0f} px, principal point at the centre, no distortion; ranges are approximate")
        if camera is None or (width, height) == (camera.width, camera.height):
            return None
        self.camera = camera.for_image(width, height)
        return (f"images are {width}x{height}, the camera model {camera.width}x{camera.height}: "
                f"model scaled by {width / camera.width:.4g}")

    def _remember(self, detection: Detection, time_s: float) -> None:
        """Carry a frame's outcome to the next: the threshold share (steered by the ring's size
        as the paper's camera would see it) and the window to track."""
        self.threshold.update(detection.radius_px / self._lens_scale if detection.found else None)
        self._last = detection if detection.found else None
        self.tracker.update(detection, time_s)

    @property
    def _lens_scale(self) -> float:
        return lens_scale(self.camera)

    @property
    def _min_radius_px(self) -> float:
        return min_ring_radius_px(self.config, self.camera)

    def _leds_merge(self, radius_px: float) -> bool:
        """Whether a ring of this radius can be read as an outline: always for a strip or an unknown
        LED count; for N known LEDs only while they come closer than a few pixels of the search
        copy (where no LED can be told from the next), since farther apart they would have been
        assembled as LEDs, and an outline there is one light's glow, a fixture or a reflection."""
        count = self.config.led_count
        if not count:
            return True
        copy_scale = min(1.0, self.config.search_scale / self._lens_scale)
        return 2.0 * math.pi * radius_px * copy_scale / count < _RESOLVED_SPACING_PX

    def _checked(self, image: np.ndarray) -> np.ndarray:
        image = as_bgr_or_gray8(image)
        if self.camera is not None and image.shape[:2] != (self.camera.height, self.camera.width):
            raise ConfigError(
                f"image is {image.shape[1]}x{image.shape[0]} but the camera model is "
                f"{self.camera.width}x{self.camera.height}"
            )
        return image

    def _led_rings(self, image: np.ndarray, copy: tuple[np.ndarray, float]) -> list[LedRingCandidate]:
        """Rings of evenly spaced LEDs in the frame (``copy``: its search copy), unless the
        marker is a continuous strip."""
        if self.config.led_count == 0:
            return []
        self._view = FrameView.of(copy)
        return self._large_enough(find_led_rings(image, copy, self.camera, self.config, self._view,
                                                 likely_count=self._likely_count()))

    def _led_rings_in(self, image: np.ndarray, window: Window) -> list[LedRingCandidate]:
        """Rings of evenly spaced LEDs in a tracking window: the same evidence as in the whole
        frame, at a cost that follows the window's size, not the frame's."""
        if self.config.led_count == 0 or self._view is None:
            return []
        box, _ = window
        copy = search_copy(image, self.config, self._lens_scale, box)
        return self._large_enough(find_led_rings(image, copy, self.camera, self.config, self._view, box[:2],
                                                 self._likely_count()))

    def _large_enough(self, rings: list[LedRingCandidate]) -> list[LedRingCandidate]:
        return [r for r in rings if r.shape.radius_px >= max(self.config.selection.min_radius_px, self._min_radius_px)]

    def _detect_in(self, image: np.ndarray, windows: list[Window],
                   led_rings: list[LedRingCandidate] | None = None) -> Detection:
        """Refine each window, choose among what passed the gates (paper Fig. 5), fit the choice.

        Rings assembled from evenly spaced LEDs are candidates too (of those, the ones with
        about as many LEDs as the best). With the LED count known they are the marker's
        evidence and outlines count only where the LEDs merge (`_leds_merge`); without it they
        compete with the outlines under the paper's rule (largest, lowest on ties).
        """
        rings = led_rings or []
        if rings:
            most = max(len(r.ring.members) for r in rings)
            rings = [r for r in rings if len(r.ring.members) >= 0.75 * most]
        regions: list[Region] = []
        rejected: list[str] = []
        if not (rings and self.config.led_count):
            refiner = Refiner(self.config, self.threshold, self.camera)
            for box, radius_estimate in windows:
                for region in refiner.refine(image, box, radius_estimate, rejected):
                    add_region(regions, region, self.config)
            regions = [r for r in regions if self._leds_merge(r.shape.radius_px)]
        shapes = [r.shape for r in rings] + [r.shape for r in regions]
        best = choose(shapes, self.config.selection)
        if best is None:
            reason = "no bright region" if not windows else "rejected: " + "; ".join(sorted(set(rejected))[:3])
            return Detection(found=False, reason=reason)
        if best < len(rings):
            return led_detection(rings[best], len(shapes), self.camera, self.config)
        return fit_region(regions[best - len(rings)], len(shapes), image.shape[:2], self.camera, self.config)


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

    def detect(self, image: np.ndarray, stamp_s: float | None = None) -> Detection:
        image = self._checked(image)
        h, w = image.shape[:2]
        radius = self._last.radius_px if self._last is not None else \
            self.config.threshold.reference_radius_px * self._lens_scale
        detection = self._detect_in(image, [((0, 0, w, h), radius)])
        self._remember(detection, 0.0)
        return detection
