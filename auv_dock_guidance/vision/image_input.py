"""Turning whatever a camera, a file or a message delivers into the 8-bit image the detector reads."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np

from auv_dock_guidance.errors import ImageInputError


def as_bgr_or_gray8(image: np.ndarray, source: str = "image") -> np.ndarray:
    """An 8-bit BGR or single-channel view/copy of a camera image.

    Accepted: uint8 or uint16, with 1, 3 or 4 channels (16-bit is scaled down, alpha
    dropped). Anything else raises ImageInputError naming the source and the problem.
    """
    if not isinstance(image, np.ndarray):
        raise ImageInputError(f"{source}: not an image array")
    if image.size == 0 or image.ndim not in (2, 3) or min(image.shape[:2]) < 8:
        raise ImageInputError(f"{source}: empty or too small (shape {image.shape})")
    if image.dtype == np.uint16:
        image = (image >> 8).astype(np.uint8)
    elif image.dtype != np.uint8:
        raise ImageInputError(f"{source}: pixel type {image.dtype} is not supported (use 8- or 16-bit)")
    if image.ndim == 3:
        channels = image.shape[2]
        if channels == 1:
            return image[:, :, 0]
        if channels == 4:
            return image[:, :, :3]
        if channels != 3:
            raise ImageInputError(f"{source}: {channels} channels (expected 1, 3 or 4)")
    return image


def read_image(path: str | Path) -> np.ndarray:
    """Read an image file for detection, with an error that names the file and the problem."""
    path = Path(path)
    if not path.is_file():
        raise ImageInputError(f"{path}: no such file")
    data = np.fromfile(path, dtype=np.uint8)
    if data.size == 0:
        raise ImageInputError(f"{path}: empty file")
    image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ImageInputError(f"{path}: not an image OpenCV can decode")
    return as_bgr_or_gray8(image, str(path))


_CHANNELS = {"bgr8": 3, "rgb8": 3, "mono8": 1, "bgra8": 4, "rgba8": 4, "8UC1": 1, "8UC3": 3}


def image_from_fields(height: int, width: int, encoding: str, step: int, data: Any) -> np.ndarray:
    """A zero-copy numpy view of the fields of a sensor_msgs/Image (BGR or mono; RGB reordered).

    Works with rclpy messages and with rosbags' deserialized ones alike. Raises
    ImageInputError on an encoding, size or step that does not add up.
    """
    channels = _CHANNELS.get(encoding)
    if channels is None:
        raise ImageInputError(f"image encoding {encoding!r} is not supported (use bgr8, rgb8 or mono8)")
    if height == 0 or width == 0:
        raise ImageInputError(f"image is empty ({width}x{height})")
    row = width * channels
    if step < row:
        raise ImageInputError(f"image step {step} is smaller than width x channels = {row}")
    buffer = data.view(np.uint8).ravel() if isinstance(data, np.ndarray) else np.frombuffer(data, dtype=np.uint8)
    if buffer.size < step * height:
        raise ImageInputError(f"image data has {buffer.size} bytes, expected step x height = {step * height}")
    frame = buffer[: step * height].reshape(height, step)[:, :row]
    frame = frame.reshape(height, width, channels) if channels > 1 else frame
    if encoding in ("rgb8", "rgba8"):
        frame = frame[:, :, 2::-1]
    return frame


def decode_compressed(data: Any, source: str = "compressed image") -> np.ndarray:
    """A JPEG/PNG buffer (sensor_msgs/CompressedImage data) as an 8-bit image."""
    buffer = data if isinstance(data, np.ndarray) else np.frombuffer(data, dtype=np.uint8)
    image = cv2.imdecode(buffer.astype(np.uint8, copy=False), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ImageInputError(f"{source}: not a JPEG or PNG OpenCV can decode")
    return as_bgr_or_gray8(image, source)


def intensity(image: np.ndarray) -> np.ndarray:
    """Brightest channel per pixel: an LED of any colour is bright in its own channel."""
    if image.ndim == 2:
        return image
    b, g, r = cv2.split(image)
    return cv2.max(cv2.max(b, g), r)
