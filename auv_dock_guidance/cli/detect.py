"""`auv-dock detect`: the marker in image files, one sequence or each image on its own."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from auv_dock_guidance.cli.common import add_camera_argument, load_camera, positive_float, print_json, rounded
from auv_dock_guidance.errors import DockGuidanceError
from auv_dock_guidance.vision.detector import Detection, Detector, DetectorConfig
from auv_dock_guidance.vision.image_input import read_image


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "detect",
        help="find the LED ring in images and print its position and bearing",
        description="Find the dock's LED ring in each image. Images given in order are one "
        "sequence (the adaptive threshold carries over) unless --independent. Images that are a "
        "uniform resize of the camera's resolution use the camera model scaled to them.",
    )
    p.add_argument("images", nargs="+", metavar="IMAGE", help="image files (PNG, JPEG, ...)")
    add_camera_argument(p)
    p.add_argument("--marker-radius", type=positive_float, default=DetectorConfig.marker_radius_m,
                   metavar="M", help="radius of the LED ring's centre line in metres (default %(default)s)")
    p.add_argument("--independent", action="store_true", help="treat every image on its own")
    p.add_argument("--json", action="store_true", help="one JSON object per image and line")
    p.set_defaults(run=run)


def detection_record(image: str, detection: Detection) -> dict[str, Any]:
    pose = detection.pose
    return {
        "image": image,
        "found": detection.found,
        "u": rounded(detection.u, 2),
        "v": rounded(detection.v, 2),
        "radius_px": rounded(detection.radius_px, 2),
        "range_m": rounded(pose.range_m if pose else None, 3),
        "offset_x_m": rounded(pose.offset_x_m if pose else None, 3),
        "offset_y_m": rounded(pose.offset_y_m if pose else None, 3),
        "yaw_deg": rounded(pose.yaw_deg if pose else None, 3),
        "pitch_deg": rounded(pose.pitch_deg if pose else None, 3),
        "threshold": rounded(detection.threshold, 1),
        "mec_u": rounded(detection.mec_u, 2),
        "mec_v": rounded(detection.mec_v, 2),
        "mec_radius_px": rounded(detection.mec_radius_px, 2),
        "reason": detection.reason or None,
    }


def run(args: argparse.Namespace) -> int:
    camera = load_camera(args.camera_info)
    detector = Detector(camera, DetectorConfig(marker_radius_m=args.marker_radius))
    failures = 0
    said: set[str] = set()
    for path in args.images:
        if args.independent:
            detector.reset()
        try:
            image = read_image(path)
            note = detector.fit_camera(image.shape[1], image.shape[0])
            if note is not None and note not in said:
                said.add(note)
                print(f"note: {note}", file=sys.stderr, flush=True)
            detection = detector.detect(image)
        except DockGuidanceError as exc:
            failures += 1
            if args.json:
                print_json({"image": path, "found": False, "error": str(exc)})
            else:
                print(f"{path}: error: {exc}", flush=True)
            continue
        record = detection_record(path, detection)
        if args.json:
            print_json(record)
        elif detection.found and detection.pose is not None:
            print(
                f"{path}: marker at u={record['u']:.1f} v={record['v']:.1f} r={record['radius_px']:.1f} px, "
                f"range {record['range_m']:.2f} m, yaw {record['yaw_deg']:+.2f} deg, "
                f"pitch {record['pitch_deg']:+.2f} deg (threshold {record['threshold']:.0f})",
                flush=True,
            )
        elif detection.found:
            print(f"{path}: marker at u={record['u']:.1f} v={record['v']:.1f} (no pose: outline unusable)")
        else:
            print(f"{path}: no marker ({detection.reason})", flush=True)
    return 1 if failures else 0
