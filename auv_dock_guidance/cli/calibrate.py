"""`auv-dock calibrate` and `auv-dock undistort`: Zhang's calibration to a camera_info file."""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

import cv2
import yaml

from auv_dock_guidance.cli.common import Number, fail, load_camera, new_path, print_json
from auv_dock_guidance.errors import DockGuidanceError
from auv_dock_guidance.geometry.calibration import (
    SQUARE_RANGE_M,
    Board,
    CalibrationError,
    CalibrationResult,
    ViewResult,
    calibrate,
    undistort_image,
)
from auv_dock_guidance.vision.image_input import read_image


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    c = subparsers.add_parser(
        "calibrate",
        help="Zhang's chessboard calibration to a ROS camera_info YAML",
        description="Find the chessboard's inner corners in each image, calibrate (plumb_bob "
        "model), drop outlier views, and write a camera_info YAML that ROS and auv-dock read.",
    )
    c.add_argument("images", nargs="+", metavar="IMAGE")
    c.add_argument("--board", required=True, metavar="COLSxROWS", help="inner corners, e.g. 9x6")
    c.add_argument("--square", required=True, type=Number(float, *SQUARE_RANGE_M), metavar="SIZE_M",
                   help="side of one printed square in metres")
    c.add_argument("--output", "-o", metavar="YAML", help="write the camera_info file here (never over an input "
                   "image; an existing file only with --force)")
    c.add_argument("--force", action="store_true", help="replace an existing --output file")
    c.add_argument("--camera-name", default="dock_camera", help="camera_name in the file (default %(default)s)")
    c.add_argument("--fix-tangential", action="store_true", help="fix p1 = p2 = 0, as the paper did")
    c.add_argument("--json", action="store_true", help="print one JSON object")
    c.set_defaults(run=run_calibrate)

    u = subparsers.add_parser(
        "undistort",
        help="an image as the ideal pinhole camera would see it (a visual calibration check)",
        description="Remove lens distortion with a camera_info file; straight edges in the scene "
        "should come out straight. Regions beyond the lens model's fold are black.",
    )
    u.add_argument("image", metavar="IMAGE")
    u.add_argument("--camera-info", required=True, metavar="YAML")
    u.add_argument("--output", "-o", required=True, metavar="OUT", help="the corrected image (never the input; an "
                   "existing file only with --force)")
    u.add_argument("--force", action="store_true", help="replace an existing --output file")
    u.set_defaults(run=run_undistort)


def run_calibrate(args: argparse.Namespace) -> int:
    try:
        board = Board.parse(args.board, args.square)
    except CalibrationError as exc:
        fail(str(exc))
    if args.output:
        check_output(args.output, args.images, args.force)
    views, unreadable = [], []
    for path in args.images:
        try:
            views.append((path, read_image(path)))
        except DockGuidanceError as exc:
            unreadable.append(ViewResult(path, reason=str(exc).removeprefix(f"{path}: ")))
    try:
        result = calibrate(views, board, args.fix_tangential, args.camera_name, skipped=unreadable)
    except CalibrationError as exc:
        fail(str(exc), code=1)
    cam = result.camera
    if args.output:
        try:
            write_replacing(Path(args.output), yaml.safe_dump(cam.to_yaml_dict(), sort_keys=False))
        except OSError as exc:
            fail(f"cannot write {args.output}: {exc.strerror}", code=1)
    if args.json:
        print_json(_report(result, args.output))
        return 0
    _print_report(result, len(args.images), args.output)
    return 0


def _report(result: CalibrationResult, output: str | None) -> dict:
    cam = result.camera
    return {
        "rms_px": result.rms_px,
        "camera_matrix": cam.matrix.tolist(),
        "distortion_coefficients": list(cam.distortion),
        "image_size": [cam.width, cam.height],
        "std": {"fx_px": result.std_fx, "fy_px": result.std_fy, "cx_px": result.std_cx, "cy_px": result.std_cy,
                **dict(zip(("k1", "k2", "p1", "p2", "k3"), result.std_distortion, strict=True))},
        "used_images": [_view(v) for v in result.used],
        "rejected_images": [_view(v) for v in result.rejected],
        "coverage_hint": result.coverage_hint,
        "warnings": result.warnings,
        "output": output,
    }


def _view(view: ViewResult) -> dict:
    entry: dict = {"image": view.name}
    if view.error_px is not None:
        entry["error_px"] = view.error_px
    if view.half_window_px is not None:
        entry["half_window_px"] = view.half_window_px
    if view.reason is not None:
        entry["reason"] = view.reason
    return entry


def _print_report(result: CalibrationResult, given: int, output: str | None) -> None:
    cam = result.camera
    print(f"calibrated from {len(result.used)} of {given} images, RMS reprojection error {result.rms_px:.3f} px")
    print(f"  fx {cam.fx:.2f} +- {result.std_fx:.2f}   fy {cam.fy:.2f} +- {result.std_fy:.2f}")
    print(f"  cx {cam.cx:.2f} +- {result.std_cx:.2f}   cy {cam.cy:.2f} +- {result.std_cy:.2f}")
    print("  distortion k1 k2 p1 p2 k3: " + " ".join(f"{x:+.4f}" for x in cam.distortion))
    for view in result.used:
        side = 2 * (view.half_window_px or 0) + 1
        print(f"  used      {view.name}: {view.error_px:.3f} px (corners refined in {side}x{side} px)")
    for view in result.rejected:
        print(f"  rejected  {view.name}: {view.reason}")
    for warning in result.warnings:
        print(f"warning: implausible calibration: {warning}")
    if result.coverage_hint:
        print(f"hint: {result.coverage_hint}")
    if output:
        print(f"wrote {output}")


def check_output(output: str, inputs: list[str], force: bool) -> None:
    """Exit before any work when ``output`` cannot be written, or writing it would destroy
    what the user gave: one of the inputs (never, even with --force) or an existing file
    (only with --force)."""
    target = Path(output)
    for given in inputs:
        if _same_file(target, Path(given)):
            fail(f"--output {output} is the input image {given}; nothing is written over an input, "
                 "even with --force")
    if target.is_dir():
        fail(f"--output {output} is a folder; give a file name")
    if target.exists():
        if not force:
            fail(f"--output {output} exists; give --force to replace it")
        return
    try:
        new_path(output)
    except argparse.ArgumentTypeError as exc:
        fail(f"--output: {exc}")


def _same_file(a: Path, b: Path) -> bool:
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)  # hard links and symbolic links too
        return a.resolve() == b.resolve()
    except OSError:
        return False


def write_replacing(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` (its folder made if need be) through a temporary file beside
    it, so a failed write never leaves a half-written file in place of the old one."""
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        with os.fdopen(handle, "w") as stream:
            stream.write(text)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def run_undistort(args: argparse.Namespace) -> int:
    check_output(args.output, [args.image], args.force)
    camera = load_camera(args.camera_info)
    try:
        image = read_image(args.image)
        corrected = undistort_image(image, camera)
    except DockGuidanceError as exc:
        fail(str(exc), code=1)
    Path(args.output).parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(args.output, corrected):
        fail(f"cannot write {args.output} (unknown extension or unwritable folder)", code=1)
    print(f"wrote {args.output}")
    return 0
