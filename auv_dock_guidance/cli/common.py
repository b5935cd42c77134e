"""Argument helpers shared by the auv-dock subcommands.

The one validation layer of the command line: every numeric option takes one of the
``Number`` types below, which declares its range, and every path the command will write
is checked when the command line is read, so bad input stops before any work with one
line that names the option, the value and the limit.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

from auv_dock_guidance.errors import CameraModelError
from auv_dock_guidance.geometry.camera import ApproximateLens, CameraModel, paper_camera


@dataclass(frozen=True)
class Number:
    """A numeric option's type and allowed range: ``low``/``high`` inclusive, ``low_open`` for "> low".

    Values must be finite; whole-number options refuse fractions.
    """

    kind: type[int] | type[float]
    low: float | None = None
    high: float | None = None
    low_open: bool = False

    @property
    def __name__(self) -> str:  # argparse names the type in some of its messages
        return "whole number" if self.kind is int else "number"

    def limits(self) -> str:
        """What the value must be, e.g. "a positive number", "a whole number from 0 to 232"."""
        positive = (self.low == 0 and self.low_open) or (self.kind is int and self.low == 1 and not self.low_open)
        if positive and self.high is None:
            return f"a positive {self.__name__}"
        low = None if self.low is None else f"{'>' if self.low_open else '>='} {self.low:g}"
        if low is not None and self.high is not None:
            bounds = f"from {self.low:g} to {self.high:g}" if not self.low_open else f"{low} and <= {self.high:g}"
        else:
            bounds = low or (f"<= {self.high:g}" if self.high is not None else "")
        return f"a {self.__name__} {bounds}".rstrip()

    def __call__(self, text: str) -> int | float:
        try:
            value: int | float = self.kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a {self.__name__}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{text} is not a finite number")
        too_low = self.low is not None and (value <= self.low if self.low_open else value < self.low)
        if too_low or (self.high is not None and value > self.high):
            raise argparse.ArgumentTypeError(f"{text} is out of range: must be {self.limits()}")
        return value


positive_float = Number(float, low=0, low_open=True)  # durations, rates, sizes, tolerances
non_negative_float = Number(float, low=0)  # a largest value that may be zero (a current, a margin)
positive_int = Number(int, low=1)  # counts of things to make or run
non_negative_int = Number(int, low=0)
seed = Number(int, low=0)  # numpy's generators take seeds >= 0
rate_hz = Number(float, low=0, high=1000, low_open=True)
workers = Number(int, low=1, high=256)
domain_id = Number(int, low=0, high=232)  # ROS 2: the largest domain whose DDS ports still fit
tcp_port = Number(int, low=1, high=65535)


def domain_from_environment() -> int:
    """$ROS_DOMAIN_ID as ROS reads it (unset or empty: 0), refused with a message if unusable."""
    text = os.environ.get("ROS_DOMAIN_ID", "").strip()
    try:
        return int(domain_id(text)) if text else 0
    except argparse.ArgumentTypeError as exc:
        fail(f"ROS_DOMAIN_ID: {exc}")


def folder_to_write(text: str) -> str:
    """A folder the command will write into: an existing folder, or one it can create."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} exists and is not a folder")
    _check_creatable(path, text)
    return text


def new_path(text: str) -> str:
    """A file or folder the command will create: it must not exist, and its parent must allow it."""
    path = Path(text)
    if path.exists() or path.is_symlink():
        raise argparse.ArgumentTypeError(f"{text} exists; it is never written over (choose a new name)")
    _check_creatable(path, text)
    return text


def _check_creatable(path: Path, text: str) -> None:
    """The nearest existing ancestor is a folder this process may write into."""
    for parent in path.absolute().parents:
        if parent.exists():
            if not parent.is_dir():
                raise argparse.ArgumentTypeError(f"cannot create {text}: {parent} is a file, not a folder")
            if not path.exists() and not os.access(parent, os.W_OK | os.X_OK):
                raise argparse.ArgumentTypeError(f"cannot create {text}: no permission to write in {parent}")
            return


def add_camera_argument(parser: argparse.ArgumentParser, approximate: bool = False) -> None:
    """--camera-info; with ``approximate``, also --focal-px and --hfov for uncalibrated footage."""
    parser.add_argument(
        "--camera-info",
        metavar="YAML",
        help="camera_info YAML of the camera (default: the paper's Table 2 calibration)",
    )
    if approximate:
        add_approximate_arguments(parser)


def add_approximate_arguments(parser: argparse.ArgumentParser) -> None:
    """--focal-px and --hfov: an approximate camera for footage without a calibration."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--focal-px", type=positive_float, metavar="F",
                       help="no calibration: focal length in pixels of these frames (principal point at the "
                       "centre, no distortion); ranges are then approximate")
    group.add_argument("--hfov", type=Number(float, low=1, high=170), metavar="DEG",
                       help="no calibration: horizontal field of view in degrees, instead of --focal-px")


def approximate_lens(args: argparse.Namespace) -> ApproximateLens | None:
    """The approximate camera asked for with --focal-px or --hfov (not with --camera-info)."""
    if getattr(args, "focal_px", None) is None and getattr(args, "hfov", None) is None:
        return None
    if args.camera_info is not None:
        fail("--camera-info is a calibration: give it, or --focal-px/--hfov for an approximate camera, not both")
    return ApproximateLens(focal_px=args.focal_px, hfov_deg=args.hfov)


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
