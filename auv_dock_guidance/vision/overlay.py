"""The debug picture for the shore laptop: small, annotated, JPEG."""

from __future__ import annotations

import cv2
import numpy as np

from auv_dock_guidance.vision.detection import Detection


def overlay_jpeg(image: np.ndarray, detection: Detection, principal: tuple[float, float], text: str,
                 scale: float = 0.25, quality: int = 70) -> bytes:
    """Downscale first (cheap, and a slow link wants few bytes), then draw and encode."""
    small = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    if small.ndim == 2:
        small = cv2.cvtColor(small, cv2.COLOR_GRAY2BGR)
    cx, cy = (int(round(c * scale)) for c in principal)
    cv2.drawMarker(small, (cx, cy), (0, 0, 255), cv2.MARKER_CROSS, 12, 1)
    if detection.found:
        centre = (int(round(detection.u * scale)), int(round(detection.v * scale)))
        radius = max(1, int(round(detection.radius_px * scale)))
        cv2.circle(small, centre, radius, (0, 255, 0), 1, cv2.LINE_AA)
        cv2.circle(small, centre, 2, (0, 255, 0), -1)
        cv2.line(small, (cx, cy), centre, (0, 200, 255), 1, cv2.LINE_AA)
    cv2.putText(small, text, (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1, cv2.LINE_AA)
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
