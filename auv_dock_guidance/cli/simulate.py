"""`auv-dock simulate`: Monte Carlo docking runs in the simulated pool."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from auv_dock_guidance.cli.common import (
    folder_to_write,
    non_negative_float,
    positive_int,
    print_json,
    rate_hz,
    seed,
    workers,
)
from auv_dock_guidance.cli.progress import Progress
from auv_dock_guidance.sim.closed_loop import EpisodeConfig
from auv_dock_guidance.sim.monte_carlo import plot, run_many, summarize


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "simulate",
        help="Monte Carlo docking runs in the simulated pool (the paper's trials, many times over)",
        description="Each episode starts 8-15 m from the dock, up to 2 m to the side, 1 m off its "
        "depth and 20 deg off its heading, and runs the real detector, guidance and mixer on "
        "rendered frames (960x540, scaled intrinsics) against the vehicle dynamics.",
    )
    p.add_argument("--episodes", type=positive_int, default=200)
    p.add_argument("--seed", type=seed, default=1)
    p.add_argument("--scenario", choices=["clear", "reflection"], default="clear")
    p.add_argument("--workers", type=workers, default=os.cpu_count() or 1)
    p.add_argument("--tracker", action="store_true", help="smooth detections with the Kalman target tracker")
    p.add_argument("--axis-alignment", action="store_true", help="steer onto the dock's axis before the terminal phase")
    p.add_argument("--current", type=non_negative_float, default=0.0, metavar="M_S",
                   help="largest random water current (m/s)")
    p.add_argument("--camera-hz", type=rate_hz, default=10.0, help="simulated camera rate (default %(default)s)")
    p.add_argument("--plots", metavar="DIR", type=folder_to_write, help="write trajectory and bearing plots (PNG) here")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    config = EpisodeConfig(scenario=args.scenario, tracker=args.tracker, axis_alignment=args.axis_alignment,
                           current_mps=args.current, camera_hz=args.camera_hz)
    progress = Progress(f"simulate {args.scenario}", args.episodes)
    results = run_many(config, args.episodes, args.seed, args.workers, progress)
    report = summarize(results)
    report.update(scenario=args.scenario, tracker=args.tracker, axis_alignment=args.axis_alignment, seed=args.seed)
    if args.plots:
        report["plots"] = [str(p) for p in plot(results, Path(args.plots), title=args.scenario)]
    if args.json:
        print_json(report)
        return 0
    low, high = report["success_ci95"]
    print(f"scenario {args.scenario}: docked {report['successes']}/{report['episodes']} "
          f"({100 * report['success_rate']:.1f} %, 95 % CI {100 * low:.1f}-{100 * high:.1f} %)")
    print(f"failures: {report['failures'] or 'none'}")
    if report["docking_time_s_median"] is not None:
        print(f"docking time median {report['docking_time_s_median']:.1f} s")
    if report["entry_lateral_error_m_p50"] is not None:
        print(f"entry lateral error p50 {report['entry_lateral_error_m_p50']:.3f} m, "
              f"p95 {report['entry_lateral_error_m_p95']:.3f} m; heading error p95 "
              f"{report['entry_heading_error_deg_p95']:.1f} deg")
    print(f"largest range with a detection: {report['max_detection_range_m']}")
    for path in report.get("plots", []):
        print(f"wrote {path}")
    return 0
