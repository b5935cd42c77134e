"""Many docking runs, their statistics, and the plots people look at."""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from auv_dock_guidance.sim.closed_loop import EpisodeConfig, EpisodeResult, run_episode


def _run(args: tuple[EpisodeConfig, int]) -> EpisodeResult:
    return run_episode(*args)


def run_many(
    config: EpisodeConfig, episodes: int, seed: int, workers: int = 1,
    progress: Callable[[int, int], None] | None = None,
) -> list[EpisodeResult]:
    """Episodes seed, seed + 1, ... (each reproducible on its own), in parallel processes."""
    jobs = [(config, seed + i) for i in range(episodes)]
    results: list[EpisodeResult] = []
    if workers <= 1:
        for job in jobs:
            results.append(_run(job))
            if progress:
                progress(len(results), episodes)
        return results
    with ProcessPoolExecutor(max_workers=workers) as pool:
        for result in pool.map(_run, jobs):
            results.append(result)
            if progress:
                progress(len(results), episodes)
    return results


def wilson_interval(successes: int, trials: int, z: float = 1.96) -> tuple[float, float]:
    """95 % confidence interval of a success rate (Wilson score; sane at 0 % and 100 %)."""
    if trials == 0:
        return (0.0, 1.0)
    p = successes / trials
    centre = (p + z * z / (2 * trials)) / (1 + z * z / trials)
    half = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / (1 + z * z / trials)
    return (max(0.0, centre - half), min(1.0, centre + half))


def summarize(results: list[EpisodeResult]) -> dict[str, Any]:
    n = len(results)
    ok = [r for r in results if r.success]
    lateral = [r.entry_lateral_error_m for r in results if r.entry_lateral_error_m is not None]
    heading = [r.entry_heading_error_deg for r in results if r.entry_heading_error_deg is not None]
    ranges = [r.max_detection_range_m for r in results if r.max_detection_range_m]
    low, high = wilson_interval(len(ok), n)
    return {
        "episodes": n,
        "successes": len(ok),
        "success_rate": len(ok) / n if n else None,
        "success_ci95": [low, high],
        "failures": dict(Counter(r.reason for r in results if not r.success)),
        "docking_time_s_median": float(np.median([r.time_s for r in ok])) if ok else None,
        "entry_lateral_error_m_p50": float(np.percentile(lateral, 50)) if lateral else None,
        "entry_lateral_error_m_p95": float(np.percentile(lateral, 95)) if lateral else None,
        "entry_heading_error_deg_p50": float(np.percentile(heading, 50)) if heading else None,
        "entry_heading_error_deg_p95": float(np.percentile(heading, 95)) if heading else None,
        "max_detection_range_m": max(ranges) if ranges else None,
        "retries": sum(r.retries for r in results),
        "episodes_with_retries": sum(1 for r in results if r.retries),
        "docked_after_retrying": sum(1 for r in ok if r.retries),
        "sidesteps": sum(r.sidesteps for r in results),
        "failed_seeds": [r.seed for r in results if not r.success],
        "by_start_bin": by_start_bin(results),
    }


STATE_MARKS_UP_TO = 10  # episodes: beyond this the plot marks no states (it would be a blur of dots)
STATE_STYLES = {"SEARCH": ("o", "tab:gray"), "TRACK": ("s", "tab:blue"), "TERMINAL": ("^", "tab:orange"),
                "DOCKED": ("*", "tab:green"), "ABORT": ("X", "tab:red")}


# Bin edges of the start conditions results are reported by (the last bin is open above).
RANGE_EDGES_M = (0.0, 10.0, 15.0, 20.0, 25.0)
OFF_AXIS_EDGES_DEG = (0.0, 10.0, 20.0, 30.0)
CURRENT_EDGES_MPS = (0.0, 0.1, 0.2)
CROSS_CURRENT_EDGES_MPS = (0.0, 0.05, 0.1, 0.15, 0.2, 0.25)


def _bin_label(value: float, edges: tuple[float, ...]) -> str:
    i = max(j for j, edge in enumerate(edges) if value >= edge or j == 0)
    return f"{edges[i]:g}-{edges[i + 1]:g}" if i + 1 < len(edges) else f">={edges[i]:g}"


def by_start_bin(results: list[EpisodeResult]) -> dict[str, dict[str, dict[str, Any]]]:
    """Success by start range, angle off the dock's axis, current speed and its part across the axis."""
    keys = {
        "range_m": (lambda r: r.start_range_m, RANGE_EDGES_M),
        "off_axis_deg": (lambda r: r.start_off_axis_deg, OFF_AXIS_EDGES_DEG),
        "current_mps": (lambda r: r.current_mps, CURRENT_EDGES_MPS),
        "cross_current_mps": (lambda r: r.cross_current_mps, CROSS_CURRENT_EDGES_MPS),
    }
    bins: dict[str, dict[str, dict[str, Any]]] = {}
    for name, (value, edges) in keys.items():
        groups: dict[str, list[EpisodeResult]] = {}
        for r in results:
            groups.setdefault(_bin_label(value(r), edges), []).append(r)
        bins[name] = {label: _bin_summary(group) for label, group in
                      sorted(groups.items(), key=lambda item: float(item[0].lstrip(">=").split("-")[0]))}
    return bins


