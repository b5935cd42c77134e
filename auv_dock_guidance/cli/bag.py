"""`auv-dock record`, `replay`, `compare` and `make-fixture`: ROS 2 bags without ROS tooling."""

from __future__ import annotations

import argparse
import json
import shutil
import time
from pathlib import Path

from auv_dock_guidance.cli.common import (
    add_approximate_arguments,
    approximate_lens,
    domain_from_environment,
    domain_id,
    fail,
    new_path,
    non_negative_int,
    positive_float,
    print_json,
)
from auv_dock_guidance.cli.progress import Progress
from auv_dock_guidance.errors import DockGuidanceError
from auv_dock_guidance.launcher import stop_on_signals
from auv_dock_guidance.replay import compare, replay


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    r = subparsers.add_parser("record", help="record the live system's topics into a ROS 2 bag (MCAP)",
                              description="Record camera, detection, guidance, telemetry and thruster topics "
                              "until Ctrl-C (or --duration).")
    r.add_argument("output", metavar="OUT", type=new_path, help="bag folder to create")
    r.add_argument("--topics", nargs="+", help="topics to record (default: all of this system's)")
    r.add_argument("--storage", choices=["mcap", "sqlite3"], default="mcap")
    r.add_argument("--duration", type=positive_float, help="stop after this many seconds")
    r.add_argument("--domain-id", type=domain_id, help="ROS_DOMAIN_ID to listen on")
    r.set_defaults(run=run_record)

    p = subparsers.add_parser("replay", help="run detector and guidance over a recorded bag",
                              description="Read the camera topic (Image or CompressedImage) and camera info of a "
                              "ROS 2 (MCAP, sqlite3) or ROS 1 bag, run the detector and guidance deterministically "
                              "as fast as possible, and write their outputs under /replay/ into a new MCAP bag "
                              "beside the input topics.")
    p.add_argument("bag", metavar="BAG")
    p.add_argument("--output", "-o", metavar="OUT", type=new_path, help="output bag folder (default BAG_replay)")
    p.add_argument("--camera-info", metavar="YAML", help="camera model when the bag has none (or to override it)")
    add_approximate_arguments(p)
    p.add_argument("--image-topic", help="camera topic when the bag has several")
    p.add_argument("--no-inputs", action="store_true", help="write only the /replay/ topics")
    p.add_argument("--realtime", action="store_true", help="with --publish: keep the recorded timing")
    p.add_argument("--publish", action="store_true", help="republish the bag into the live ROS graph instead")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(run=run_replay)

    c = subparsers.add_parser("compare", help="compare two replay outputs within tolerances (regression check)")
    c.add_argument("a", metavar="A")
    c.add_argument("b", metavar="B")
    c.add_argument("--center-px", type=positive_float, default=1.0, help="centre tolerance (default %(default)s px)")
    c.add_argument("--range-pct", type=positive_float, default=2.0, help="range tolerance (default %(default)s %%)")
    c.add_argument("--command-us", type=non_negative_int, default=10,
                   help="thruster command tolerance (default %(default)s us)")
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=run_compare)

    f = subparsers.add_parser("make-fixture", help="write the simulated approach bag used by the replay test")
    f.add_argument("output", metavar="OUT", type=new_path)
    f.set_defaults(run=run_make_fixture)


def run_replay(args: argparse.Namespace) -> int:
    bag = Path(args.bag)
    if args.publish:
        return _publish(bag, args.realtime)
    output = Path(args.output) if args.output else bag.with_name(bag.name + "_replay")
    try:
        summary = replay(bag, output, Path(args.camera_info) if args.camera_info else None, args.image_topic,
                         copy_inputs=not args.no_inputs, progress=Progress("replay", 1), lens=approximate_lens(args))
    except DockGuidanceError as exc:
        fail(str(exc), code=1)
    if not summary.processed and output.exists():
        shutil.rmtree(output)  # it would hold no replay output: nothing to keep
        summary.output = None
    report = summary.as_dict()
    if args.json:
        print_json(report)
    else:
        print(f"{report['frames']} frames, {report['detections']} with the marker "
              f"({100 * report['detection_rate']:.1f} %), {report['fps'] or 0:.0f} frames/s")
        for line in report["transitions"]:
            print(f"  {line}")
        if report["command_range_us"]:
            print("  thruster pulses (min-max us): " + ", ".join(f"{lo}-{hi}" for lo, hi in report["command_range_us"]))
        for note in report["notes"]:
            print(f"  note: {note}")
        for problem in report["problems"]:
            print(f"  warning: {problem}")
        if report["output"]:
            print(f"wrote {report['output']}")
    if not summary.processed:
        fail(f"{bag}: no frame could be used ({report['problems'][0] if report['problems'] else 'no frames'}); "
             f"no output written", code=1)
    return 0


