"""`auv-dock soak`: the full simulated system for a long run, with faults injected and survived.

Faults, in turn, each while the vehicle is tracking the dock (farther than 4 m):

  telemetry_pause   the main controller sends no telemetry for 1.5 s
  guidance_killed   the guidance process is killed, and restarted 2 s later
  detector_killed   the vision process (camera and detector) is killed, and restarted
  camera_stalled    the vision process is frozen for 2.5 s (SIGSTOP), then resumed
  serial_unplugged  the main controller's serial device vanishes for 1.5 s, then returns
  line_noise        3 s of random bytes on the serial line between telemetry frames

What each must cause: neutral pulses at the main controller within the deadline (the
bridge's failsafe for a dead guidance; guidance's ABORT for lost telemetry or camera);
after a re-plug, neutral before anything else; through line noise, tracking goes on.
A reaction that comes too late is a deadline miss; one that is wrong (no neutral at all,
thrust right after a re-plug, an abort under line noise) is a wrong reaction. A fault is
survived when the system tracks the dock again within 30 s with every node process
running. When the vehicle docks or stalls it is put back at a new start and
guidance re-armed. A camera that falls silent for the soak as well as for guidance
(a vision process starved on a loaded machine) must stop the vehicle whatever fault
runs then: that ABORT is reported as a camera gap, not as a wrong reaction.
"""

from __future__ import annotations

import argparse
import bisect
import itertools
import math
import signal
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from auv_dock_guidance.cli.common import domain_id, positive_float, print_json, rounded
from auv_dock_guidance.cli.progress import Progress
from auv_dock_guidance.control.guidance import CAMERA_SILENT, GuidanceConfig, State
from auv_dock_guidance.launcher import StopRequested, announce, private_domain_id, registered, rss_mb, stop_on_signals
from auv_dock_guidance.sim.world import PoolWorld, VehiclePose

if TYPE_CHECKING:  # rclpy is imported only when a soak runs
    from auv_dock_guidance.sim_system import SimulatedSystem

NEUTRAL = (1500, 1500, 1500, 1500)
VISION = "vision_pipeline"  # the process of camera_ingest and detector
FAILSAFE_DEADLINE_S = 0.2  # neutral at the thrusters within 200 ms of the last command
TELEMETRY_DEADLINE_S = 0.5 + 0.1  # guidance's telemetry timeout plus a control tick and transport
CAMERA_TIMEOUT_S = GuidanceConfig.camera_timeout_s
CAMERA_DEADLINE_S = CAMERA_TIMEOUT_S + 0.6  # guidance's camera timeout, as above
GAP_SLACK_S = 0.2  # the soak and guidance time the same frames, each on its own schedule
RECOVERY_S = 30.0
TRACKING = {State.TRACK, State.TERMINAL, State.RETRY, State.DOCKED}  # states with the dock tracked


@dataclass(frozen=True)
class Fault:
    name: str
    inject: Callable[[SimulatedSystem], None]
    hold_s: float  # observed this long before it is cleared
    clear: Callable[[SimulatedSystem], None]
    neutral_within_s: float | None  # None: thrust must go on through it
    from_last_command: bool = False  # the deadline counts from the last command, not the fault
    neutral_after_s: float | None = None  # the link is down until then: the first command after it must be neutral


@dataclass(frozen=True)
class Outcome:
    reaction_ms: float | None = None  # time to neutral (to the link back, after a re-plug)
    late: str | None = None  # the deadline was missed
    wrong: str | None = None  # the reaction itself was wrong
    camera_gap: str | None = None  # guidance stopped for a camera the soak saw silent too: right under any fault


def _nothing(system: SimulatedSystem) -> None:
    pass


def _signal(process: str, sig: signal.Signals) -> Callable[[SimulatedSystem], None]:
    def send(system: SimulatedSystem) -> None:
        p = system.group.processes[process]
        p.send_signal(sig)
        if sig == signal.SIGKILL:
            p.wait(timeout=5)
    return send


