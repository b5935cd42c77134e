"""auv-dock: everything a person runs off-vehicle, one subcommand each."""

from __future__ import annotations

import argparse
import faulthandler
import signal
import sys

from auv_dock_guidance import __version__
from auv_dock_guidance.cli import bag, bench, calibrate, demo, detect, evaluate, link, run, shore, simulate, soak


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="auv-dock",
        description="Monocular docking guidance for an AUV: detect the dock's LED ring, "
        "evaluate the detector, and run the pipeline off-vehicle.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    subparsers = parser.add_subparsers(title="commands", metavar="COMMAND")
    demo.add_parser(subparsers)
    detect.add_parser(subparsers)
    evaluate.add_parsers(subparsers)
    link.add_parsers(subparsers)
    calibrate.add_parsers(subparsers)
    run.add_parser(subparsers)
    bench.add_parser(subparsers)
    simulate.add_parser(subparsers)
    bag.add_parsers(subparsers)
    soak.add_parser(subparsers)
    shore.add_parsers(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    if hasattr(signal, "SIGUSR1") and sys.__stderr__ is not None:
        # `kill -USR1 <pid>`: where a command that does not stop is stuck, on the process's own stderr
        faulthandler.register(signal.SIGUSR1, file=sys.__stderr__, all_threads=True)
    parser = build_parser()
    args = parser.parse_args(argv)
    if not hasattr(args, "run"):
        parser.print_help()
        return 2
    try:
        return int(args.run(args) or 0)
    except KeyboardInterrupt:
        print("auv-dock: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