def run_compare(args: argparse.Namespace) -> int:
    try:
        result = compare(Path(args.a), Path(args.b), args.center_px, args.range_pct, args.command_us)
    except DockGuidanceError as exc:
        fail(str(exc), code=1)
    data = {
        "frames_a": result.frames_a, "frames_b": result.frames_b, "matched": result.matched,
        "center_px_max": result.center_px_max, "range_rel_max": result.range_rel_max,
        "command_us_max": result.command_us_max, "detection_mismatches": result.detection_mismatches,
        "problems": result.problems, "within_tolerance": not result.problems,
    }
    if args.json:
        print_json(data)
    else:
        print(f"{result.matched} frames matched; centre differs by up to {result.center_px_max:.3f} px, range by "
              f"{100 * result.range_rel_max:.2f} %, commands by {result.command_us_max} us; "
              f"{result.detection_mismatches} detection mismatches")
        for problem in result.problems:
            print(f"  {problem}")
        print("within tolerance" if not result.problems else "DIFFERENT beyond tolerance")
    return 0 if not result.problems else 1


def run_make_fixture(args: argparse.Namespace) -> int:
    from auv_dock_guidance.sim.fixture import make_fixture

    try:
        make_fixture(Path(args.output))
    except DockGuidanceError as exc:
        fail(str(exc), code=1)
    print(f"wrote {args.output}")
    return 0


def run_record(args: argparse.Namespace) -> int:
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    from auv_dock_guidance.nodes.common import destroy_and_shut_down
    from auv_dock_guidance.recording import DEBUG_TOPICS, BagRecorder

    topics = dict(DEBUG_TOPICS)
    topics.update({"camera/image_raw": "sensor_msgs/msg/Image", "camera/camera_info": "sensor_msgs/msg/CameraInfo",
                   "vehicle/armed": "std_msgs/msg/Bool"})
    if args.topics:
        unknown = [t for t in args.topics if t not in topics and f"/{t.lstrip('/')}" not in topics]
        if unknown:
            fail(f"unknown topic(s) {', '.join(unknown)}; known: {', '.join(topics)}")
        topics = {t: m for t, m in topics.items() if t in args.topics or f"/{t.lstrip('/')}" in args.topics}
    domain = args.domain_id if args.domain_id is not None else domain_from_environment()
    with stop_on_signals():  # SIGTERM and SIGHUP end the recording as Ctrl-C does: the bag is closed whole
        rclpy.init(domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
        node = rclpy.create_node("auv_dock_recorder")
        try:
            recorder = BagRecorder(node, Path(args.output), topics, args.storage)
        except DockGuidanceError as exc:
            destroy_and_shut_down([node])
            fail(str(exc))
        end = time.monotonic() + args.duration if args.duration else None
        print(f"recording {len(topics)} topics on ROS domain {domain} into {args.output}; Ctrl-C stops", flush=True)
        try:
            while end is None or time.monotonic() < end:
                rclpy.spin_once(node, timeout_sec=0.1)
        except KeyboardInterrupt:
            pass
        finally:
            recorder.close()
            destroy_and_shut_down([node])
    print(json.dumps({k: v for k, v in recorder.counts.items() if v}))
    return 0


def _publish(bag: Path, realtime: bool) -> int:
    """Republish a bag into the live graph (original timing with --realtime) until it ends or a stop signal."""
    with stop_on_signals():
        return _republish(bag, realtime)


def _republish(bag: Path, realtime: bool) -> int:
    import rclpy
    from rclpy.serialization import deserialize_message
    from rclpy.signals import SignalHandlerOptions
    from rosbags.highlevel import AnyReader

    from auv_dock_guidance.nodes.common import destroy_and_shut_down
    from auv_dock_guidance.recording import message_class

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("auv_dock_bag_player")
    try:
        with AnyReader([bag]) as reader:
            publishers = {}
            for c in reader.connections:
                try:
                    publishers[c.id] = (node.create_publisher(message_class(c.msgtype), c.topic, 10),
                                        message_class(c.msgtype))
                except (ImportError, AttributeError, ValueError):
                    print(f"skipping {c.topic}: type {c.msgtype} is not available here")
            first_bag = first_wall = None
            count = 0
            for connection, timestamp, raw in reader.messages(connections=[c for c in reader.connections
                                                                           if c.id in publishers]):
                if realtime:
                    first_bag = first_bag if first_bag is not None else timestamp
                    first_wall = first_wall if first_wall is not None else time.monotonic()
                    delay = (timestamp - first_bag) * 1e-9 - (time.monotonic() - first_wall)
                    if delay > 0:
                        time.sleep(delay)
                publisher, cls = publishers[connection.id]
                publisher.publish(deserialize_message(bytes(raw), cls))
                count += 1
    except KeyboardInterrupt:
        pass
    except Exception as exc:
        fail(f"{bag}: {exc}", code=1)
    finally:
        destroy_and_shut_down([node])
    print(f"published {count} messages")
    return 0
