"""`auv-dock calibrate` and `auv-dock undistort`: Zhang's calibration to a camera_info file."""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import yaml

from auv_dock_guidance.cli.common import fail, load_camera, positive_float, print_json
from auv_dock_guidance.errors import DockGuidanceError
from auv_dock_guidance.geometry.calibration import Board, CalibrationError, calibrate, undistort_image
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
    c.add_argument("--square", required=True, type=positive_float, metavar="SIZE_M", help="square size in metres")
    c.add_argument("--output", "-o", metavar="YAML", help="write the camera_info file here")
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
    u.add_argument("--output", "-o", required=True, metavar="OUT")
    u.set_defaults(run=run_undistort)


def run_calibrate(args: argparse.Namespace) -> int:
    try:
        board = Board.parse(args.board, args.square)
    except CalibrationError as exc:
        fail(str(exc))
    views, unreadable = [], []
    for path in args.images:
        try:
            views.append((path, read_image(path)))
        except DockGuidanceError as exc:
            unreadable.append({"image": path, "reason": str(exc)})
    try:
        result = calibrate(views, board, args.fix_tangential, args.camera_name)
    except CalibrationError as exc:
        for item in unreadable:
            print(f"auv-dock: skipped {item['reason']}", flush=True)
        fail(str(exc), code=1)
    cam = result.camera
    rejected = unreadable + [{"image": r.name, "reason": r.reason} for r in result.rejected]
    report = {
        "rms_px": result.rms_px,
        "camera_matrix": cam.matrix.tolist(),
        "distortion_coefficients": list(cam.distortion),
        "image_size": [cam.width, cam.height],
        "std_fx_fy_cx_cy": [result.std_fx, result.std_fy, result.std_cx, result.std_cy],
        "std_distortion": list(result.std_distortion),
        "used_images": [{"image": v.name, "error_px": v.error_px} for v in result.used],
        "rejected_images": rejected,
        "coverage_hint": result.coverage_hint,
        "output": args.output,
    }
    if args.output:
        try:
            Path(args.output).write_text(yaml.safe_dump(cam.to_yaml_dict(), sort_keys=False))
        except OSError as exc:
            fail(f"cannot write {args.output}: {exc.strerror}", code=1)
    if args.json:
        print_json(report)
        return 0
    print(f"calibrated from {len(result.used)} of {len(args.images)} images, "
          f"RMS reprojection error {result.rms_px:.3f} px")
    print(f"  fx {cam.fx:.2f} +- {result.std_fx:.2f}   fy {cam.fy:.2f} +- {result.std_fy:.2f}")
    print(f"  cx {cam.cx:.2f} +- {result.std_cx:.2f}   cy {cam.cy:.2f} +- {result.std_cy:.2f}")
    print("  distortion k1 k2 p1 p2 k3: " + " ".join(f"{x:+.4f}" for x in cam.distortion))
    for view in result.used:
        print(f"  used      {view.name}: {view.error_px:.3f} px")
    for item in rejected:
        print(f"  rejected  {item['image']}: {item['reason']}")
    if result.coverage_hint:
        print(f"hint: {result.coverage_hint}")
    if args.output:
        print(f"wrote {args.output}")
    return 0


def run_undistort(args: argparse.Namespace) -> int:
    camera = load_camera(args.camera_info)
    try:
        image = read_image(args.image)
        corrected = undistort_image(image, camera)
    except DockGuidanceError as exc:
        fail(str(exc), code=1)
    if not cv2.imwrite(args.output, corrected):
        fail(f"cannot write {args.output} (unknown extension or unwritable folder)", code=1)
    print(f"wrote {args.output}")
    return 0
