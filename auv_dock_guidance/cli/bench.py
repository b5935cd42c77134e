"""`auv-dock bench`: measured timings (never asserted in tests)."""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from auv_dock_guidance.cli.common import domain_id, positive_float, positive_int, print_json, rate_hz, rounded
from auv_dock_guidance.cli.progress import Progress
from auv_dock_guidance.geometry.camera import paper_camera
from auv_dock_guidance.launcher import (
    VISION_COMBINED,
    VISION_SEPARATE,
    NodeGroup,
    announce,
    private_domain_id,
    registered,
    ros_environment,
    rss_mb,
    stop_on_signals,
)
from auv_dock_guidance.sim.main_controller import MainControllerSim
from auv_dock_guidance.sim.scene import Lamp, SceneSpec, render
from auv_dock_guidance.vision.detector import Detector, DetectorConfig, PaperBaseline


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "bench",
        help="timings: detector modes against the paper's baseline, and frame-to-PWM latency",
        description="--latency runs the four nodes as processes on 1080p frames at 30 Hz and times "
        "each frame from publication to its thruster command on the serial line.",
    )
    p.add_argument("--latency", action="store_true", help="only the frame-to-PWM latency through the nodes")
    p.add_argument("--compare", action="store_true",
                   help="the latency run twice, the detector's tracking off and on (same frames, same load)")
    p.add_argument("--seconds", type=positive_float, default=15.0, help="latency run length (default %(default)s)")
    p.add_argument("--rate", type=rate_hz, default=30.0, help="camera rate in Hz (default %(default)s)")
    p.add_argument("--separate-vision", action="store_true", help="camera_ingest and detector as two processes")
    p.add_argument("--frames", type=positive_int, default=120,
                   help="frames for the detector timings (default %(default)s)")
    p.add_argument("--domain-id", type=domain_id, help="ROS_DOMAIN_ID of the nodes (default: a free one from 30-200)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    report: dict[str, Any] = {}
    if not args.latency:
        report.update(detector_bench(args.frames))
    domain = args.domain_id if args.domain_id is not None else private_domain_id()
    with stop_on_signals(), registered(domain, "bench --latency"):
        announce(domain, sys.stderr if args.json else sys.stdout)
        if args.compare:
            runs = {f"tracking_{state}": latency_bench(args.seconds, args.rate, not args.separate_vision, domain,
                                                       tracking)
                    for state, tracking in (("off", False), ("on", True))}
            report.update(runs)
            off, on = runs["tracking_off"]["latency_ms_p95"], runs["tracking_on"]["latency_ms_p95"]
            report["tracking_speedup_p95"] = rounded(off / on, 2) if off and on else None
            complete = all(run["frames"] for run in runs.values())
        else:
            report.update(latency_bench(args.seconds, args.rate, not args.separate_vision, domain))
            complete = bool(report["frames"])
    if args.json:
        print_json(report)
    else:
        for key, value in report.items():
            for name, item in value.items() if isinstance(value, dict) else [("", value)]:
                print(f"{key + ('.' + name if name else ''):36}{item}")
    return 0 if complete else 1


# The benched marker is the renderer's continuous strip, and the detectors are told so, as a
# user describes a marker (marker_led_count): with the count unknown, the search for rings
# of separate LEDs runs too (about 7 ms more per full frame on the 2-core machine).
_MARKER_LEDS = 0


def _bench_sequence(count: int) -> list[tuple[np.ndarray, tuple[float, float] | None]]:
    """A fixed approach, 15 m to 2.5 m, with a surface reflection and a lamp: (1080p frame, true centre)."""
    camera = paper_camera()
    frames = []
    for i in range(count):
        share = i / max(count - 1, 1)
        spec = SceneSpec(
            marker_center_m=(0.8 * (1 - share), 0.4 * (1 - share) + 0.1, 15.0 - 12.5 * share),
            marker_normal=(0.1, 0.0, -1.0), brightness=3.0, attenuation_per_m=0.08, surface_height_m=1.6,
            reflection_gain=0.9, ripple_m=0.02, lamps=(Lamp(300.0, 900.0, 5.0, 2.0),), seed=1000 + i,
        )
        image, truth = render(camera, spec)
        frames.append((image, truth.center_px))
    return frames


def detector_bench(count: int) -> dict[str, Any]:
    """The paper's literal full-frame pipeline against our full-frame and tracking modes, same frames."""
    frames = _bench_sequence(count)
    camera = paper_camera()
    modes = {
        "baseline": PaperBaseline(camera),
        "full_frame": Detector(camera, DetectorConfig(led_count=_MARKER_LEDS)),
        "tracking": Detector(camera, DetectorConfig(led_count=_MARKER_LEDS, tracking=True)),
    }
    results: dict[str, list] = {}
    times: dict[str, np.ndarray] = {}
    progress = Progress("detector modes", len(modes) * count)
    done = 0
    for name, detector in modes.items():
        detector.detect(frames[0][0])  # warm caches before timing
        detector.reset()
        elapsed, out = [], []
        for image, _ in frames:
            start = time.perf_counter()
            out.append(detector.detect(image))
            elapsed.append(time.perf_counter() - start)
            done += 1
            progress(done, len(modes) * count)
        results[name], times[name] = out, np.array(elapsed)
    report: dict[str, Any] = {"frames_per_mode": count}
    for name in modes:
        t = times[name]
        report[f"{name}_fps"] = rounded(1.0 / float(np.mean(t)), 1)
        report[f"{name}_ms_p50"] = rounded(float(np.percentile(t, 50)) * 1000, 2)
        report[f"{name}_ms_p95"] = rounded(float(np.percentile(t, 95)) * 1000, 2)
        report[f"{name}_detection_rate"] = rounded(sum(d.found for d in results[name]) / count, 3)
        errors = [math.hypot(d.u - c[0], d.v - c[1])
                  for d, (_, c) in zip(results[name], frames, strict=True) if d.found and c]
        report[f"{name}_center_error_px_p95"] = rounded(float(np.percentile(errors, 95)), 2) if errors else None
    base = float(np.mean(times["baseline"]))
    report["tracking_p95_over_p50"] = rounded(report["tracking_ms_p95"] / report["tracking_ms_p50"], 2)
    report["full_frame_speedup"] = rounded(base / float(np.mean(times["full_frame"])), 2)
    report["tracking_speedup"] = rounded(base / float(np.mean(times["tracking"])), 2)
    # Agreement where the baseline found the marker itself (not a lamp or the reflection).
    on_marker = [b.found and c is not None and math.hypot(b.u - c[0], b.v - c[1]) < max(5.0, 0.5 * b.radius_px)
                 for b, (_, c) in zip(results["baseline"], frames, strict=True)]
    report["baseline_wrong_object_frames"] = sum(b.found for b in results["baseline"]) - sum(on_marker)
    disagreement = [
        max(math.hypot(d.u - b.u, d.v - b.v), abs(d.radius_px - b.radius_px))
        for name in ("full_frame", "tracking")
        for d, b, ok in zip(results[name], results["baseline"], on_marker, strict=True) if ok and d.found
    ]
    report["max_center_disagreement_px"] = rounded(max(disagreement), 3) if disagreement else None
    return report


def _approach_frames(folder: Path, count: int = 8) -> None:
    """A loop the camera plays over and over (few frames: the camera holds them decoded, in the
    vision process): the dock drifts round a small ellipse in view while the range swings
    between 7.4 and 8.6 m, 10-20 px a frame, with a surface reflection and a lamp; the last
    frame leads back to the first."""
    camera = paper_camera()
    for i in range(count):
        angle = 2.0 * math.pi * i / count
        spec = SceneSpec(
            marker_center_m=(0.3 + 0.1 * math.cos(angle), 0.3 + 0.06 * math.sin(angle), 8.0 + 0.6 * math.sin(angle)),
            marker_normal=(0.1, 0.0, -1.0), brightness=3.0, attenuation_per_m=0.08, surface_height_m=1.6,
            reflection_gain=0.9, ripple_m=0.02, lamps=(Lamp(300.0, 900.0, 5.0, 2.0),), seed=i,
        )
        cv2.imwrite(str(folder / f"frame_{i:03d}.png"), render(camera, spec)[0])


def latency_bench(seconds: float, rate_hz: float, combined_vision: bool = True,
                  domain: int | None = None, tracking: bool = True) -> dict[str, Any]:
    """Frame capture -> thruster command on the serial line, across the real node processes.

    Its caller handles the stop signals (launcher.stop_on_signals): a stop ends the nodes in
    the finally below, the serial bridge first."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.signals import SignalHandlerOptions
    from std_msgs.msg import Float64

    from auv_dock_guidance.nodes.common import destroy_and_shut_down

    domain = domain if domain is not None else private_domain_id()
    with tempfile.TemporaryDirectory(prefix="auv-dock-bench-") as tmp:
        folder = Path(tmp) / "frames"
        folder.mkdir()
        _approach_frames(folder)
        controller = MainControllerSim().start()
        group = NodeGroup(
            VISION_COMBINED if combined_vision else VISION_SEPARATE,
            overrides={
                "camera_ingest": {"source": "folder", "path": str(folder), "loop": True, "rate_hz": float(rate_hz)},
                "serial_bridge": {"port": controller.port, "arm_on_start": True},
                "detector": {"debug_image_rate_hz": 0.0, "tracking": tracking, "marker_led_count": _MARKER_LEDS},
            },
            env=ros_environment(domain_id=domain),
            log_dir=Path(tmp) / "logs",
        )
        rclpy.init(domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
        node = rclpy.create_node("latency_bench")
        latencies: list[float] = []
        counts = {"captured": 0, "processed": 0, "skipped": 0}  # as the nodes last reported them

        def on_diagnostics(msg: DiagnosticArray) -> None:
            for status in msg.status:
                values = {v.key: v.value for v in status.values}
                if status.name.endswith("camera_ingest"):
                    counts["captured"] = int(values["frames"])
                elif status.name.endswith("detector"):  # one report: processed and skipped agree
                    counts["processed"], counts["skipped"] = int(values["frames_processed"]), \
                        int(values["frames_skipped"])

        def on_latency(msg: Float64) -> None:
            latencies.append(msg.data)

        node.create_subscription(Float64, "bridge/latency", on_latency, 100)
        node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, 10)
        progress = Progress("latency", int(seconds))
        try:
            group.start()
            warmup_end = time.monotonic() + 6.0  # start-up and DDS discovery
            while time.monotonic() < warmup_end:
                rclpy.spin_once(node, timeout_sec=0.1)
            latencies.clear()
            start = dict(counts)
            vision = group.processes["vision_pipeline" if combined_vision else "detector"].pid
            start_rss = rss_mb(vision)
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                rclpy.spin_once(node, timeout_sec=0.1)
                progress(int(seconds - (end - time.monotonic())), int(seconds))
            settle = time.monotonic() + 1.5  # the last diagnostics and latencies
            while time.monotonic() < settle:
                rclpy.spin_once(node, timeout_sec=0.1)
            seen = {key: counts[key] - start[key] for key in counts}
            vision_rss = rss_mb(vision)
        finally:
            group.stop()
            controller.stop()
            destroy_and_shut_down([node])
    ms = np.array(latencies) * 1000.0
    return {
        "frames": seen["processed"] + seen["skipped"],  # that reached the detector (frames_captured: left the camera)
        "frames_processed": seen["processed"],
        "frames_dropped": seen["skipped"],
        "frames_captured": seen["captured"],
        "commands_timed": int(ms.size),
        "latency_ms_p50": rounded(float(np.percentile(ms, 50)), 2) if ms.size else None,
        "latency_ms_p95": rounded(float(np.percentile(ms, 95)), 2) if ms.size else None,
        "latency_ms_max": rounded(float(ms.max()), 2) if ms.size else None,
        "rate_hz": rate_hz,
        # the detector's process after the run (with camera_ingest when they share one)
        "detector_rss_mb": rounded(vision_rss, 1),
        "detector_rss_growth_mb": rounded(vision_rss - start_rss, 1),  # from the end of the warm-up
    }