def _bin_summary(group: list[EpisodeResult]) -> dict[str, Any]:
    docked = sum(r.success for r in group)
    failures = dict(Counter(r.reason for r in group if not r.success))
    return {"episodes": len(group), "docked": docked, "rate": docked / len(group),
            "retries": sum(r.retries for r in group), "failures": failures}


def plot_envelope(results: list[EpisodeResult], folder: Path, title: str = "") -> Path:
    """Success over the start's angle off the dock's axis and the current across it, as one PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder.mkdir(parents=True, exist_ok=True)
    off_edges = np.array([*OFF_AXIS_EDGES_DEG, 40.0])
    cross_edges = np.array([*CROSS_CURRENT_EDGES_MPS, 0.3])
    rate = np.full((len(cross_edges) - 1, len(off_edges) - 1), np.nan)
    count = np.zeros_like(rate, dtype=int)
    docked = np.zeros_like(rate, dtype=int)
    for r in results:
        i = min(int(np.searchsorted(cross_edges, r.cross_current_mps, side="right")) - 1, len(cross_edges) - 2)
        j = min(int(np.searchsorted(off_edges, r.start_off_axis_deg, side="right")) - 1, len(off_edges) - 2)
        count[i, j] += 1
        docked[i, j] += r.success
    rate[count > 0] = docked[count > 0] / count[count > 0]
    fig, ax = plt.subplots(figsize=(7, 4.8))
    image = ax.pcolormesh(off_edges, cross_edges, rate, vmin=0.0, vmax=1.0, cmap="RdYlGn")
    for i in range(rate.shape[0]):
        for j in range(rate.shape[1]):
            if count[i, j]:
                ax.text(0.5 * (off_edges[j] + off_edges[j + 1]), 0.5 * (cross_edges[i] + cross_edges[i + 1]),
                        f"{docked[i, j]}/{count[i, j]}", ha="center", va="center", fontsize=9)
    fig.colorbar(image, ax=ax, label="share docked")
    ax.set_xlabel("start: angle off the dock's axis, seen from the dock (deg)")
    ax.set_ylabel("current across the dock's axis (m/s)")
    ax.set_title(f"{title} docked / episodes by start".strip())
    fig.tight_layout()
    path = folder / "success_envelope.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot(results: list[EpisodeResult], folder: Path, entrance_radius: float = 0.35, title: str = "") -> list[Path]:
    """Top and side views of every trajectory (of the nose, in the dock's frame, up to the
    entrance plane), with where each guidance state began when there are few, and the
    bearings over time, as PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for view, (index, label) in {"top": (2, "left of the dock's axis (m)"),
                                 "side": (3, "above the dock's axis (m)")}.items():
        fig, ax = plt.subplots(figsize=(9, 3.6))
        for r in results:
            track = np.array([(p[0], p[1], p[index]) for p in r.trajectory])
            if len(track):
                ax.plot(track[:, 1], track[:, 2], color="tab:green" if r.success else "tab:red", lw=0.8, alpha=0.7)
                if len(results) <= STATE_MARKS_UP_TO:
                    _mark_states(ax, track, r.states)
        ax.axvline(0.0, color="0.6", lw=0.8, ls="--", label="entrance plane")
        ax.plot([0.0, 0.0], [-entrance_radius, entrance_radius], color="k", lw=3)
        if len(results) <= STATE_MARKS_UP_TO:
            ax.legend(fontsize=7, loc="best")
        ax.set_xlabel("along the dock's axis (m, 0 = entrance plane)")
        ax.set_ylabel(label)
        ax.set_title(f"{title} {view} view: green docked, red failed".strip())
        ax.grid(alpha=0.3)
        fig.tight_layout()
        path = folder / f"trajectories_{view}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    fig, axes = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    for r in results:
        if r.bearing_errors:
            b = np.array(r.bearing_errors)
            axes[0].plot(b[:, 0], b[:, 1], lw=0.6, alpha=0.6)
            axes[1].plot(b[:, 0], b[:, 2], lw=0.6, alpha=0.6)
    axes[0].set_ylabel("yaw bearing (deg)")
    axes[1].set_ylabel("pitch bearing (deg)")
    axes[1].set_xlabel("time (s)")
    axes[0].set_title(f"{title} bearing to the dock as the camera saw it".strip())
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.tight_layout()
    path = folder / "bearing_errors.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    paths.append(path)
    return paths


def _mark_states(ax: Any, track: np.ndarray, states: list[tuple[float, str]]) -> None:
    """A marker where each state began, on a (t, along, across) track; each state in the legend once."""
    labelled = set(ax.get_legend_handles_labels()[1])
    for t, state in states:
        if not track[0, 0] <= t <= track[-1, 0]:
            continue
        along = float(np.interp(t, track[:, 0], track[:, 1]))
        across = float(np.interp(t, track[:, 0], track[:, 2]))
        marker, color = STATE_STYLES.get(state, ("D", "k"))
        label = None if state in labelled else state
        labelled.add(state)
        ax.plot([along], [across], marker=marker, color=color, ms=7, ls="none", label=label, zorder=3)
