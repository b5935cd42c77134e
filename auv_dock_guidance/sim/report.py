"""Pictures of a docking run: what the camera saw, what the detector made of it, and when.

From the detector's overlay frames (the debug image a shore laptop receives: the frame
with the ring it found, its centre and the line from the image centre) this makes a
strip of the moments that matter (first detection, tracking, the terminal phase, the
last frame before the entrance) and an animated GIF of the whole approach. The GIF is
written with Pillow (already installed with matplotlib; well kept, and GIF plays in
every browser and in a README, where a video needs a player and a codec OpenCV's wheels
may lack).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from auv_dock_guidance.geometry.camera import paper_camera
from auv_dock_guidance.sim.closed_loop import EpisodeConfig, EpisodeResult, run_episode
from auv_dock_guidance.sim.scene import GroundTruth
from auv_dock_guidance.vision.detection import Detection
from auv_dock_guidance.vision.overlay import overlay_jpeg, overlay_text

FIRST_DETECTION, TRACKING, TERMINAL, LAST_SIGHTING, LAST = (
    "first detection", "tracking", "terminal phase", "last sighting", "last frame before the entrance")


@dataclass(frozen=True)
class OverlayFrame:
    """One overlay frame (JPEG, as the detector publishes it) and when it was seen (s from the start)."""

    t_s: float
    jpeg: bytes

    def image_rgb(self) -> np.ndarray | None:
        image = cv2.imdecode(np.frombuffer(self.jpeg, np.uint8), cv2.IMREAD_COLOR)
        return None if image is None else cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


@dataclass(frozen=True)
class Moment:
    label: str
    frame: OverlayFrame


def state_at(states: list[tuple[float, str]], t_s: float) -> str:
    """The guidance state at a time, from the (start time, state) list (ordered); "" before the first."""
    index = bisect.bisect_right([t for t, _ in states], t_s) - 1
    return states[index][1] if index >= 0 else ""


def state_starts(states: list[tuple[float, str]]) -> dict[str, float]:
    """When each state first began."""
    starts: dict[str, float] = {}
    for t, state in states:
        starts.setdefault(state, t)
    return starts


def key_moments(frames: list[OverlayFrame], detections_s: tuple[float, float] | None,
                states: list[tuple[float, str]], last_label: str = LAST) -> list[Moment]:
    """The frames to show: the first with the dock found, the middle of tracking, the start of
    the terminal phase, the last with the dock found, and the last one; each once, in time
    order. ``detections_s``: the times of the first and the last detection."""
    if not frames:
        return []
    times = [f.t_s for f in frames]
    starts = state_starts(states)

    def first_after(t_s: float) -> OverlayFrame | None:
        index = bisect.bisect_left(times, t_s)
        return frames[index] if index < len(frames) else None

    def last_before(t_s: float) -> OverlayFrame | None:
        index = bisect.bisect_right(times, t_s) - 1
        return frames[index] if index >= 0 else None

    wanted: list[tuple[str, OverlayFrame | None]] = []
    if detections_s is not None:
        wanted.append((FIRST_DETECTION, first_after(detections_s[0])))
    if "TRACK" in starts:
        track_end = starts.get("TERMINAL", times[-1])
        wanted.append((TRACKING, first_after(0.5 * (starts["TRACK"] + track_end))))
    if "TERMINAL" in starts:
        wanted.append((TERMINAL, first_after(starts["TERMINAL"])))
    if detections_s is not None:
        wanted.append((LAST_SIGHTING, last_before(detections_s[1])))
    wanted.append((last_label, frames[-1]))
    moments: list[Moment] = []
    for label, frame in wanted:
        if frame is not None and all(m.frame is not frame for m in moments):
            moments.append(Moment(label, frame))
    return sorted(moments, key=lambda m: m.frame.t_s)


def write_strip(moments: list[Moment], path: Path, caption: Callable[[Moment], str], title: str = "") -> Path:
    """The moments side by side, each with its caption, as one PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    decoded = [(m, m.frame.image_rgb()) for m in moments]
    images = [(m, image) for m, image in decoded if image is not None]
    if not images:
        raise ValueError("no overlay frame could be decoded")
    height, width = images[0][1].shape[:2]
    tile_in = 3.2
    fig, axes = plt.subplots(1, len(images), figsize=(tile_in * len(images), tile_in * height / width + 0.7),
                             squeeze=False)
    for ax, (moment, image) in zip(axes[0], images, strict=True):
        ax.imshow(image, interpolation="lanczos")
        ax.set_title(caption(moment), fontsize=8.5)
        ax.axis("off")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def write_animation(frames: list[OverlayFrame], path: Path, label: Callable[[OverlayFrame], str],
                    fps: float = 6.0, every_s: float = 0.5, width_px: int = 480) -> Path:
    """The approach as an animated GIF (Pillow): a frame every ``every_s`` of the run (the
    debug image's rate, and three times real speed at 6 fps), each with its label burnt in,
    scaled to ``width_px``; the last frame always, held for 2 s."""
    from PIL import Image

    if not frames:
        raise ValueError("no overlay frames for the animation")
    chosen = [frames[0]]
    for frame in frames[1:]:
        if frame.t_s >= chosen[-1].t_s + 0.8 * every_s:  # frames a little early still count
            chosen.append(frame)
    if chosen[-1] is not frames[-1]:
        chosen.append(frames[-1])
    pictures = []
    for frame in chosen:
        image = frame.image_rgb()
        if image is None:
            continue
        scale = width_px / image.shape[1]
        image = cv2.resize(image, None, fx=scale, fy=scale,
                           interpolation=cv2.INTER_CUBIC if scale > 1 else cv2.INTER_AREA)
        bar = np.zeros((18, image.shape[1], 3), np.uint8)
        cv2.putText(bar, label(frame), (4, 13), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (255, 255, 255), 1, cv2.LINE_AA)
        pictures.append(Image.fromarray(np.vstack([image, bar])).quantize(colors=128, dither=Image.Dither.NONE))
    if not pictures:
        raise ValueError("no overlay frame could be decoded")
    path.parent.mkdir(parents=True, exist_ok=True)
    durations = [int(1000 / fps)] * (len(pictures) - 1) + [2000]  # hold the last frame
    pictures[0].save(path, save_all=True, append_images=pictures[1:], duration=durations, loop=0, optimize=True)
    return path


