"""Argument helpers shared by the auv-dock subcommands."""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any, NoReturn

from auv_dock_guidance.errors import CameraModelError
from auv_dock_guidance.geometry.camera import CameraModel, paper_camera


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"{text} must be a positive number")
    return value


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{text} must be a positive whole number")
    return value


def add_camera_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--camera-info",
        metavar="YAML",
        help="camera_info YAML of the camera (default: the paper's Table 2 calibration)",
    )


def load_camera(path: str | None) -> CameraModel:
    """The camera to use; exits with a clear message if the file is unusable."""
    if path is None:
        return paper_camera()
    try:
        return CameraModel.from_yaml(path)
    except CameraModelError as exc:
        fail(str(exc))


def fail(message: str, code: int = 2) -> NoReturn:
    print(f"auv-dock: error: {message}", file=sys.stderr)
    raise SystemExit(code)


def print_json(data: dict[str, Any]) -> None:
    print(json.dumps(data, default=_jsonable), flush=True)


def _jsonable(value: Any) -> Any:
    if hasattr(value, "item"):
        return value.item()
    raise TypeError(f"cannot write {type(value).__name__} as JSON")


def rounded(value: float | None, digits: int = 3) -> float | None:
    if value is None or not math.isfinite(value):
        return None
    return round(float(value), digits)
