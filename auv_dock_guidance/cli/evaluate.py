"""`auv-dock evaluate` and `auv-dock edges-eval`: detector accuracy on rendered ground truth."""

from __future__ import annotations

import argparse
import os
from typing import Any

from auv_dock_guidance.cli.common import (
    add_camera_argument,
    approximate_lens,
    fail,
    load_camera,
    positive_float,
    positive_int,
    print_json,
    seed,
    workers,
)
from auv_dock_guidance.cli.detect import add_marker_arguments
from auv_dock_guidance.cli.labels import run_labels
from auv_dock_guidance.cli.progress import Progress
from auv_dock_guidance.sim.evaluate import (
    edge_comparison,
    population,
    real_dock_population,
    run_cases,
    run_frames,
    summarize,
    sweep_population,
    sweep_summary,
)
from auv_dock_guidance.sim.scenarios import ScenarioMix
from auv_dock_guidance.vision.detector import DetectorConfig


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "evaluate",
        help="detection rate and accuracy on rendered scenes with ground truth",
        description="Render scenes, detect, and compare with the ground truth. The default "
        "population (the paper's 1080p camera): 2-15 m, the ring whole in view, a third with "
        "surface reflections, some with lamps, some empty; with what real docks and pools add "
        "(uneven and dead LEDs, funnel glow, structure, caustics, particles, vignetting, JPEG) "
        "unless --plain. --population real-dock: what recorded footage of a dock shows (PAL "
        "720x576 cameras and video, 6-12 blooming LEDs around a lit funnel or a strip, rings "
        "cut by the frame and corners, green haze, tiled walls with ring-shaped fixtures, "
        "reflections, blooming lamps, empty frames). --range-sweep instead measures the "
        "detection rate per metre of range from 2 to 30 m.",
    )
    p.add_argument("--frames", type=positive_int, default=300, help="scenes to render (default %(default)s)")
    p.add_argument("--seed", type=seed, default=1, help="random seed of the scene population (default %(default)s)")
    p.add_argument("--range-sweep", action="store_true", help="detection rate per metre from 2 to 30 m")
    p.add_argument("--population", choices=("paper", "real-dock"), default="paper",
                   help="scenes to render: the paper's camera and marker (default), or real docks as "
                   "recorded video shows them, each frame through its own PAL camera")
    p.add_argument("--plain", action="store_true",
                   help="without the real-world effects (the clean population the paper's figures compare with)")
    p.add_argument("--frames-per-range", type=positive_int, default=20,
                   help="scenes per metre in the range sweep (default %(default)s)")
    p.add_argument("--attenuation", type=positive_float, default=0.08, metavar="PER_M",
                   help="beam attenuation of the water in the range sweep (default %(default)s /m: a clear pool)")
    p.add_argument("--brightness", type=positive_float, default=3.0,
                   help="LED radiance in the range sweep, in full-scale units (default %(default)s)")
    p.add_argument("--labels", metavar="LABELS.json",
                   help="instead of rendering: score detections on recorded frames against hand labels "
                   "(format and scoring rule in README); the frames are IMAGES, or those the labels name")
    p.add_argument("images", nargs="*", metavar="IMAGE",
                   help="with --labels: the frames to score (default: the labelled frames, next to the labels "
                   "file or in its frames/ folder)")
    add_marker_arguments(p)
    p.add_argument("--workers", type=workers, default=os.cpu_count() or 1,
                   help="processes rendering in parallel (default: all cores)")
    add_camera_argument(p, approximate=True)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(run=run_evaluate)

    e = subparsers.add_parser(
        "edges-eval",
        help="the paper's Table 1: traditional vs improved Canny (PSNR, Pratt's FOM)",
        description="Compare the traditional Canny (Gaussian + Sobel) with the improved one "
        "(bilateral + Scharr) on noisy renders whose clean edges are known.",
    )
    e.add_argument("--frames", type=positive_int, default=40, help="scenes (default %(default)s)")
    e.add_argument("--seed", type=seed, default=3, help="random seed (default %(default)s)")
    add_camera_argument(e)
    e.add_argument("--json", action="store_true", help="print one JSON object")
    e.set_defaults(run=run_edges)


