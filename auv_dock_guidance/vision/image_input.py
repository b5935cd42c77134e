"""Turning whatever a camera, a file or a message delivers into the 8-bit image the detector reads."""

from __future__ import annotations

import errno
import os
import stat
from dataclasses import dataclass
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
        raise ImageInputError(f"{path}: {_not_a_file(path)}")
    data = np.fromfile(path, dtype=np.uint8)
    if data.size == 0:
        raise ImageInputError(f"{path}: empty file")
    image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ImageInputError(f"{path}: not an image OpenCV can decode")
    return as_bgr_or_gray8(image, str(path))


def _not_a_file(path: Path) -> str:
    """Why a path is no image file, in the words a person would use."""
    try:
        mode = path.stat().st_mode
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return "a symbolic link that loops back on itself"
        if path.is_symlink():
            return f"a symbolic link to {os.readlink(path)}, which does not exist"
        return "no such file" if exc.errno == errno.ENOENT else exc.strerror or str(exc)
    return "a folder, not an image file" if stat.S_ISDIR(mode) else "not a regular file"


# OpenCV names Bayer patterns by the second row's first two pixels, ROS by the first row's
# (cv_bridge's table); each code is checked against a known colour image in the tests.
_BAYER = {"rggb": cv2.COLOR_BayerBG2BGR, "bggr": cv2.COLOR_BayerRG2BGR,
          "gbrg": cv2.COLOR_BayerGR2BGR, "grbg": cv2.COLOR_BayerGB2BGR}


@dataclass(frozen=True)
class _Layout:
    channels: int  # values per pixel in the buffer
    depth: int  # bytes per value
    to_bgr: int | None = None  # cv2.cvtColor code to BGR, when the pixels are not BGR/mono already
    reorder: bool = False  # RGB(A) order: reverse to BGR


def _encodings() -> dict[str, _Layout]:
    table = {"mono8": _Layout(1, 1), "8UC1": _Layout(1, 1), "bgr8": _Layout(3, 1), "8UC3": _Layout(3, 1),
             "bgra8": _Layout(4, 1), "8UC4": _Layout(4, 1), "rgb8": _Layout(3, 1, reorder=True),
             "rgba8": _Layout(4, 1, reorder=True), "mono16": _Layout(1, 2), "16UC1": _Layout(1, 2),
             "bgr16": _Layout(3, 2), "16UC3": _Layout(3, 2), "bgra16": _Layout(4, 2), "16UC4": _Layout(4, 2),
             "rgb16": _Layout(3, 2, reorder=True), "rgba16": _Layout(4, 2, reorder=True),
             "yuv422": _Layout(2, 1, cv2.COLOR_YUV2BGR_UYVY), "uyvy": _Layout(2, 1, cv2.COLOR_YUV2BGR_UYVY),
             "yuv422_yuy2": _Layout(2, 1, cv2.COLOR_YUV2BGR_YUY2), "yuyv": _Layout(2, 1, cv2.COLOR_YUV2BGR_YUY2)}
    for pattern, code in _BAYER.items():
        table[f"bayer_{pattern}8"] = _Layout(1, 1, code)
        table[f"bayer_{pattern}16"] = _Layout(1, 2, code)
    return table


ENCODINGS = _encodings()


def image_from_fields(
    height: int, width: int, encoding: str, step: int, data: Any, is_bigendian: bool = False
) -> np.ndarray:
    """The 8-bit BGR or mono image in the fields of a sensor_msgs/Image.

    bgr8 and mono8 come back as zero-copy views; RGB is reordered, Bayer demosaiced, YUV
    converted, 16-bit scaled to 8 (as cv_bridge does) and alpha dropped. Works with
    rclpy messages and with rosbags' deserialized ones alike. Raises ImageInputError on an
    encoding, size or step that does not add up.
    """
    if encoding == "nv21":
        return _nv21(height, width, step, data)
    layout = ENCODINGS.get(encoding)
    if layout is None:
        raise ImageInputError(f"image encoding {encoding!r} is not supported "
                              f"(supported: {', '.join(sorted([*ENCODINGS, 'nv21']))})")
    if height == 0 or width == 0:
        raise ImageInputError(f"image is empty ({width}x{height})")
    row = width * layout.channels * layout.depth
    if step < row:
        raise ImageInputError(f"{encoding} image step {step} is smaller than width x bytes per pixel = {row}")
    buffer = _bytes(data)
    if buffer.size < step * height:
        raise ImageInputError(f"image data has {buffer.size} bytes, expected step x height = {step * height}")
    rows = buffer[: step * height].reshape(height, step)[:, :row]
    if layout.depth == 2:
        words = np.ascontiguousarray(rows).view(">u2" if is_bigendian else "<u2")
        rows = (words >> 8).astype(np.uint8)  # to 8 bits first: demosaicing then runs on 8-bit data
    shape = (height, width, layout.channels) if layout.channels > 1 else (height, width)
    frame = rows.reshape(shape)
    if layout.to_bgr is not None:
        return cv2.cvtColor(np.ascontiguousarray(frame), layout.to_bgr)
    if layout.reorder:
        return frame[:, :, 2::-1]
    return frame[:, :, :3] if layout.channels == 4 else frame


def _nv21(height: int, width: int, step: int, data: Any) -> np.ndarray:
    """Full-resolution luma, then interleaved V/U at half resolution (Android's camera format)."""
    if height % 2 or width % 2 or height == 0 or width == 0:
        raise ImageInputError(f"nv21 image needs an even, non-zero size, got {width}x{height}")
    if step < width:
        raise ImageInputError(f"nv21 image step {step} is smaller than the width {width}")
    rows = height * 3 // 2
    buffer = _bytes(data)
    if buffer.size < step * rows:
        raise ImageInputError(f"image data has {buffer.size} bytes, expected step x height x 1.5 = {step * rows}")
    planes = np.ascontiguousarray(buffer[: step * rows].reshape(rows, step)[:, :width])
    return cv2.cvtColor(planes, cv2.COLOR_YUV2BGR_NV21)


def _bytes(data: Any) -> np.ndarray:
    return data.view(np.uint8).ravel() if isinstance(data, np.ndarray) else np.frombuffer(data, dtype=np.uint8)


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
