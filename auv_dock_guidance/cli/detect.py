"""`auv-dock detect`: the marker in image files, one sequence or each image on its own."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from auv_dock_guidance.cli.common import (
    Number,
    add_camera_argument,
    approximate_lens,
    fail,
    folder_to_write,
    load_camera,
    positive_float,
    print_json,
    rounded,
)
from auv_dock_guidance.errors import ConfigError, DockGuidanceError
from auv_dock_guidance.vision.detector import Detection, Detector, DetectorConfig
from auv_dock_guidance.vision.image_input import read_image
from auv_dock_guidance.vision.marker import COLOURS, colour_bgr
from auv_dock_guidance.vision.overlay import annotated, contact_sheet


def led_colour(text: str) -> tuple[float, float, float]:
    try:
        return colour_bgr(text)
    except ConfigError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_marker_arguments(parser: argparse.ArgumentParser) -> None:
    """The marker as the user describes it: ring radius, LED count, LED colour."""
    parser.add_argument("--marker-radius", type=positive_float, default=DetectorConfig.marker_radius_m,
                        metavar="M", help="radius of the LED ring's centre line in metres (default %(default)s)")
    parser.add_argument("--led-count", type=Number(int, low=0, high=360), metavar="N",
                        help="LEDs on the ring (0: a continuous strip; default: not known, found from the frames)")
    parser.add_argument("--led-colour", type=led_colour, metavar="COLOUR",
                        help=f"colour of the LEDs, #RRGGBB or one of {', '.join(COLOURS)} (default: any colour)")


def detector_from_args(args: argparse.Namespace) -> Detector:
    """The detector the camera and marker options ask for; exits with a clear message if refused."""
    lens = approximate_lens(args)
    camera = None if lens is not None else load_camera(args.camera_info)
    try:
        config = DetectorConfig(marker_radius_m=args.marker_radius, led_count=args.led_count, led_bgr=args.led_colour)
    except DockGuidanceError as exc:
        fail(str(exc))
    return Detector(camera, config, lens=lens)


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "detect",
        help="find the LED ring in images and print its position and bearing",
        description="Find the dock's LED ring in each image. Images given in order are one "
        "sequence (the adaptive threshold carries over) unless --independent. Images that are a "
        "uniform resize of the camera's resolution use the camera model scaled to them. Without a "
        "calibration, --focal-px or --hfov makes an approximate camera (ranges marked approximate).",
    )
    p.add_argument("images", nargs="+", metavar="IMAGE", help="image files (PNG, JPEG, ...)")
    add_camera_argument(p, approximate=True)
    add_marker_arguments(p)
    p.add_argument("--independent", action="store_true", help="treat every image on its own")
    p.add_argument("--overlay", type=folder_to_write, metavar="DIR",
                   help="write each image with what was found drawn on it, and a contact sheet of the run, "
                   "into DIR (existing files are never written over)")
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
        "range_approximate": detection.range_approximate,
        "leds": len(detection.leds),
        "led_count": detection.led_count or None,
        "partial": detection.partial,
        "threshold": rounded(detection.threshold, 1),
        "mec_u": rounded(detection.mec_u, 2),
        "mec_v": rounded(detection.mec_v, 2),
        "mec_radius_px": rounded(detection.mec_radius_px, 2),
        "reason": detection.reason or None,
    }


_TILE_WIDTH = 320  # pixels of a frame on the contact sheet


class OverlayWriter:
    """Annotated frames and the run's contact sheet in a folder, never over an existing file."""

    def __init__(self, folder: str) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.tiles: list[np.ndarray] = []

    def add(self, image_path: str, image: np.ndarray, detection: Detection, label: str = "") -> Path:
        name = label or Path(image_path).name
        picture = annotated(image, detection, name)
        scale = _TILE_WIDTH / image.shape[1]  # drawn on the small copy, so the marks stay visible
        self.tiles.append(annotated(cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA),
                                    detection, name, scale))
        return self._write(f"{Path(image_path).stem}_overlay", picture)

    def finish(self) -> Path | None:
        return self._write("contact_sheet", contact_sheet(self.tiles)) if self.tiles else None

    def _write(self, stem: str, picture: np.ndarray) -> Path:
        path, n = self.folder / f"{stem}.png", 1
        while path.exists():
            path, n = self.folder / f"{stem}-{n}.png", n + 1
        if not cv2.imwrite(str(path), picture):
            raise DockGuidanceError(f"{path}: cannot write")
        return path


def run(args: argparse.Namespace) -> int:
    detector = detector_from_args(args)
    overlay = OverlayWriter(args.overlay) if args.overlay else None
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
            if overlay is not None:
                overlay.add(path, image, detection)
        except DockGuidanceError as exc:
            failures += 1
            if args.json:
                print_json({"image": path, "found": False, "error": str(exc)})
            else:
                print(f"{path}: error: {exc}", flush=True)
            continue
        _print(path, detection, args.json)
    if overlay is not None:
        sheet = overlay.finish()
        if sheet is not None:
            print(f"overlays in {overlay.folder}, contact sheet {sheet}", file=sys.stderr, flush=True)
    return 1 if failures else 0


def _print(path: str, detection: Detection, as_json: bool) -> None:
    record = detection_record(path, detection)
    if as_json:
        print_json(record)
    elif detection.found and detection.pose is not None:
        approx = " (approximate)" if detection.range_approximate else ""
        partial = ", partial: a corner of the ring" if detection.partial else ""
        print(
            f"{path}: marker at u={record['u']:.1f} v={record['v']:.1f} r={record['radius_px']:.1f} px, "
            f"range {record['range_m']:.2f} m{approx}, yaw {record['yaw_deg']:+.2f} deg, "
            f"pitch {record['pitch_deg']:+.2f} deg{partial}",
            flush=True,
        )
    elif detection.found:
        print(f"{path}: marker at u={record['u']:.1f} v={record['v']:.1f} (no pose: outline unusable)")
    else:
        print(f"{path}: no marker ({detection.reason})", flush=True)