def _restart(process: str) -> Callable[[SimulatedSystem], None]:
    return lambda system: system.group.restart(process)


def _line_noise(system: SimulatedSystem) -> None:
    rng = np.random.default_rng()
    end = time.monotonic() + 3.0
    while time.monotonic() < end:
        system.controller.inject(rng.integers(0, 256, 120, dtype=np.uint8).tobytes())
        system.spin(0.05)


FAULTS = (
    Fault("telemetry_pause", lambda s: s.controller.pause_telemetry(1.5), 2.0, _nothing, TELEMETRY_DEADLINE_S),
    Fault("guidance_killed", _signal("guidance", signal.SIGKILL), 2.0, _restart("guidance"), FAILSAFE_DEADLINE_S,
          from_last_command=True),
    Fault("detector_killed", _signal(VISION, signal.SIGKILL), 2.0, _restart(VISION), CAMERA_DEADLINE_S),
    Fault("camera_stalled", _signal(VISION, signal.SIGSTOP), 2.5, _signal(VISION, signal.SIGCONT), CAMERA_DEADLINE_S),
    Fault("serial_unplugged", lambda s: s.controller.unplug(1.5), 4.0, _nothing, None, neutral_after_s=1.5),
    Fault("line_noise", _line_noise, 0.5, _nothing, None),
)


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("soak", help="long run of the simulated system with faults injected",
                              description=__doc__.split("\n\n")[0])
    p.add_argument("--minutes", type=positive_float, default=5.0)
    p.add_argument("--fault-every", type=positive_float, default=25.0, metavar="S", help="seconds between faults")
    p.add_argument("--domain-id", type=domain_id, help="ROS_DOMAIN_ID of the nodes (default: a free one from 30-200)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(run=run)


def _start_pose(rng: np.random.Generator, world: PoolWorld) -> VehiclePose:
    return VehiclePose(world.dock_x_m - rng.uniform(10, 14), rng.uniform(-1.5, 1.5),
                       -world.dock_depth_m + rng.uniform(-0.8, 0.8), yaw=math.radians(rng.uniform(-10, 10)))


def run(args: argparse.Namespace) -> int:
    domain = args.domain_id if args.domain_id is not None else private_domain_id()
    with stop_on_signals(), registered(domain, "soak"):
        announce(domain, sys.stderr if args.json else sys.stdout)
        return _soak(args, domain)


def _soak(args: argparse.Namespace, domain: int) -> int:
    from diagnostic_msgs.msg import DiagnosticArray
    from std_msgs.msg import Bool, String

    from auv_dock_guidance.sim_system import SimulatedSystem

    rng = np.random.default_rng(5)
    world = PoolWorld(reflection=True)
    logs = Path(tempfile.mkdtemp(prefix="auv-dock-soak-"))
    system = SimulatedSystem(world, _start_pose(rng, world), logs, domain_id=domain)
    state = {"value": "starting"}
    since_fault: set[str] = set()  # every state guidance reported since the last fault
    frame_times: list[float] = []
    transitions: list[tuple[float, str]] = []
    guidance_status = {"value": "none"}  # guidance's newest /diagnostics entry, for a failed recovery
    def on_state(m: String) -> None:
        state["value"] = m.data
        since_fault.add(m.data)

    def on_transition(m: String) -> None:
        transitions.append((time.monotonic(), m.data))

    def on_detected(m: Bool) -> None:
        frame_times.append(time.monotonic())

    def on_diagnostics(m: DiagnosticArray) -> None:
        for status in m.status:
            if status.name.endswith(": guidance"):
                values = ", ".join(f"{v.key} {v.value}" for v in status.values)
                guidance_status["value"] = f"{status.message} ({values})"

    system.node.create_subscription(String, "guidance/state", on_state, 10)
    system.node.create_subscription(String, "guidance/transition", on_transition, 10)
    system.node.create_subscription(Bool, "dock/detected", on_detected, 100)
    system.node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, 10)
    group = system.group
    injected: list[str] = []
    not_survived: list[str] = []  # which, and when: to find it in the node logs
    outcomes: list[Outcome] = []
    dockings = 0
    t0 = time.monotonic()
    end = t0 + args.minutes * 60.0
    progress = Progress("soak", int(args.minutes * 60))
    rss_start = rss_end = 0.0
    stopped_by = None
    try:
        system.start()
        system.spin(12.0)  # start-up, discovery, first lock
        rss_start = sum(rss_mb(p.pid) for p in group.processes.values())
        next_fault = time.monotonic() + args.fault_every
        while time.monotonic() < end:
            system.spin(0.2)
            progress(int(time.monotonic() - t0), int(args.minutes * 60))
            range_left = world.dock_x_m - world.camera_position(system.controller.pose)[0]
            if system.nose_past_dock() or range_left < 1.0 or state["value"] in ("DOCKED", "ABORT"):
                dockings += system.nose_past_dock()
                system.reposition(_start_pose(rng, world))
                continue
            if time.monotonic() >= next_fault and state["value"] == "TRACK" and range_left > 4.0:
                fault = FAULTS[len(injected) % len(FAULTS)]
                injected.append(fault.name)
                outcomes.append(_inject(fault, system, transitions, frame_times))
                if not _recovered(system, since_fault):
                    seen = _unrecovered(system, since_fault, frame_times, guidance_status["value"])
                    not_survived.append(f"{fault.name} #{len(injected)} at {time.monotonic() - t0:.0f} s ({seen})")
                next_fault = time.monotonic() + args.fault_every
        rss_end = sum(rss_mb(p.pid) for p in group.processes.values())
    except KeyboardInterrupt as exc:
        stopped_by = str(exc) if isinstance(exc, StopRequested) else "Ctrl-C"
        rss_end = sum(rss_mb(p.pid) for p in group.processes.values())
    finally:
        codes = system.stop()
    minutes = (time.monotonic() - t0) / 60.0
    late = [o.late for o in outcomes if o.late]
    wrong = [o.wrong for o in outcomes if o.wrong]
    camera_gaps = [o.camera_gap for o in outcomes if o.camera_gap]
    worst_ms: dict[str, float] = {}
    for name, outcome in zip(injected, outcomes, strict=True):
        if outcome.reaction_ms is not None:
            worst_ms[name] = max(outcome.reaction_ms, worst_ms.get(name, 0.0))
    report = {
        "minutes": rounded(minutes, 2), "frames": len(frame_times), "deadline_misses": len(late),
        "rss_start_mb": rounded(rss_start, 1), "rss_end_mb": rounded(rss_end, 1),
        "rss_growth_pct": rounded(100.0 * (rss_end - rss_start) / rss_start, 1) if rss_start else None,
        "faults_injected": len(injected), "faults_survived": len(injected) - len(not_survived), "dockings": dockings,
        "worst_reaction_ms": {k: rounded(v, 0) for k, v in worst_ms.items()},
        "faults": injected, "not_survived": not_survived,
        "late": late, "wrong_reactions": wrong, "camera_gaps": camera_gaps, "node_exit_codes": codes, "logs": str(logs),
        "ros_domain_id": domain, "stopped_by": stopped_by,
    }
    if args.json:
        print_json(report)
    else:
        for key, value in report.items():
            print(f"{key:18}{value}")
    return 0 if not late and not wrong and not not_survived and stopped_by is None else 1


