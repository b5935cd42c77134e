"""`auv-dock link-selftest` and `auv-dock mock-controller`: the serial link off-vehicle."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from auv_dock_guidance.cli.common import Number, fail, print_json, rate_hz, rounded
from auv_dock_guidance.cli.progress import Progress
from auv_dock_guidance.launcher import stop_on_signals
from auv_dock_guidance.sim.link_selftest import run_selftest
from auv_dock_guidance.sim.main_controller import MainControllerSim


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    s = subparsers.add_parser(
        "link-selftest",
        help="the serial bridge against the simulated main controller over a pseudo-terminal",
        description="Send thruster commands at 30 Hz through the real bridge and protocol to the "
        "simulated main controller, then stop and time the failsafe.",
    )
    s.add_argument("--seconds", type=Number(float, low=0.2, high=3600), default=3.0,
                   help="how long to send commands, 0.2-3600 (default %(default)s): at least a few commands at 30 Hz")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.set_defaults(run=run_selftest_command)

    m = subparsers.add_parser(
        "mock-controller",
        help="run the simulated main controller on a pseudo-terminal until Ctrl-C",
        description="Open a pseudo-terminal, speak the main-controller protocol on it, apply "
        "received PWM to a simple vehicle model and send telemetry.",
    )
    m.add_argument("--port", metavar="PATH",
                   help="the symbolic link to the pseudo-terminal the bridge opens (default: a temporary one)")
    m.add_argument("--telemetry-hz", type=rate_hz, default=50.0, help="telemetry rate (default %(default)s)")
    m.set_defaults(run=run_mock_controller)


def run_selftest_command(args: argparse.Namespace) -> int:
    report = run_selftest(args.seconds, progress=Progress("link self-test", int(args.seconds * 30)))
    data = {
        "frames_sent": report.frames_sent,
        "frames_received": report.frames_received,
        "crc_errors": report.crc_errors,
        "roundtrip_ms_p50": rounded(report.roundtrip_ms_p50, 2),
        "roundtrip_ms_p95": rounded(report.roundtrip_ms_p95, 2),
        "failsafe_ms": rounded(report.failsafe_ms, 1),
        "controller_crc_errors": report.controller_crc_errors,
    }
    if args.json:
        print_json(data)
    else:
        for key, value in data.items():
            print(f"{key:24}{value}")
    failed = [text for text, bad in (
        ("no frame came back from the simulated main controller", report.frames_received == 0),
        ("the controller never received neutral after the last command (the bridge's failsafe)",
         report.failsafe_ms is None)) if bad]
    if failed:
        fail("link self-test failed: " + "; ".join(failed), code=1)
    return 0


def run_mock_controller(args: argparse.Namespace) -> int:
    try:
        controller = MainControllerSim(telemetry_hz=args.telemetry_hz, link=Path(args.port) if args.port else None)
    except FileExistsError as exc:
        fail(str(exc))
    except OSError as exc:
        parent = Path(args.port).parent
        fail(f"--port {args.port}: " + (f"{parent} is not a folder" if not parent.is_dir() else
                                        f"cannot create the link to the pseudo-terminal there ({exc.strerror})"))
    with stop_on_signals(), controller:
        print(f"main controller simulator on {controller.port} ({controller.pty_name}); Ctrl-C stops", flush=True)
        try:
            while True:
                time.sleep(1.0)
                s = controller.state
                print(f"armed={controller.armed} pwm={controller.applied} yaw={s.yaw:+.3f} pitch={s.pitch:+.3f} "
                      f"frames={controller.decoder.stats.frames} crc_errors={controller.decoder.stats.crc_errors}",
                      flush=True)
        except KeyboardInterrupt:
            pass
    return 0