def run_evaluate(args: argparse.Namespace) -> int:
    if args.labels is not None:
        return run_labels(args)
    if args.images:
        fail("images are scored only against labels: give --labels LABELS.json")
    if approximate_lens(args) is not None:
        fail("--focal-px and --hfov are for recorded frames (--labels); rendering needs a calibrated camera")
    marker_given = args.led_count is not None or args.led_colour is not None
    if marker_given or args.marker_radius != DetectorConfig.marker_radius_m:
        fail("the rendered population draws its own markers: --marker-radius, --led-count and --led-colour "
             "go with --labels")
    config = DetectorConfig()
    if args.population == "real-dock":
        for given, option in ((args.plain, "--plain"), (args.range_sweep, "--range-sweep"),
                              (args.camera_info, "--camera-info")):
            if given:
                fail(f"{option} applies to the paper population only: --population real-dock draws its own "
                     "PAL cameras and real-world look")
        cases = real_dock_population(args.frames, args.seed)
        report = summarize(run_cases(cases, config, args.workers, Progress("evaluate", len(cases))))
        report["population"] = args.population
        if args.json:
            print_json(report)
        else:
            _print_summary(report)
        return 0
    camera = load_camera(args.camera_info)
    mix = ScenarioMix(real_world=not args.plain)
    if args.range_sweep:
        specs = sweep_population(camera, range(2, 31), args.frames_per_range, args.seed,
                                 args.attenuation, args.brightness, mix)
        outcomes = run_frames(camera, config, specs, args.workers, Progress("range sweep", len(specs)))
        report = sweep_summary(outcomes)
        report.update(attenuation_per_m=args.attenuation, brightness=args.brightness)
        if args.json:
            print_json(report)
        else:
            print(f"detection rate by range (attenuation {args.attenuation} /m, brightness {args.brightness}):")
            for metre, rate in report["detection_rate_by_range_m"].items():
                print(f"  {metre:3d} m  {100 * rate:5.1f} %  " + "#" * round(40 * rate))
            print(f"detected in >= 95 % of frames up to {report['max_range_m_at_95pct']} m")
        return 0
    specs = population(camera, args.frames, args.seed, mix)
    outcomes = run_frames(camera, config, specs, args.workers, Progress("evaluate", len(specs)))
    report = summarize(outcomes)
    report["population"] = "paper-plain" if args.plain else "paper"
    if args.json:
        print_json(report)
    else:
        _print_summary(report)
    return 0


def _pct(value: float | None) -> str:
    return "n/a" if value is None else f"{100 * float(value):.1f} %"


def _num(value: float | None, unit: str, scale: float = 1.0, digits: int = 2) -> str:
    return "n/a" if value is None else f"{float(value) * scale:.{digits}f}{unit}"


def _print_summary(r: dict[str, Any]) -> None:
    """The report for a person; views apart only where the frame cut some rings."""
    views = bool(r["cut_frames"] or r["corner_frames"])
    if views:
        print(f"frames                 {r['frames']} ({r['marker_frames']} with half of the ring or more in view, "
              f"{r['corner_frames']} with a corner, {r['empty_frames']} empty)")
        print(f"detection rate         {_pct(r['detection_rate'])} (whole ring {_pct(r['detection_rate_whole'])} "
              f"of {r['whole_frames']}, cut by the frame {_pct(r['detection_rate_cut'])} of {r['cut_frames']})")
        print(f"corners found          {_pct(r['detection_rate_corner'])} of {r['corner_frames']} "
              f"(wrong object on {r['corner_wrong_object']})")
    else:
        print(f"frames                 {r['frames']} ({r['marker_frames']} with the marker, {r['empty_frames']} empty)")
        print(f"detection rate         {_pct(r['detection_rate'])}")
    print(f"false positives        {r['false_positives']} of {r['empty_frames']} empty frames")
    print(f"reflection chosen      {r['reflection_chosen']} of {r['reflection_frames']} frames with a reflection")
    print(f"wrong object chosen    {r['wrong_object']}")
    print(f"centre error           p50 {_num(r['center_error_px_p50'], ' px')}, "
          f"p95 {_num(r['center_error_px_p95'], ' px')}")
    print(f"range error            p50 {_num(r['range_error_rel_p50'], ' %', 100)}, "
          f"p95 {_num(r['range_error_rel_p95'], ' %', 100)}")
    if views:
        for view, name in (("whole", "whole ring"), ("cut", "cut ring")):
            print(f"  {name:<21}p50 {_num(r[f'range_error_rel_p50_{view}'], ' %', 100)}, "
                  f"p95 {_num(r[f'range_error_rel_p95_{view}'], ' %', 100)}")
    print(f"yaw error              p50 {_num(r['yaw_error_deg_p50'], ' deg', digits=3)}, "
          f"p95 {_num(r['yaw_error_deg_p95'], ' deg', digits=3)}")
    print(f"pitch error            p50 {_num(r['pitch_error_deg_p50'], ' deg', digits=3)}, "
          f"p95 {_num(r['pitch_error_deg_p95'], ' deg', digits=3)}")
    print(f"error in dock/pose's   across p50 {_num(r['pose_error_sigmas_across_p50'], '')}, "
          f"p95 {_num(r['pose_error_sigmas_across_p95'], '')}; range p50 {_num(r['pose_error_sigmas_range_p50'], '')}, "
          f"p95 {_num(r['pose_error_sigmas_range_p95'], '')}")
    print("  standard deviations  (a covariance that neither flatters nor hides the detector: p50 0.67, p95 1.96)")


def run_edges(args: argparse.Namespace) -> int:
    camera = load_camera(args.camera_info)
    report = edge_comparison(camera, args.frames, args.seed)
    if args.json:
        print_json(report)
        return 0
    print(f"{'method':<20}{'PSNR (dB)':>12}{'PFOM':>10}   ({report['frames']} noisy renders)")
    print(f"{'traditional Canny':<20}{report['traditional_psnr_db']:>12.2f}{report['traditional_pfom']:>10.3f}")
    print(f"{'improved Canny':<20}{report['improved_psnr_db']:>12.2f}{report['improved_pfom']:>10.3f}")
    print("paper (Table 1):    traditional 21.127 dB / 0.255, improved 23.118 dB / 0.513")
    return 0
