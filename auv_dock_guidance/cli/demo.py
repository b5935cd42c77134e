"""`auv-dock demo`: the main job. The whole system as real ROS 2 nodes on a simulated vehicle.

This process is the simulator: the vehicle dynamics behind a simulated main controller on
a pseudo-terminal, and the vehicle pose on ``sim/vehicle_pose``. camera_ingest renders
what the camera sees from that pose; detector, guidance and serial_bridge run as on the
vehicle. The run ends when the nose crosses the dock's entrance plane (or on a failure),
and leaves a report folder: a plot, a JSON summary and an MCAP bag of the debug topics.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from datetime import datetime
from pathlib import Path
from typing import Any

from auv_dock_guidance.cli.common import domain_id, fail, folder_to_write, positive_float
from auv_dock_guidance.launcher import StopRequested, announce, private_domain_id, registered, stop_on_signals
from auv_dock_guidance.sim.closed_loop import EpisodeResult, entry_outcome, nose_in_dock_frame
from auv_dock_guidance.sim.monte_carlo import plot
from auv_dock_guidance.sim.report import OverlayFrame, distance_to_entrance, write_run_pictures
from auv_dock_guidance.sim.world import PoolWorld, VehiclePose

# Guidance leaves an ABORT for lost telemetry or camera by itself once both have been healthy for
# recovery_s (2 s), as on a vehicle, so a busy computer's hiccup does not end the run; an ABORT
# still standing after this long is final.
ABORT_FINAL_S = 8.0


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "demo",
        help="the main job: all nodes docking a simulated vehicle, with a report folder",
        description="Run camera_ingest, detector, guidance and serial_bridge as ROS 2 processes "
        "against a simulated vehicle and main controller in the paper's pool, 12 m out, 1 m to "
        "the side and 0.5 m above the dock, with the surface reflecting the ring.",
    )
    p.add_argument("--scenario", choices=["clear", "reflection"], default="reflection")
    p.add_argument("--report", metavar="DIR", type=folder_to_write, help="report folder (default reports/demo-<time>)")
    p.add_argument("--timeout", type=positive_float, default=100.0, help="give up after this many seconds")
    p.add_argument("--domain-id", type=domain_id, help="ROS_DOMAIN_ID of the nodes (default: a free one from 30-200)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    report = Path(args.report or f"reports/demo-{datetime.now():%Y%m%d-%H%M%S}")
    if report.exists() and any(report.iterdir()):
        fail(f"report folder {report} is not empty; choose another with --report")
    domain = args.domain_id if args.domain_id is not None else private_domain_id()
    with stop_on_signals(), registered(domain, "demo"):
        announce(domain)
        return _demo(args, report, domain)


def _demo(args: argparse.Namespace, report: Path, domain: int) -> int:
    import rclpy
    from geometry_msgs.msg import Vector3Stamped
    from sensor_msgs.msg import CompressedImage
    from std_msgs.msg import String

    from auv_dock_guidance.nodes.common import TRANSITION_QOS
    from auv_dock_guidance.recording import DEBUG_TOPICS, BagRecorder
    from auv_dock_guidance.sim_system import SimulatedSystem

    report.mkdir(parents=True, exist_ok=True)
    world = PoolWorld(reflection=args.scenario == "reflection")
    start = VehiclePose(x=world.dock_x_m - 12.0, y=1.0, z=-world.dock_depth_m + 0.5, yaw=math.radians(5.0))
    system = SimulatedSystem(world, start, report / "logs", domain_id=domain)
    node, controller = system.node, system.controller
    seen: dict[str, Any] = {"state": "starting", "bearing": None}

    states: list[tuple[float, str]] = []  # (s from the start, state entered)

    def on_state(m: String) -> None:
        seen["state"] = m.data
        if not states:  # the state guidance started in
            states.append((time.monotonic() - t0, m.data))

    transitions: list[str] = []

    def on_transition(m: String) -> None:
        print(f"  guidance: {m.data}", flush=True)
        transitions.append(m.data)
        states.append((time.monotonic() - t0, m.data.split(":", 1)[0].split("->")[-1].strip()))

    node.create_subscription(String, "guidance/state", on_state, 10)
    node.create_subscription(String, "guidance/transition", on_transition, TRANSITION_QOS)
    bearings: list[tuple[float, float, float]] = []
    t0 = time.monotonic()

    def on_bearing(m: Vector3Stamped) -> None:
        seen["bearing"] = m.vector
        bearings.append((time.monotonic() - t0, math.degrees(m.vector.x), math.degrees(m.vector.y)))

    node.create_subscription(Vector3Stamped, "dock/bearing", on_bearing, 10)
    overlays: list[OverlayFrame] = []  # what the shore sees: the detector's debug image

    def on_overlay(m: CompressedImage) -> None:
        overlays.append(OverlayFrame(time.monotonic() - t0, bytes(m.data)))

    node.create_subscription(CompressedImage, "dock/debug_image/compressed", on_overlay, 10)
    recorder = BagRecorder(node, report / "debug_bag", DEBUG_TOPICS)
    system.record_transforms(recorder)
    trajectory: list[tuple[float, float, float, float, float]] = []  # t, nose in the dock frame, yaw
    outcome = "timeout"
    lateral: float | None = None  # entry errors, once the nose crosses the entrance plane
    heading: float | None = None
    last_print = 0.0
    aborted_at: float | None = None  # s from the start when guidance entered the ABORT it is in
    try:
        system.start()
        print(f"demo: {args.scenario} pool, vehicle 12 m out, 1 m to the side, 0.5 m above the dock; "
              f"report in {report}", flush=True)
        while (elapsed := time.monotonic() - t0) < args.timeout:
            rclpy.spin_once(node, timeout_sec=0.05)
            p = controller.pose
            trajectory.append((elapsed, *nose_in_dock_frame(world, p), p.yaw))
            if elapsed - last_print >= 2.0:
                last_print = elapsed
                b = seen["bearing"]
                sight = f"range {b.z:5.2f} m  yaw {math.degrees(b.x):+6.2f}  pitch {math.degrees(b.y):+6.2f} deg" \
                    if b is not None else "no marker yet"
                to_dock = world.dock_x_m - world.camera_position(p)[0]
                print(f"  t={elapsed:5.1f} s  {seen['state']:<9} {sight}  (to dock {to_dock:5.2f} m)", flush=True)
            if system.nose_past_dock():
                outcome, lateral, heading = entry_outcome(world, p)
                break
            if seen["state"] != "ABORT":
                aborted_at = None
            elif aborted_at is None:
                aborted_at = elapsed
            elif elapsed - aborted_at > ABORT_FINAL_S:
                outcome = "abort"
                break
            if system.group.exited():
                outcome = f"node stopped: {system.group.exited()}"
                break
    except KeyboardInterrupt as exc:
        outcome = f"stopped by {exc}" if isinstance(exc, StopRequested) else "interrupted"
    finally:
        duration = time.monotonic() - t0
        recorder.close()
        codes = system.stop()
    result = EpisodeResult(0, outcome == "docked", outcome, duration, lateral, heading, None,
                           trajectory[::5] + trajectory[-1:], bearings, states)
    plots = plot([result], report, world.entrance_radius_m, title="demo")
    plots += write_run_pictures(report, overlays, states, (bearings[0][0], bearings[-1][0]) if bearings else None,
                                distance_to_entrance(trajectory), lateral is not None,
                                title=f"demo ({args.scenario} pool): what the camera saw, with the detector's overlay")
    summary = {
        "outcome": outcome, "docked": outcome == "docked", "time_s": round(duration, 2),
        "entry_lateral_error_m": lateral, "entry_heading_error_deg": heading, "scenario": args.scenario,
        "aborts": [line for line in transitions if "-> ABORT" in line],
        "frames_with_marker": len(bearings), "bag": str(report / "debug_bag"), "messages": recorder.counts,
        "plots": [str(p) for p in plots], "node_exit_codes": codes, "ros_domain_id": domain,
        # What a shore laptop receives if it subscribes to every debug topic at the defaults.
        "debug_traffic_kbit_s": round(8 * sum(recorder.bytes.values()) / max(duration, 1e-6) / 1000, 1),
        "debug_traffic_kbit_s_by_topic": {t: round(8 * b / max(duration, 1e-6) / 1000, 2)
                                          for t, b in sorted(recorder.bytes.items())},
    }
    (report / "summary.json").write_text(json.dumps(summary, indent=2))
    if outcome == "docked" and lateral is not None and heading is not None:
        print(f"docked in {duration:.1f} s (entry {100 * lateral:.1f} cm off centre, "
              f"heading {heading:.1f} deg off the axis)")
        if summary["aborts"]:
            print(f"  on the way guidance aborted {len(summary['aborts'])} time(s) and recovered: {summary['aborts']}")
    else:
        print(f"not docked: {outcome} after {duration:.1f} s")
    print(f"report: {report}/summary.json, {', '.join(p.name for p in plots)}, debug_bag/ (MCAP)")
    return 0 if outcome == "docked" else 1
