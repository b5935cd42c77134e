"""`auv-dock bench`: measured timings (never asserted in tests)."""

from __future__ import annotations

import argparse
import os
import random
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from auv_dock_guidance.cli.common import positive_float, positive_int, print_json, rounded
from auv_dock_guidance.cli.progress import Progress
from auv_dock_guidance.geometry.camera import paper_camera
from auv_dock_guidance.launcher import NodeGroup, ros_environment
from auv_dock_guidance.sim.main_controller import MainControllerSim
from auv_dock_guidance.sim.scene import SceneSpec, render


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "bench",
        help="timings: detector modes against the paper's baseline, and frame-to-PWM latency",
        description="--latency runs the four nodes as processes on 1080p frames at 30 Hz and times "
        "each frame from publication to its thruster command on the serial line.",
    )
    p.add_argument("--latency", action="store_true", help="only the frame-to-PWM latency through the nodes")
    p.add_argument("--seconds", type=positive_float, default=15.0, help="latency run length (default %(default)s)")
    p.add_argument("--rate", type=positive_float, default=30.0, help="camera rate in Hz (default %(default)s)")
    p.add_argument("--frames", type=positive_int, default=120, help="frames for the detector timings")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    report = latency_bench(args.seconds, args.rate)
    if args.json:
        print_json(report)
    else:
        for key, value in report.items():
            print(f"{key:24}{value}")
    return 0 if report["frames"] else 1


def _approach_frames(folder: Path, count: int = 12) -> None:
    camera = paper_camera()
    rng = np.random.default_rng(0)
    for i in range(count):
        z = 14.0 - i
        spec = SceneSpec(marker_center_m=(float(rng.uniform(-1, 1)), float(rng.uniform(-0.5, 0.5)), z), seed=i)
        cv2.imwrite(str(folder / f"frame_{i:03d}.png"), render(camera, spec)[0])


def latency_bench(seconds: float, rate_hz: float) -> dict[str, object]:
    """Frame publish -> thruster command on the serial line, across the real node processes."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from std_msgs.msg import Bool, Float64

    domain = random.Random(os.getpid()).randint(30, 200)
    with tempfile.TemporaryDirectory(prefix="auv-dock-bench-") as tmp:
        folder = Path(tmp) / "frames"
        folder.mkdir()
        _approach_frames(folder)
        controller = MainControllerSim().start()
        group = NodeGroup(
            ["camera_ingest", "detector", "guidance", "serial_bridge"],
            overrides={
                "camera_ingest": {"source": "folder", "path": str(folder), "loop": True, "rate_hz": rate_hz},
                "serial_bridge": {"port": controller.port, "arm_on_start": True},
                "detector": {"debug_image_rate_hz": 0.0},
            },
            env=ros_environment(domain_id=domain),
            log_dir=Path(tmp) / "logs",
        )
        rclpy.init(domain_id=domain)
        node = rclpy.create_node("latency_bench")
        latencies: list[float] = []
        processed = [0]
        published = [0]

        def on_diagnostics(msg: DiagnosticArray) -> None:
            for status in msg.status:
                if status.name.endswith("camera_ingest"):
                    published[0] = int(next(v.value for v in status.values if v.key == "frames"))

        node.create_subscription(Float64, "bridge/latency", lambda m: latencies.append(m.data), 100)
        node.create_subscription(Bool, "dock/detected", lambda m: processed.__setitem__(0, processed[0] + 1), 100)
        node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, 10)
        group.start()
        progress = Progress("latency", int(seconds))
        try:
            warmup_end = time.monotonic() + 6.0  # start-up and DDS discovery
            while time.monotonic() < warmup_end:
                rclpy.spin_once(node, timeout_sec=0.1)
            latencies.clear()
            start_published, start_processed = published[0], processed[0]
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                rclpy.spin_once(node, timeout_sec=0.1)
                progress(int(seconds - (end - time.monotonic())), int(seconds))
            settle = time.monotonic() + 1.5  # the last diagnostics and latencies
            while time.monotonic() < settle:
                rclpy.spin_once(node, timeout_sec=0.1)
            frames = published[0] - start_published
            handled = processed[0] - start_processed
        finally:
            node.destroy_node()
            rclpy.try_shutdown()
            group.stop()
            controller.stop()
    ms = np.array(latencies) * 1000.0
    return {
        "frames": frames,
        "frames_processed": handled,
        "frames_dropped": max(0, frames - handled),
        "commands_timed": int(ms.size),
        "latency_ms_p50": rounded(float(np.percentile(ms, 50)), 2) if ms.size else None,
        "latency_ms_p95": rounded(float(np.percentile(ms, 95)), 2) if ms.size else None,
        "latency_ms_max": rounded(float(ms.max()), 2) if ms.size else None,
        "rate_hz": rate_hz,
    }
