"""`auv-dock run`: the node set from one parameter file, on a machine without ROS tooling."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from auv_dock_guidance.cli.common import domain_from_environment, domain_id, fail
from auv_dock_guidance.launcher import (
    VISION_COMBINED,
    VISION_SEPARATE,
    NodeGroup,
    StopRequested,
    announce,
    registered,
    ros_environment,
    stop_on_signals,
)
from auv_dock_guidance.resources import config_file
from auv_dock_guidance.sim.main_controller import MainControllerSim


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "run",
        help="start the guidance nodes as processes (what ros2 launch does on a ROS install)",
        description="Start camera_ingest, detector, guidance and serial_bridge from "
        "config/dock_guidance.yaml until Ctrl-C (or SIGTERM, SIGHUP), then stop them cleanly, the "
        "serial bridge first (thrusters neutral). camera_ingest and detector share one process "
        "(frames stay inside one DDS participant) unless --separate-vision.",
    )
    p.add_argument("--config", metavar="YAML", help="parameter file (default: config/dock_guidance.yaml)")
    p.add_argument("--separate-vision", action="store_true",
                   help="run camera_ingest and detector as two processes (default: one process, two nodes)")
    p.add_argument("--source", choices=["device", "video", "folder", "sim"], help="camera source")
    p.add_argument("--path", help="camera index/path, video file or image folder")
    p.add_argument("--port", help="main controller serial port")
    p.add_argument("--mock-controller", action="store_true",
                   help="run the simulated main controller on a pseudo-terminal and arm the bridge")
    p.add_argument("--domain-id", type=domain_id,
                   help="ROS_DOMAIN_ID for the nodes (default: $ROS_DOMAIN_ID, else 0)")
    p.add_argument("--network", action="store_true", help="discover beyond localhost (a shore laptop)")
    p.set_defaults(run=run)


def _check_source(source: str | None, path: str | None) -> None:
    """A camera source that cannot work is refused before any node starts."""
    if path is None or source not in ("folder", "video"):
        return
    where = Path(path)
    if source == "folder":
        if not where.exists():
            fail(f"--path {path}: no such folder (--source folder reads the images in a folder)")
        if not where.is_dir():
            fail(f"--path {path} is a file, not a folder (--source folder reads the images in a folder; "
                 f"a video file is --source video)")
    elif where.is_dir():
        fail(f"--path {path} is a folder, not a video file (a folder of images is --source folder)")


def run(args: argparse.Namespace) -> int:
    params = Path(args.config) if args.config else config_file("dock_guidance.yaml")
    if not params.is_file():
        fail(f"parameter file {params} does not exist")
    _check_source(args.source, args.path)
    overrides: dict[str, dict[str, object]] = {"camera_ingest": {}, "serial_bridge": {}}
    if args.source:
        overrides["camera_ingest"]["source"] = args.source
    if args.path:
        overrides["camera_ingest"]["path"] = args.path
    if args.port:
        overrides["serial_bridge"]["port"] = args.port
    domain = args.domain_id if args.domain_id is not None else domain_from_environment()
    nodes = VISION_SEPARATE if args.separate_vision else VISION_COMBINED
    group = NodeGroup(nodes, params, overrides, ros_environment(domain, not args.network))
    controller = None
    with stop_on_signals(), registered(domain, "run", not args.network):
        announce(domain)
        try:
            if args.mock_controller:
                controller = MainControllerSim().start()
                overrides["serial_bridge"].update(port=controller.port, arm_on_start=True)
                print(f"simulated main controller on {controller.port}", flush=True)
            group.start()
            print(f"started {', '.join(nodes)}; Ctrl-C stops", flush=True)
            while not (dead := group.exited()):
                time.sleep(0.5)
            print("stopped by itself: " + ", ".join(f"{n} (exit {c})" for n, c in dead.items()), flush=True)
        except KeyboardInterrupt as exc:
            print(f"\nstopping ({exc if isinstance(exc, StopRequested) else 'Ctrl-C'})...", flush=True)
        finally:
            codes = group.stop()
            if controller is not None:
                controller.stop()
    print("stopped: " + ", ".join(f"{n} {c}" for n, c in codes.items()), flush=True)
    return 0 if all(c in (0, -2, 130) for c in codes.values()) else 1
