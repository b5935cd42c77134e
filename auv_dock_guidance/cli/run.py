"""`auv-dock run`: the node set from one parameter file, on a machine without ROS tooling."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from auv_dock_guidance.cli.common import domain_id, fail
from auv_dock_guidance.launcher import VISION_COMBINED, VISION_SEPARATE, NodeGroup, ros_environment
from auv_dock_guidance.resources import config_file
from auv_dock_guidance.sim.main_controller import MainControllerSim


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "run",
        help="start the guidance nodes as processes (what ros2 launch does on a ROS install)",
        description="Start camera_ingest, detector, guidance and serial_bridge from "
        "config/dock_guidance.yaml until Ctrl-C, then stop them cleanly. camera_ingest and detector "
        "share one process (frames stay inside one DDS participant) unless --separate-vision.",
    )
    p.add_argument("--config", metavar="YAML", help="parameter file (default: config/dock_guidance.yaml)")
    p.add_argument("--separate-vision", action="store_true",
                   help="run camera_ingest and detector as two processes (default: one process, two nodes)")
    p.add_argument("--source", choices=["device", "video", "folder", "sim"], help="camera source")
    p.add_argument("--path", help="camera index/path, video file or image folder")
    p.add_argument("--port", help="main controller serial port")
    p.add_argument("--mock-controller", action="store_true",
                   help="run the simulated main controller on a pseudo-terminal and arm the bridge")
    p.add_argument("--domain-id", type=domain_id, help="ROS_DOMAIN_ID for the nodes")
    p.add_argument("--network", action="store_true", help="discover beyond localhost (a shore laptop)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    params = Path(args.config) if args.config else config_file("dock_guidance.yaml")
    if not params.is_file():
        fail(f"parameter file {params} does not exist")
    overrides: dict[str, dict[str, object]] = {"camera_ingest": {}, "serial_bridge": {}}
    if args.source:
        overrides["camera_ingest"]["source"] = args.source
    if args.path:
        overrides["camera_ingest"]["path"] = args.path
    if args.port:
        overrides["serial_bridge"]["port"] = args.port
    controller = None
    if args.mock_controller:
        controller = MainControllerSim().start()
        overrides["serial_bridge"].update(port=controller.port, arm_on_start=True)
        print(f"simulated main controller on {controller.port}", flush=True)
    nodes = VISION_SEPARATE if args.separate_vision else VISION_COMBINED
    group = NodeGroup(nodes, params, overrides, ros_environment(args.domain_id, not args.network))
    group.start()
    print(f"started {', '.join(nodes)}; Ctrl-C stops", flush=True)
    try:
        while True:
            time.sleep(0.5)
            dead = group.exited()
            if dead:
                print("stopped by itself: " + ", ".join(f"{n} (exit {c})" for n, c in dead.items()), flush=True)
                break
    except KeyboardInterrupt:
        print("\nstopping...", flush=True)
    codes = group.stop()
    if controller is not None:
        controller.stop()
    print("stopped: " + ", ".join(f"{n} {c}" for n, c in codes.items()), flush=True)
    return 0 if all(c in (0, -2, 130) for c in codes.values()) else 1
