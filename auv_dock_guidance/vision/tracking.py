"""Where to look next: a window around the marker's predicted position, at a cost set by the
ring's size, not the frame's; and, while tracking, the whole frame's search a slice per frame.

The prediction is the last position moved on by the image-plane velocity of the last two
detections (constant velocity, from the frames' stamps, so a frame skipped in between is
allowed for). The window grows with the ring and with how far the prediction reached.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from auv_dock_guidance.vision.config import DetectorConfig
from auv_dock_guidance.vision.detection import Detection
from auv_dock_guidance.vision.search import BANDS, Copy, SearchSteps, Window, search_steps

MAX_EXTRAPOLATION_S = 0.5  # older detections give a position, not a velocity to follow
UNSTAMPED_FRAME_S = 1.0 / 30.0  # frames without a stamp count as this far apart


@dataclass(frozen=True)
class Sighting:
    """The marker in one frame: image centre and radius (px) and the frame's time (s)."""

    u: float
    v: float
    radius_px: float
    stamp_s: float


class WindowTracker:
    """The window to refine in the next frame, from the marker's recent sightings."""

    def __init__(self, margin_px: float = 24.0) -> None:
        self.margin_px = margin_px  # added to the window's half-width, for small rings
        self._sightings: list[Sighting] = []

    def reset(self) -> None:
        self._sightings.clear()

    def update(self, detection: Detection, stamp_s: float) -> None:
        """Remember a found marker; a lost one ends the track (the next frame searches it all)."""
        if not detection.found:
            self._sightings.clear()
            return
        mec = detection.mec_radius_px if math.isfinite(detection.mec_radius_px) else 0.0
        self._sightings = [*self._sightings[-1:], Sighting(detection.u, detection.v,
                                                           max(detection.radius_px, mec), stamp_s)]

    @property
    def tracking(self) -> bool:
        return bool(self._sightings)

    def predict(self, stamp_s: float) -> Sighting | None:
        """Where the marker should be at ``stamp_s`` (None without a track)."""
        if not self._sightings:
            return None
        last = self._sightings[-1]
        if len(self._sightings) < 2:
            return Sighting(last.u, last.v, last.radius_px, stamp_s)
        first = self._sightings[0]
        span = last.stamp_s - first.stamp_s
        ahead = min(stamp_s - last.stamp_s, MAX_EXTRAPOLATION_S)
        if not (span > 0 and ahead > 0 and span <= MAX_EXTRAPOLATION_S):
            return Sighting(last.u, last.v, last.radius_px, stamp_s)
        k = ahead / span
        return Sighting(last.u + k * (last.u - first.u), last.v + k * (last.v - first.v),
                        max(last.radius_px, last.radius_px + k * (last.radius_px - first.radius_px)), stamp_s)

    def window(self, frame_size: tuple[int, int], stamp_s: float, window_radii: float = 1.5) -> Window | None:
        """(box, radius) around the predicted marker in a frame of ``frame_size`` (h, w), its
        half-width ``window_radii`` ring radii plus room for the motion; None without a track."""
        predicted = self.predict(stamp_s)
        if predicted is None:
            return None
        last = self._sightings[-1]
        moved = math.hypot(predicted.u - last.u, predicted.v - last.v)
        half = window_radii * predicted.radius_px + self.margin_px + 0.5 * moved
        h, w = frame_size
        box = (max(0, int(predicted.u - half)), max(0, int(predicted.v - half)),
               min(w, int(math.ceil(predicted.u + half))), min(h, int(math.ceil(predicted.v + half))))
        if box[2] - box[0] < 2 or box[3] - box[1] < 2:
            return None  # predicted out of the frame: search it all
        return box, predicted.radius_px


class SpreadSearch:
    """The periodic search of the whole frame while tracking, spread over frames so that no
    frame waits for it: a slice of the search (about a millisecond) per frame, then one
    frame for the rings of separate LEDs on its copy, then one of the regions it found per
    frame, each refined beside the tracked window on that frame and chosen between by the
    paper's rule. A better candidate (the real ring, when its reflection took over) then
    takes the track at once."""

    def __init__(self) -> None:
        self._steps: SearchSteps | None = None
        self._copy: Copy | None = None
        self._pending: list[Window] = []

    @property
    def busy(self) -> bool:
        return self._steps is not None or self._copy is not None or bool(self._pending)

    def start(self, config: DetectorConfig, lens_scale: float, min_radius_px: float) -> None:
        self._steps = search_steps(config, lens_scale, min_radius_px, bands=BANDS)
        self._copy, self._pending = None, []
        next(self._steps)

    def stop(self) -> None:
        self._steps, self._copy, self._pending = None, None, []

    def step(self, image: np.ndarray, tracked: Window) -> tuple[list[Window], Copy | None]:
        """Advance by one slice on this frame: the candidate windows to refine on it beside
        the tracked one (none, or one the tracked window does not already hold), and the
        finished search copy on the one frame that looks for LED rings in it."""
        if self._steps is not None:
            try:
                self._steps.send(image)
            except StopIteration as done:
                self._steps = None
                windows, self._copy = done.value
                self._pending = list(windows)
            return [], None
        if self._copy is not None:
            copy, self._copy = self._copy, None
            return [], copy
        while self._pending:
            window = self._pending.pop(0)
            if not _inside(window, tracked):
                return [window], None
        return [], None


def in_window(detection: Detection, window: Window) -> bool:
    """The detection's centre lies in the window."""
    (x0, y0, x1, y1), _ = window
    return x0 <= detection.u <= x1 and y0 <= detection.v <= y1


def _inside(window: Window, tracked: Window) -> bool:
    """The window's region lies within the tracked window: refining it would find the same."""
    (x0, y0, x1, y1), _ = window
    (tx0, ty0, tx1, ty1), _ = tracked
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    return tx0 <= cx <= tx1 and ty0 <= cy <= ty1 and (x1 - x0) <= 1.5 * (tx1 - tx0)