def _inject(fault: Fault, system: SimulatedSystem, transitions: list[tuple[float, str]],
            frame_times: Sequence[float]) -> Outcome:
    """Inject, observe, clear, and judge what reached the main controller."""
    start = time.monotonic()
    fault.inject(system)
    system.spin(fault.hold_s)
    fault.clear(system)
    records = [r for r in system.controller.records() if r.time_s >= start - 1.0]
    driving = [r for r in records if r.pwm_us != NEUTRAL and r.time_s < start + 0.05]
    if not driving:
        return Outcome()  # nothing was moving: nothing to stop
    name = fault.name
    if fault.neutral_within_s is not None:
        neutral = [r for r in records if r.pwm_us == NEUTRAL and r.time_s >= start]
        if not neutral:
            return Outcome(wrong=f"{name}: no neutral command reached the controller")
        ms = 1000 * (neutral[0].time_s - (driving[-1].time_s if fault.from_last_command else start))
        late = f"{name}: neutral after {ms:.0f} ms (limit {1000 * fault.neutral_within_s:.0f} ms)"
        return Outcome(ms, late=late if ms > 1000 * fault.neutral_within_s else None)
    if fault.neutral_after_s is not None:
        back = start + fault.neutral_after_s
        after = [r for r in records if r.time_s >= back]
        if not after:
            return Outcome(wrong=f"{name}: no command reached the controller after the link returned")
        if after[0].pwm_us != NEUTRAL:
            return Outcome(wrong=f"{name}: the first command after the link returned was {after[0].pwm_us}")
        return Outcome(1000 * (after[0].time_s - back))
    aborts = [(t, text) for t, text in transitions if t >= start and "-> ABORT" in text]
    if aborts:
        return judge_abort(name, *aborts[0], frame_times)
    if not any(r.pwm_us != NEUTRAL for r in records if r.time_s >= time.monotonic() - 1.0):
        return Outcome(wrong=f"{name}: thrust stopped")
    return Outcome()


