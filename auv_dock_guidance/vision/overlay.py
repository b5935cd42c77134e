"""Pictures of what the detector found: the shore laptop's small JPEG, annotated frames and
a contact sheet of a whole run."""

from __future__ import annotations

import math

import cv2
import numpy as np

from auv_dock_guidance.vision.detection import Detection

_FOUND, _PARTIAL, _LEDS, _AIM, _TEXT = (0, 255, 0), (0, 200, 255), (255, 0, 255), (0, 200, 255), (255, 255, 255)


def draw_detection(canvas: np.ndarray, detection: Detection, scale: float = 1.0,
                   principal: tuple[float, float] | None = None) -> None:
    """Draw the ring's circle, its LED centroids and centre (and the line from the image centre)
    on a BGR canvas that is the frame scaled by ``scale``."""
    if principal is not None:
        cx, cy = (int(round(c * scale)) for c in principal)
        cv2.drawMarker(canvas, (cx, cy), (0, 0, 255), cv2.MARKER_CROSS, 12, 1)
    if not detection.found:
        return
    colour = _PARTIAL if detection.partial else _FOUND
    if math.isfinite(detection.u) and math.isfinite(detection.v):
        centre = (int(round(detection.u * scale)), int(round(detection.v * scale)))
        if math.isfinite(detection.radius_px):
            cv2.circle(canvas, centre, max(1, int(round(detection.radius_px * scale))), colour, 1, cv2.LINE_AA)
        cv2.drawMarker(canvas, centre, colour, cv2.MARKER_TILTED_CROSS, max(6, int(16 * scale)), 2)
        if principal is not None:
            cv2.line(canvas, (cx, cy), centre, _AIM, 1, cv2.LINE_AA)
    for u, v in detection.leds:
        cv2.circle(canvas, (int(round(u * scale)), int(round(v * scale))), max(3, int(round(6 * scale))), _LEDS, 1,
                   cv2.LINE_AA)


def annotated(image: np.ndarray, detection: Detection, label: str = "", scale: float = 1.0) -> np.ndarray:
    """A BGR copy of the frame (or of a copy of it at ``scale``) with the detection drawn on it and
    a caption: what was found (range, LEDs, partial), or why nothing was."""
    canvas = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
    draw_detection(canvas, detection, scale)
    if detection.found:
        text = f"found r={detection.radius_px:.0f}px"
        if detection.pose is not None:
            text += f" {detection.pose.range_m:.2f}m{'~' if detection.range_approximate else ''}"
        if detection.leds:
            text += f" {len(detection.leds)}/{detection.led_count} LEDs"
        if detection.partial:
            text += " partial"
    else:
        text = f"not found: {detection.reason}"
    size = max(0.3, canvas.shape[1] / 1600.0)
    for row, line in enumerate(filter(None, (label, text))):
        origin = (6, int(22 * size / 0.4 * (row + 1) * 0.9))
        cv2.putText(canvas, line, origin, cv2.FONT_HERSHEY_SIMPLEX, size, (0, 0, 0), 3, cv2.LINE_AA)
        cv2.putText(canvas, line, origin, cv2.FONT_HERSHEY_SIMPLEX, size, _TEXT, 1, cv2.LINE_AA)
    return canvas


def contact_sheet(tiles: list[np.ndarray], width_px: int = 3200) -> np.ndarray:
    """The frames of a run in rows, each scaled to one tile size, about ``width_px`` wide."""
    if not tiles:
        raise ValueError("a contact sheet needs at least one frame")
    columns = max(1, min(len(tiles), math.ceil(math.sqrt(1.5 * len(tiles)))))
    tile_w = max(80, width_px // columns)
    h0, w0 = tiles[0].shape[:2]
    tile_h = max(1, round(tile_w * h0 / w0))
    rows = math.ceil(len(tiles) / columns)
    sheet = np.zeros((rows * tile_h, columns * tile_w, 3), np.uint8)
    for i, tile in enumerate(tiles):
        small = cv2.resize(tile, (tile_w, tile_h), interpolation=cv2.INTER_AREA)
        if small.ndim == 2:
            small = cv2.cvtColor(small, cv2.COLOR_GRAY2BGR)
        r, c = divmod(i, columns)
        sheet[r * tile_h:(r + 1) * tile_h, c * tile_w:(c + 1) * tile_w] = small
    return sheet


def overlay_jpeg(image: np.ndarray, detection: Detection, principal: tuple[float, float], text: str,
                 scale: float = 0.25, quality: int = 70) -> bytes:
    """Downscale first (cheap, and a slow link wants few bytes), then draw and encode."""
    small = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    if small.ndim == 2:
        small = cv2.cvtColor(small, cv2.COLOR_GRAY2BGR)
    draw_detection(small, detection, scale, principal)
    cv2.putText(small, text, (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, _TEXT, 1, cv2.LINE_AA)
    ok, data = cv2.imencode(".jpg", small, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    return data.tobytes() if ok else b""


def overlay_text(detection: Detection, share: float | None = None) -> str:
    """The overlay's line: found or searching, the threshold (and its share), range and bearing."""
    text = f"{'FOUND' if detection.found else 'SEARCH'} thr {detection.threshold:.0f}"
    if share is not None:
        text += f" share {share:.2f}"
    if detection.pose is not None:
        pose = detection.pose
        text += f" r {pose.range_m:.1f}m yaw {pose.yaw_deg:+.1f} pitch {pose.pitch_deg:+.1f}"
    return text
