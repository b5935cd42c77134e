"""Camera encodings a recorded bag may hold, decoded to the BGR or mono image the detector reads."""

import numpy as np
import pytest

from auv_dock_guidance.errors import ImageInputError
from auv_dock_guidance.vision.image_input import image_from_fields

# Four flat colour blocks (BGR): red, green, blue, grey; 8 x 8 pixels each.
RED, GREEN, BLUE, GREY = (40, 30, 220), (30, 200, 50), (210, 60, 20), (128, 128, 128)
BLOCKS = np.zeros((16, 16, 3), np.uint8)
BLOCKS[:8, :8], BLOCKS[:8, 8:], BLOCKS[8:, :8], BLOCKS[8:, 8:] = RED, GREEN, BLUE, GREY
INTERIORS = {RED: (slice(2, 6), slice(2, 6)), GREEN: (slice(2, 6), slice(10, 14)),
             BLUE: (slice(10, 14), slice(2, 6)), GREY: (slice(10, 14), slice(10, 14))}


def assert_blocks(image: np.ndarray, tolerance: int) -> None:
    for colour, (rows, cols) in INTERIORS.items():
        mean = image[rows, cols].reshape(-1, 3).mean(axis=0)
        assert np.all(np.abs(mean - colour) <= tolerance), (colour, mean)


def mosaic(pattern: str) -> np.ndarray:
    """The single-channel image a Bayer sensor with this pattern (first row, ROS naming) records."""
    channel = {"b": 0, "g": 1, "r": 2}
    out = np.zeros(BLOCKS.shape[:2], np.uint8)
    for i, letter in enumerate(pattern):
        dy, dx = divmod(i, 2)
        out[dy::2, dx::2] = BLOCKS[dy::2, dx::2, channel[letter]]
    return out


@pytest.mark.parametrize("pattern", ["rggb", "bggr", "gbrg", "grbg"])
def test_bayer_patterns_demosaic_to_the_right_colours(pattern):
    raw = mosaic(pattern)
    image = image_from_fields(16, 16, f"bayer_{pattern}8", 16, raw.tobytes())
    assert_blocks(image, tolerance=6)
    wide = (raw.astype("<u2") << 8) | 0x5A  # the same sensor read out with 16 bits
    assert_blocks(image_from_fields(16, 16, f"bayer_{pattern}16", 32, wide.tobytes()), tolerance=6)


def test_colour_orders_and_alpha():
    rgb = BLOCKS[:, :, ::-1]
    assert_blocks(image_from_fields(16, 16, "rgb8", 48, rgb.tobytes()), tolerance=0)
    rgba = np.dstack([rgb, np.full((16, 16), 255, np.uint8)])
    assert_blocks(image_from_fields(16, 16, "rgba8", 64, rgba.tobytes()), tolerance=0)
    bgra = np.dstack([BLOCKS, np.zeros((16, 16), np.uint8)])
    assert_blocks(image_from_fields(16, 16, "bgra8", 64, bgra.tobytes()), tolerance=0)


def test_bgr8_is_a_view_and_row_padding_is_skipped():
    padded = np.zeros((16, 64), np.uint8)  # 48 bytes of pixels, 16 of padding per row
    padded[:, :48] = BLOCKS.reshape(16, 48)
    padded[:, 48:] = 255
    image = image_from_fields(16, 16, "bgr8", 64, padded)
    assert_blocks(image, tolerance=0)
    assert np.shares_memory(image, padded)


@pytest.mark.parametrize("bigendian", [False, True])
def test_sixteen_bit_images_keep_their_high_byte_in_either_byte_order(bigendian):
    words = (BLOCKS.astype(np.uint16) << 8) | 0x7F
    order = ">u2" if bigendian else "<u2"
    assert_blocks(image_from_fields(16, 16, "bgr16", 96, words.astype(order).tobytes(), bigendian), tolerance=0)
    assert_blocks(image_from_fields(16, 16, "rgb16", 96, words[:, :, ::-1].astype(order).tobytes(), bigendian),
                  tolerance=0)
    mono = image_from_fields(16, 16, "mono16", 32, words[:, :, 1].astype(order).tobytes(), bigendian)
    assert mono.dtype == np.uint8 and np.array_equal(mono, BLOCKS[:, :, 1])


def _yuv() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """BT.601 studio-range Y, U, V of the blocks (what camera YUV422 output carries)."""
    b, g, r = (BLOCKS[:, :, i].astype(float) for i in range(3))
    y = 16 + (65.481 * r + 128.553 * g + 24.966 * b) / 255
    u = 128 + (-37.797 * r - 74.203 * g + 112.0 * b) / 255
    v = 128 + (112.0 * r - 93.786 * g - 18.214 * b) / 255
    return (np.clip(np.round(c), 0, 255).astype(np.uint8) for c in (y, u, v))


@pytest.mark.parametrize("encoding", ["yuv422", "uyvy", "yuv422_yuy2", "yuyv"])
def test_yuv422_byte_orders(encoding):
    y, u, v = _yuv()
    packed = np.zeros((16, 32), np.uint8)
    luma_first = encoding in ("yuv422_yuy2", "yuyv")
    packed[:, 1 - luma_first::2] = y  # Y on odd bytes in UYVY, even bytes in YUYV
    chroma = packed[:, luma_first::2]
    chroma[:, 0::2], chroma[:, 1::2] = u[:, 0::2], v[:, 0::2]
    assert_blocks(image_from_fields(16, 16, encoding, 32, packed.tobytes()), tolerance=8)


def test_nv21():
    y, u, v = _yuv()
    vu = np.zeros((8, 16), np.uint8)
    vu[:, 0::2], vu[:, 1::2] = v[::2, ::2], u[::2, ::2]
    assert_blocks(image_from_fields(16, 16, "nv21", 16, np.vstack([y, vu]).tobytes()), tolerance=8)


@pytest.mark.parametrize(("encoding", "step", "size", "message"), [
    ("32FC1", 64, 1024, "'32FC1' is not supported (supported: 16UC1"),
    ("bgr16", 48, 1536, "bgr16 image step 48 is smaller than width x bytes per pixel = 96"),
    ("mono8", 16, 100, "image data has 100 bytes, expected step x height = 256"),
    ("nv21", 16, 256, "expected step x height x 1.5 = 384"),
])
def test_what_does_not_add_up_is_named(encoding, step, size, message):
    with pytest.raises(ImageInputError, match=message.replace("(", r"\(").replace(".", r"\.")):
        image_from_fields(16, 16, encoding, step, bytes(size))
