"""`auv-dock soak`: the full simulated system for a long run, with faults injected and survived.

Faults, in turn, each while the vehicle is tracking the dock: the navigation stops
sending telemetry for 1.5 s; the guidance node is killed (and restarted); the detector
node is killed (and restarted). For each it checks that neutral pulses reach the main
controller within its deadline, and that the system tracks the dock again afterwards.
When the vehicle docks or stalls it is put back at a new start and guidance re-armed.
"""

from __future__ import annotations

import argparse
import math
import signal
import tempfile
import time
from pathlib import Path

import numpy as np

from auv_dock_guidance.cli.common import positive_float, print_json, rounded
from auv_dock_guidance.cli.progress import Progress
from auv_dock_guidance.launcher import rss_mb
from auv_dock_guidance.sim.world import PoolWorld, VehiclePose

NEUTRAL = (1500, 1500, 1500, 1500)
FAULTS = ("telemetry_pause", "guidance_killed", "detector_killed")


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("soak", help="long run of the simulated system with faults injected",
                              description=__doc__.split("\n\n")[0])
    p.add_argument("--minutes", type=positive_float, default=5.0)
    p.add_argument("--fault-every", type=positive_float, default=25.0, metavar="S", help="seconds between faults")
    p.add_argument("--json", action="store_true")
    p.set_defaults(run=run)


def _start_pose(rng: np.random.Generator, world: PoolWorld) -> VehiclePose:
    return VehiclePose(world.dock_x_m - rng.uniform(10, 14), rng.uniform(-1.5, 1.5),
                       -world.dock_depth_m + rng.uniform(-0.8, 0.8), yaw=math.radians(rng.uniform(-10, 10)))


def run(args: argparse.Namespace) -> int:
    from std_msgs.msg import Bool, String

    from auv_dock_guidance.sim_system import SimulatedSystem

    rng = np.random.default_rng(5)
    world = PoolWorld(reflection=True)
    logs = Path(tempfile.mkdtemp(prefix="auv-dock-soak-"))
    system = SimulatedSystem(world, _start_pose(rng, world), logs)
    state = {"value": "starting"}
    frames = [0]
    system.node.create_subscription(String, "guidance/state", lambda m: state.__setitem__("value", m.data), 10)
    system.node.create_subscription(Bool, "dock/detected", lambda m: frames.__setitem__(0, frames[0] + 1), 100)
    system.start()
    group = system.group
    deadline_s = 0.2 + 0.05  # the bridge's failsafe timeout plus two 50 Hz ticks
    telemetry_deadline_s = 0.5 + 0.1  # guidance's telemetry timeout plus a control tick and transport
    injected: list[str] = []
    survived: list[str] = []
    misses: list[str] = []
    dockings = 0
    t0 = time.monotonic()
    end = t0 + args.minutes * 60.0
    progress = Progress("soak", int(args.minutes * 60))
    rss_start = rss_end = 0.0
    try:
        system.spin(12.0)  # start-up, discovery, first lock
        rss_start = sum(rss_mb(p.pid) for p in group.processes.values())
        next_fault = time.monotonic() + args.fault_every
        while time.monotonic() < end:
            system.spin(0.2)
            progress(int(time.monotonic() - t0), int(args.minutes * 60))
            range_left = world.dock_x_m - world.camera_position(system.vehicle.pose)[0]
            if system.nose_past_dock() or range_left < 1.0 or state["value"] in ("DOCKED", "ABORT"):
                dockings += system.nose_past_dock()
                system.reposition(_start_pose(rng, world))
                continue
            if time.monotonic() >= next_fault and state["value"] == "TRACK" and range_left > 4.0:
                fault = FAULTS[len(injected) % len(FAULTS)]
                injected.append(fault)
                ok, miss = _inject(fault, system, deadline_s, telemetry_deadline_s, state)
                if miss:
                    misses.append(miss)
                if ok:
                    survived.append(fault)
                next_fault = time.monotonic() + args.fault_every
        rss_end = sum(rss_mb(p.pid) for p in group.processes.values())
    except KeyboardInterrupt:
        rss_end = sum(rss_mb(p.pid) for p in group.processes.values())
    finally:
        codes = system.stop()
    minutes = (time.monotonic() - t0) / 60.0
    report = {
        "minutes": rounded(minutes, 2), "frames": frames[0], "deadline_misses": len(misses),
        "rss_start_mb": rounded(rss_start, 1), "rss_end_mb": rounded(rss_end, 1),
        "rss_growth_pct": rounded(100.0 * (rss_end - rss_start) / rss_start, 1) if rss_start else None,
        "faults_injected": len(injected), "faults_survived": len(survived), "dockings": dockings,
        "faults": injected, "misses": misses, "node_exit_codes": codes, "logs": str(logs),
    }
    if args.json:
        print_json(report)
    else:
        for key, value in report.items():
            print(f"{key:18}{value}")
    return 0 if not misses and len(survived) == len(injected) else 1


def _inject(fault: str, system, deadline_s: float, telemetry_deadline_s: float, state: dict) -> tuple[bool, str | None]:
    """Inject one fault; (survived, deadline miss description or None)."""
    controller, group = system.controller, system.group
    start = time.monotonic()
    if fault == "telemetry_pause":
        controller.pause_telemetry(1.5)
        limit = telemetry_deadline_s
    else:
        node = "guidance" if fault == "guidance_killed" else "vision_pipeline"  # the detector's process
        group.processes[node].send_signal(signal.SIGKILL)
        group.processes[node].wait(timeout=5)
        limit = deadline_s if node == "guidance" else 1.0 + telemetry_deadline_s  # camera timeout for the detector
    system.spin(2.0)
    records = [r for r in controller.records() if r.time_s >= start - 1.0]
    driving = [r for r in records if r.pwm_us != NEUTRAL and r.time_s < start + 0.05]
    neutral = [r for r in records if r.pwm_us == NEUTRAL and r.time_s >= start]
    miss = None
    if driving and neutral:
        delay = neutral[0].time_s - max(start, driving[-1].time_s) if fault == "telemetry_pause" \
            else neutral[0].time_s - driving[-1].time_s
        if delay > limit:
            miss = f"{fault}: neutral after {1000 * delay:.0f} ms (limit {1000 * limit:.0f} ms)"
    elif driving and not neutral:
        miss = f"{fault}: no neutral command reached the controller"
    if fault != "telemetry_pause":
        group.restart("guidance" if fault == "guidance_killed" else "vision_pipeline")
        if fault == "guidance_killed":
            system.spin(4.0)
            system.reposition(system.vehicle.pose)  # the new guidance starts in SEARCH anyway
    recovered_by = time.monotonic() + 25.0
    while time.monotonic() < recovered_by:
        system.spin(0.2)
        if state["value"] == "TRACK" and not group.exited():
            return True, miss
    return False, miss
