"""What a video chain does to a frame: analogue PAL camera, DVD-style recorder, JPEG stills.

Composite PAL video carries colour at a quarter of the bandwidth of brightness, so hue
bleeds sideways over a few pixels. An interlaced camera takes the even and the odd rows
20 ms apart: when the camera moves, the two fields are shifted and edges comb. A recorder
keeps a band of black blanking at the side of the picture. The recorder's MPEG-2 and the
stills' JPEG code the picture in 8x8 blocks with colour at half resolution both ways
(4:2:0), so at low quality blocks show and colour smears further; one JPEG pass stands in
for each of them. No randomness: a recording is fixed by its settings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class VideoRecording:
    chroma_blur_px: float = 2.0  # horizontal spread of colour (Gaussian sigma, pixels)
    interlace_px: float = 0.0  # horizontal shift of the odd field against the even one (motion in 20 ms)
    letterbox_px: int = 0  # black blanking columns at the left edge
    recorder_quality: int = 0  # JPEG quality standing in for the recorder's MPEG-2 (0: none)
    quality: int = 75  # JPEG quality of the stored frame (0: stored raw)


def record(image: np.ndarray, video: VideoRecording) -> np.ndarray:
    """The BGR uint8 frame as it comes out of the video chain (a new array)."""
    image = image.copy()
    if video.chroma_blur_px > 0.3:
        ycc = cv2.cvtColor(image, cv2.COLOR_BGR2YCrCb)
        width = 2 * math.ceil(3.0 * video.chroma_blur_px) + 1  # along rows only
        for channel in (1, 2):
            ycc[:, :, channel] = cv2.GaussianBlur(ycc[:, :, channel], (width, 1), video.chroma_blur_px)
        image = cv2.cvtColor(ycc, cv2.COLOR_YCrCb2BGR)
    if abs(video.interlace_px) >= 0.25:
        odd = image[1::2]
        shift = np.array([[1.0, 0.0, video.interlace_px], [0.0, 1.0, 0.0]], np.float32)
        image[1::2] = cv2.warpAffine(odd, shift, (odd.shape[1], odd.shape[0]), flags=cv2.INTER_LINEAR,
                                     borderMode=cv2.BORDER_REPLICATE)
    if video.letterbox_px > 0:
        image[:, : video.letterbox_px] = 1
    for quality in (video.recorder_quality, video.quality):
        if quality:
            decoded = cv2.imdecode(cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])[1],
                                   cv2.IMREAD_COLOR)
            assert decoded is not None  # a JPEG we just made
            image = decoded
    return image