def write_run_pictures(folder: Path, frames: list[OverlayFrame], states: list[tuple[float, str]],
                       detections_s: tuple[float, float] | None, to_entrance_m: Callable[[float], float],
                       reached_entrance: bool, title: str = "", prefix: str = "") -> list[Path]:
    """The strip of key moments (``camera_strip.png``) and the approach (``approach.gif``) of one
    run, their names after ``prefix``; nothing when no overlay frame was seen."""
    if not frames:
        return []
    moments = key_moments(frames, detections_s, states, LAST if reached_entrance else "last frame")

    def caption(moment: Moment) -> str:
        t = moment.frame.t_s
        return f"{moment.label}\nt {t:.1f} s, {state_at(states, t) or 'starting'}, {to_entrance_m(t):.1f} m to go"

    def label(frame: OverlayFrame) -> str:
        t = frame.t_s
        return f"t {t:5.1f} s  {state_at(states, t) or 'starting':<9} {to_entrance_m(t):5.1f} m to the entrance"

    return [write_strip(moments, folder / f"{prefix}camera_strip.png", caption, title),
            write_animation(frames, folder / f"{prefix}approach.gif", label)]


def distance_to_entrance(trajectory: Sequence[tuple[float, float, float, float, float]]) -> Callable[[float], float]:
    """Distance of the nose to the entrance plane at a time, from (t, along the dock's axis, ...) samples."""
    times = np.array([p[0] for p in trajectory])
    along = np.array([p[1] for p in trajectory])
    return lambda t_s: float(-np.interp(t_s, times, along)) if len(times) else math.nan


def worst_episode_pictures(config: EpisodeConfig, results: list[EpisodeResult], folder: Path) -> list[Path]:
    """``episode_pictures`` of the worst episode (none without episodes)."""
    worst = worst_episode(results)
    return episode_pictures(config, worst, folder) if worst is not None else []


def worst_episode(results: list[EpisodeResult]) -> EpisodeResult | None:
    """The run a person should look at: the first failure, else the widest entry."""
    if not results:
        return None
    failed = [r for r in results if not r.success]
    if failed:
        return min(failed, key=lambda r: r.seed)
    return max(results, key=lambda r: r.entry_lateral_error_m or 0.0)


def episode_pictures(config: EpisodeConfig, result: EpisodeResult, folder: Path) -> list[Path]:
    """The strip and the animation of one simulated episode, run again from its seed (each
    episode is reproducible) with the detector's overlay kept for every frame."""
    frames: list[OverlayFrame] = []
    ranges: list[tuple[float, float]] = []  # t, true distance to the dock ahead of the camera

    camera = paper_camera().scaled(config.render_scale)  # the episode's camera
    principal = (camera.cx, camera.cy)

    def keep(t_s: float, image: np.ndarray, detection: Detection, truth: GroundTruth) -> None:
        frames.append(OverlayFrame(t_s, overlay_jpeg(image, detection, principal, overlay_text(detection),
                                                     scale=0.5, quality=80)))
        if truth.position_m is not None:
            ranges.append((t_s, truth.position_m[2]))

    again = run_episode(config, result.seed, on_frame=keep)
    detections = [t for t, _, _ in again.bearing_errors]
    times = np.array([t for t, _ in ranges])
    distances = np.array([d for _, d in ranges])

    def to_dock(t_s: float) -> float:
        return float(np.interp(t_s, times, distances)) if len(times) else math.nan

    title = (f"worst of the episodes: seed {result.seed}, {again.reason}"
             + (f", entry {100 * again.entry_lateral_error_m:.1f} cm off centre"
                if again.entry_lateral_error_m is not None else ""))
    return write_run_pictures(folder, frames, [(0.0, "SEARCH"), *again.states],
                              (detections[0], detections[-1]) if detections else None, to_dock,
                              again.entry_lateral_error_m is not None, title, prefix=f"worst_seed{result.seed}_")