def judge_abort(fault: str, at_s: float, transition: str, frame_times: Sequence[float]) -> Outcome:
    """An ABORT under a fault that thrust must go on through is wrong, unless it was for a silent camera
    and no frame reached the soak either for about as long (the longest gap before the abort)."""
    if CAMERA_SILENT not in transition:
        return Outcome(wrong=f"{fault}: {transition}")
    first = max(bisect.bisect_left(frame_times, at_s - CAMERA_TIMEOUT_S - 2.0) - 1, 0)
    points = [*frame_times[first:bisect.bisect_right(frame_times, at_s)], at_s]
    gap = max((b - a for a, b in itertools.pairwise(points)), default=math.inf)
    if gap < CAMERA_TIMEOUT_S - GAP_SLACK_S:
        return Outcome(wrong=f"{fault}: {transition} (frames reached the soak at most {gap:.2f} s apart)")
    return Outcome(camera_gap=f"{fault}: {transition} (no frame reached the soak for {gap:.1f} s either)")


def _unrecovered(system: SimulatedSystem, since_fault: set[str], frame_times: Sequence[float],
                 guidance_status: str) -> str:
    """What the soak saw of a system that did not recover; each node's threads' stacks go to its log
    (nodes.common registers SIGUSR1 with faulthandler), to tell a deaf node from a hung one."""
    for process in system.group.processes.values():
        if process.poll() is None:
            process.send_signal(signal.SIGUSR1)
    said = ", ".join(sorted(since_fault)) or "nothing"
    last_frame = f"{time.monotonic() - frame_times[-1]:.1f} s ago" if frame_times else "never"
    return f"guidance said {said}; its diagnostics {guidance_status}; last frame {last_frame}; stacks in the logs"


def _recovered(system: SimulatedSystem, since_fault: set[str]) -> bool:
    """Tracking the dock again (as guidance says after the fault), with every node process running.

    Any state guidance reported since the fault counts, not the newest one alone: on a busy
    machine a recovery close to the dock passes through TRACK into TERMINAL within one spin.
    RETRY counts too: only a confirmed marker leads there, and a restarted guidance can pass
    from TRACK to RETRY (its first entry check) before the soak has matched its publisher.
    """
    since_fault.clear()  # a killed guidance's last word does not count
    deadline = time.monotonic() + RECOVERY_S
    while time.monotonic() < deadline:
        system.spin(0.2)
        if since_fault & TRACKING and not system.group.exited():
            return True
    return False
