"""`auv-dock evaluate --labels`: the detector on recorded frames, scored against hand labels.

The scoring rule lives in `vision/labels.py`; this finds the frames, runs each block of
consecutive frames as one sequence and prints the rates per block and overall.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from auv_dock_guidance.cli.common import fail, print_json
from auv_dock_guidance.cli.detect import detector_from_args
from auv_dock_guidance.errors import DockGuidanceError
from auv_dock_guidance.vision.image_input import read_image
from auv_dock_guidance.vision.labels import FrameLabel, FrameScore, LabelError, blocks, load_labels, score, summary


def run_labels(args: argparse.Namespace) -> int:
    try:
        labels, problems = load_labels(args.labels)
    except LabelError as exc:
        fail(str(exc))
    frames = _frame_paths(Path(args.labels), labels, args.images, problems)
    detector = detector_from_args(args)
    said: set[str] = set()
    per_block: list[dict[str, Any]] = []
    everything: list[FrameScore] = []
    for block in blocks([label for label in labels if label.index in frames]):
        detector.reset()
        scores = []
        for label in block:
            try:
                image = read_image(frames[label.index])
                note = detector.fit_camera(image.shape[1], image.shape[0])
                if note is not None and note not in said:
                    said.add(note)
                    print(f"note: {note}", file=sys.stderr, flush=True)
                detection = detector.detect(image)
            except DockGuidanceError as exc:
                problems.append(f"{args.labels}: frame {label.index} ({label.file}): {exc}")
                detector.reset()  # the sequence is broken here
                continue
            scores.append(score(label, detection.found, detection.u, detection.v))
        if scores:
            per_block.append({"first_index": block[0].index, "last_index": block[-1].index, **summary(scores)})
            everything.extend(scores)
    for problem in problems:
        print(f"auv-dock: error: {problem}", file=sys.stderr, flush=True)
    report = {"labels": str(args.labels), "overall": summary(everything), "blocks": per_block,
              "problems": len(problems)}
    if args.json:
        print_json(report)
    else:
        _print_report(report)
    return 1 if problems or not everything else 0


def _frame_paths(labels_path: Path, labels: list[FrameLabel], images: list[str],
                 problems: list[str]) -> dict[int, str]:
    """Frame index -> image file: the given images matched to the labels by file name, or the
    labelled files next to the labels file or in its frames/ folder. What is missing is a problem."""
    by_name = {label.file: label for label in labels}
    if images:
        found: dict[int, str] = {}
        for image in images:
            label = by_name.get(Path(image).name)
            if label is None:
                problems.append(f"{image}: no entry of {labels_path} names this file")
            else:
                found[label.index] = image
        return found
    folder = labels_path.parent
    found = {}
    for label in labels:
        for candidate in (folder / label.file, folder / "frames" / label.file):
            if candidate.is_file():
                found[label.index] = str(candidate)
                break
        else:
            problems.append(f"{labels_path}: frame {label.index} ({label.file}): not found in {folder} "
                            f"or {folder / 'frames'}")
    return found


def _pct(value: float | None) -> str:
    return "   n/a" if value is None else f"{100 * value:5.1f}%"


def _print_report(report: dict[str, Any]) -> None:
    print(f"{'frames':>14} {'visible':>15} {'corner':>15} {'wrong':>11} {'centre error / disk radius':>28}")
    rows = [(f"{b['first_index']}-{b['last_index']}", b) for b in report["blocks"]] + [("all", report["overall"])]
    for name, r in rows:
        error = "n/a" if r["center_error_p50"] is None else (
            f"p50 {100 * r['center_error_p50']:.1f}% p95 {100 * r['center_error_p95']:.1f}% ({r['center_errors']})")
        print(f"{name:>9} {r['frames']:>4} {_pct(r['visible_rate'])} of {r['visible_frames']:>4} "
              f"{_pct(r['corner_rate'])} of {r['corner_frames']:>4} {r['wrong_objects']:>4} "
              f"{_pct(r['wrong_object_rate'])} {error:>28}")
    if report["overall"]["empty_frames"]:
        print(f"frames without a marker: {report['overall']['empty_frames']}, "
              f"detections there {report['overall']['empty_detections']}")
