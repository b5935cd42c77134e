"""Detections scored against hand labels of recorded frames (`auv-dock evaluate --labels`).

The label format is that of ``shared/realdata/docknet-dev/labels.json``::

    {"frames": [{"file": "a.jpg", "index": 40, "class": "visible",
                 "box": [x, y, w, h], "disk": {"cx", "cy", "axes": [w, h], "angle_deg"}}, ...]}

``class`` is ``visible`` (the dock wholly in view, or half the ring or more), ``corner``
(only a corner of it: a detection is welcome, not required) or ``none`` (no marker in
view). ``box`` is the dock's visible part, ``disk`` the ellipse of its funnel where the
whole of it is in view. A detection is on the dock when its centre lies in the box grown
by 25 % of its width and height on each side; anywhere else (or in a frame without a
box) it is a wrong object. The centre error, where there is a disk, is the distance to
the disk's centre over its mean radius. Frames with consecutive indices are one
sequence (a block); the detector carries its state within a block only.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from auv_dock_guidance.errors import DockGuidanceError

CLASSES = ("visible", "corner", "none")
BOX_GROWTH = 0.25  # of the box's width and height, on each side


class LabelError(DockGuidanceError, ValueError):
    """A labels file, or an entry of it, that cannot be used."""


@dataclass(frozen=True)
class Disk:
    cx: float
    cy: float
    mean_radius_px: float


@dataclass(frozen=True)
class FrameLabel:
    file: str
    index: int
    cls: str
    box: tuple[float, float, float, float] | None = None  # x, y, w, h
    disk: Disk | None = None


@dataclass(frozen=True)
class FrameScore:
    """One frame's outcome: ``found`` anything; ``on_dock`` where the labels say the dock is."""

    label: FrameLabel
    found: bool
    on_dock: bool
    center_error: float | None = None  # over the disk's mean radius, where there is a disk


def load_labels(path: str | Path) -> tuple[list[FrameLabel], list[str]]:
    """The usable entries of a labels file and one message per unusable entry (naming it).

    Raises LabelError when the file itself cannot be read or is not a labels file.
    """
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except OSError as exc:
        raise LabelError(f"{path}: cannot read ({exc.strerror})") from exc
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise LabelError(f"{path}: not JSON ({exc})") from exc
    frames = data.get("frames") if isinstance(data, dict) else None
    if not isinstance(frames, list):
        raise LabelError(f'{path}: expected {{"frames": [...]}}, a list of labelled frames')
    labels: list[FrameLabel] = []
    problems: list[str] = []
    seen: set[int] = set()
    for position, entry in enumerate(frames):
        try:
            label = parse_entry(entry)
            if label.index in seen:
                raise LabelError(f"index {label.index} is labelled twice")
            seen.add(label.index)
            labels.append(label)
        except LabelError as exc:
            name = entry.get("file") if isinstance(entry, dict) else None
            problems.append(f"{path}: entry {position}{f' ({name})' if name else ''}: {exc}")
    return labels, problems


def parse_entry(entry: Any) -> FrameLabel:
    """One entry of ``frames``; LabelError says which field is wrong and why."""
    if not isinstance(entry, dict):
        raise LabelError("not an object")
    file, index, cls = entry.get("file"), entry.get("index"), entry.get("class")
    if not isinstance(file, str) or not file:
        raise LabelError(f"file {file!r} is not a file name")
    if isinstance(index, bool) or not isinstance(index, int) or index < 0:
        raise LabelError(f"index {index!r} is not a whole number >= 0")
    if cls not in CLASSES:
        raise LabelError(f"class {cls!r} is not one of {', '.join(CLASSES)}")
    box: tuple[float, float, float, float] | None = None
    if entry.get("box") is not None:
        x, y, w, h = _numbers(entry["box"], 4, "box")
        if w <= 0 or h <= 0:
            raise LabelError(f"box {[x, y, w, h]} has no positive width and height")
        box = (x, y, w, h)
    disk = None
    if entry.get("disk") is not None:
        raw = entry["disk"]
        if not isinstance(raw, dict):
            raise LabelError("disk is not an object with cx, cy, axes")
        cx, cy = _numbers([raw.get("cx"), raw.get("cy")], 2, "disk centre")
        axes = _numbers(raw.get("axes"), 2, "disk axes")
        if min(axes) <= 0:
            raise LabelError(f"disk axes {list(axes)} must be positive")
        disk = Disk(cx, cy, 0.25 * (axes[0] + axes[1]))
    if cls == "none" and (box is not None or disk is not None):
        raise LabelError("class none (no marker) has a box or disk")
    return FrameLabel(file, index, cls, box, disk)


def _numbers(value: Any, count: int, name: str) -> tuple[float, ...]:
    ok = isinstance(value, list) and len(value) == count and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    if not ok:
        raise LabelError(f"{name} {value!r} is not {count} finite numbers")
    return tuple(float(v) for v in value)


def blocks(labels: list[FrameLabel]) -> list[list[FrameLabel]]:
    """Labels in index order, split where the indices stop being consecutive."""
    ordered = sorted(labels, key=lambda label: label.index)
    runs: list[list[FrameLabel]] = []
    for label in ordered:
        if runs and label.index == runs[-1][-1].index + 1:
            runs[-1].append(label)
        else:
            runs.append([label])
    return runs


def score(label: FrameLabel, found: bool, u: float = math.nan, v: float = math.nan) -> FrameScore:
    """A detection (its ring centre at u, v) against one frame's label."""
    if not found:
        return FrameScore(label, False, False)
    on_dock = False
    if label.box is not None and math.isfinite(u) and math.isfinite(v):
        x, y, w, h = label.box
        on_dock = (x - BOX_GROWTH * w <= u <= x + w + BOX_GROWTH * w
                   and y - BOX_GROWTH * h <= v <= y + h + BOX_GROWTH * h)
    error = None
    if on_dock and label.disk is not None:
        error = math.hypot(u - label.disk.cx, v - label.disk.cy) / label.disk.mean_radius_px
    return FrameScore(label, True, on_dock, error)


def summary(scores: list[FrameScore]) -> dict[str, Any]:
    """Rates and centre errors of a set of frames (a block, or all of them)."""
    def of(cls: str) -> list[FrameScore]:
        return [s for s in scores if s.label.cls == cls]

    def rate(part: list[FrameScore]) -> float | None:
        return sum(s.on_dock for s in part) / len(part) if part else None

    wrong = sum(s.found and not s.on_dock for s in scores)
    errors = np.array([s.center_error for s in scores if s.center_error is not None])
    visible, corner, empty = of("visible"), of("corner"), of("none")
    return {
        "frames": len(scores),
        "visible_frames": len(visible),
        "visible_rate": rate(visible),
        "corner_frames": len(corner),
        "corner_rate": rate(corner),
        "empty_frames": len(empty),
        "empty_detections": sum(s.found for s in empty),
        "wrong_objects": wrong,
        "wrong_object_rate": wrong / len(scores) if scores else None,
        "disk_frames": sum(s.label.disk is not None for s in scores),
        "center_errors": len(errors),
        "center_error_p50": float(np.percentile(errors, 50)) if len(errors) else None,
        "center_error_p95": float(np.percentile(errors, 95)) if len(errors) else None,
    }
