"""`auv-dock simulate`: Monte Carlo docking runs in the simulated pool or open water."""

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
from auv_dock_guidance.sim.closed_loop import SCENARIOS, STEERING, EpisodeConfig
from auv_dock_guidance.sim.monte_carlo import plot, plot_envelope, run_many, summarize
from auv_dock_guidance.sim.report import worst_episode_pictures


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "simulate",
        help="Monte Carlo docking runs in the simulated pool or open water (the paper's trials, many times over)",
        description="Pool (clear, reflection): each episode starts 8-15 m from the dock, up to 2 m to the "
        "side, 1 m off its depth and 20 deg off its heading. open-water: 10-30 m out, within 40 deg of "
        "the dock's axis (which points anywhere), heading within 40 deg of the line to the dock, depth "
        "within 2 m, a current of up to 0.3 m/s in any direction with slow gusts, no walls. Each runs "
        "the real detector, guidance and mixer on rendered frames (960x540, scaled intrinsics) against "
        "the vehicle dynamics.",
    )
    p.add_argument("--episodes", type=positive_int, default=200)
    p.add_argument("--seed", type=seed, default=1)
    p.add_argument("--scenario", choices=SCENARIOS, default="clear")
    p.add_argument("--workers", type=workers, default=os.cpu_count() or 1)
    p.add_argument("--steering", choices=list(STEERING), default="both",
                   help="plain: the paper's bearing homing; tracker: the dock tracked in the level frame, the "
                   "velocity crabbed into the estimated current; axis: lined up with the dock's axis; both "
                   "(default)")
    p.add_argument("--compare", action="store_true", help="run every --steering variant on the same episodes")
    p.add_argument("--current", type=non_negative_float, default=None, metavar="M_S",
                   help="largest random water current (m/s; default 0 in the pool, 0.3 in open water)")
    p.add_argument("--camera-hz", type=rate_hz, default=10.0, help="simulated camera rate (default %(default)s)")
    p.add_argument("--plots", metavar="DIR", type=folder_to_write,
                   help="write trajectory, bearing and success-envelope plots (PNG) here")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    variants = list(STEERING) if args.compare else [args.steering]
    reports = {}
    for steering in variants:
        config = EpisodeConfig(scenario=args.scenario, steering=steering, current_mps=args.current,
                               camera_hz=args.camera_hz)
        progress = Progress(f"simulate {args.scenario} {steering}", args.episodes)
        results = run_many(config, args.episodes, args.seed, args.workers, progress)
        report = summarize(results)
        report.update(scenario=args.scenario, steering=steering, seed=args.seed,
                      largest_current_mps=config.largest_current_mps())
        if args.plots:
            folder = Path(args.plots) / steering if args.compare else Path(args.plots)
            title = f"{args.scenario} {steering}"
            report["plots"] = [str(p) for p in [*plot(results, folder, title=title),
                                                plot_envelope(results, folder, title=title),
                                                *worst_episode_pictures(config, results, folder)]]
        reports[steering] = report
    if args.json:
        print_json(reports[args.steering] if not args.compare else {"comparison": reports})
        return 0
    if args.compare:
        _print_comparison(reports)
    for report in reports.values():
        _print_report(report)
    return 0


def _print_report(report: dict) -> None:
    low, high = report["success_ci95"]
    print(f"scenario {report['scenario']}, steering {report['steering']}: docked {report['successes']}/"
          f"{report['episodes']} ({100 * report['success_rate']:.1f} %, 95 % CI {100 * low:.1f}-{100 * high:.1f} %)")
    print(f"failures: {report['failures'] or 'none'}; retries {report['retries']} in "
          f"{report['episodes_with_retries']} episodes ({report['docked_after_retrying']} docked after retrying); "
          f"sidesteps {report['sidesteps']}")
    if report["docking_time_s_median"] is not None:
        print(f"docking time median {report['docking_time_s_median']:.1f} s")
    if report["entry_lateral_error_m_p50"] is not None:
        print(f"entry lateral error p50 {report['entry_lateral_error_m_p50']:.3f} m, "
              f"p95 {report['entry_lateral_error_m_p95']:.3f} m; heading error p50 "
              f"{report['entry_heading_error_deg_p50']:.1f} deg, p95 {report['entry_heading_error_deg_p95']:.1f} deg")
    print(f"largest range with a detection: {report['max_detection_range_m']}")
    for name, bins in report["by_start_bin"].items():
        print(f"  by {name}: " + ", ".join(f"{label} {b['docked']}/{b['episodes']}" for label, b in bins.items()))
    for path in report.get("plots", []):
        print(f"wrote {path}")


def _print_comparison(reports: dict[str, dict]) -> None:
    print("steering  docked       95 % CI         lateral p95  heading p95  retries  failures")
    for steering, r in reports.items():
        low, high = r["success_ci95"]
        lateral = r["entry_lateral_error_m_p95"]
        heading = r["entry_heading_error_deg_p95"]
        print(f"{steering:<9} {r['successes']:>4}/{r['episodes']:<6} {100 * low:5.1f}-{100 * high:5.1f} %   "
              f"{'-' if lateral is None else f'{100 * lateral:.1f} cm':>11}  "
              f"{'-' if heading is None else f'{heading:.1f} deg':>11}  {r['retries']:>7}  {r['failures'] or '-'}")
