"""Bad input to every auv-dock command: a non-zero exit, one line naming the input, no traceback,
nothing the user gave changed, nothing left running.

Each case runs in-process (argparse and the checks before any work fail fast); what needs a
real process (signals, node processes) is in test/nodes/test_shutdown.py.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from auv_dock_guidance.cli.common import Number
from auv_dock_guidance.cli.main import build_parser, main

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
CONFIG = Path(__file__).resolve().parents[2] / "config"


@pytest.fixture(scope="module")
def user(tmp_path_factory) -> Path:
    """What a user hands the commands: files, folders, a damaged bag, a camera of another size."""
    home = tmp_path_factory.mktemp("user")
    (home / "FILE").write_text("a regular file\n")
    (home / "DIR").mkdir()
    (home / "LOOP").symlink_to(home / "LOOP2")
    (home / "LOOP2").symlink_to(home / "LOOP")
    shutil.copytree(FIXTURES / "approach_bag", home / "bag")
    shutil.copytree(FIXTURES / "approach_bag", home / "cut")
    data = next((home / "cut").glob("*.mcap"))
    data.write_bytes(data.read_bytes()[: data.stat().st_size // 2])
    shutil.copytree(FIXTURES / "approach_bag", home / "damaged")
    data = next((home / "damaged").glob("*.mcap"))
    raw = bytearray(data.read_bytes())
    raw[len(raw) // 2: len(raw) // 2 + 20_000] = bytes(20_000)
    data.write_bytes(bytes(raw))
    (home / "junk.mcap").write_bytes(b"not a bag" * 50)
    (home / "cam640.yaml").write_text((CONFIG / "camera_info.yaml").read_text()
                                      .replace("image_width: 1920", "image_width: 640")
                                      .replace("image_height: 1080", "image_height: 480"))
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from auv_dock_guidance.replay import OUTPUT_TOPICS

    writer = Writer(home / "empty_replay", version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    for topic, msgtype in OUTPUT_TOPICS.items():
        writer.add_connection(topic, msgtype, typestore=get_typestore(Stores.ROS2_JAZZY))
    writer.close()
    (home / "out").mkdir()  # where outputs may be created
    return home


# (arguments with U for the user's folder, exit code, words the message must hold)
BAD = [
    # issue 19, 1-5, 7, 8, 10, 14 and their siblings: numbers out of range, paths that cannot work
    ("replay U/bag --output U/FILE/sub", 2, ["--output", "U/FILE", "not a folder"]),
    ("replay U/bag --output U/bag", 2, ["--output", "exists"]),
    ("replay U/bag --output U/out/r8 --camera-info U/cam640.yaml", 1, ["cam640.yaml", "does not fit", "640x480"]),
    ("replay U/nothing --output U/out/r", 1, ["U/nothing", "no such bag"]),
    ("replay U/junk.mcap --output U/out/r", 1, ["junk.mcap", "cannot open"]),
    ("replay U/FILE --output U/out/r", 1, ["U/FILE", "cannot open"]),
    ("compare U/empty_replay U/empty_replay", 1, ["empty_replay", "no replayed frames"]),
    ("compare U/bag U/bag", 1, ["U/bag", "no /replay/ topics"]),
    ("compare U/empty_replay U/empty_replay --center-px nan", 2, ["--center-px", "nan"]),
    ("compare U/empty_replay U/empty_replay --command-us -1", 2, ["--command-us", "-1"]),
    ("make-fixture U/FILE", 2, ["U/FILE", "exists"]),
    ("record U/bag", 2, ["U/bag", "exists"]),
    ("record U/out/rec --duration 0", 2, ["--duration", "0"]),
    ("record U/out/rec --domain-id 233", 2, ["--domain-id", "233"]),
    ("mock-controller --port U/MISSING/tty0", 2, ["--port", "U/MISSING", "not a folder"]),
    ("mock-controller --port U/FILE/tty0", 2, ["--port", "U/FILE"]),
    ("mock-controller --port U/FILE", 2, ["U/FILE", "not a symbolic link"]),
    ("mock-controller --telemetry-hz 0", 2, ["--telemetry-hz", "0"]),
    ("link-selftest --seconds 0.001", 2, ["--seconds", "0.001", "0.2"]),
    ("link-selftest --seconds nan", 2, ["--seconds", "nan"]),
    ("simulate --episodes 1 --workers 1 --seed -5", 2, ["--seed", "-5", ">= 0"]),
    ("simulate --episodes 1 --workers 1 --seed 1.5", 2, ["--seed", "1.5", "whole number"]),
    ("simulate --episodes 1 --workers 1 --camera-hz 0", 2, ["--camera-hz", "0"]),
    ("simulate --episodes 1 --workers 1 --camera-hz -10", 2, ["--camera-hz", "-10"]),
    ("simulate --episodes 1 --workers 1 --camera-hz inf", 2, ["--camera-hz", "inf", "finite"]),
    ("simulate --episodes 1 --workers 1 --current nan", 2, ["--current", "nan", "finite"]),
    ("simulate --episodes 1 --workers 1 --current -0.1", 2, ["--current", "-0.1"]),
    ("simulate --episodes 1 --workers 1 --plots U/FILE/p", 2, ["--plots", "U/FILE", "not a folder"]),
    ("simulate --episodes 1 --workers 1 --plots U/FILE", 2, ["--plots", "U/FILE", "not a folder"]),
    ("simulate --episodes 0", 2, ["--episodes", "0", "positive"]),
    ("simulate --workers 0", 2, ["--workers", "0"]),
    ("evaluate --frames 2 --workers 1 --seed -1", 2, ["--seed", "-1"]),
    ("evaluate --frames 0", 2, ["--frames", "0"]),
    ("evaluate --range-sweep --attenuation nan", 2, ["--attenuation", "nan"]),
    ("evaluate --range-sweep --brightness -1", 2, ["--brightness", "-1"]),
    ("evaluate --workers 1000", 2, ["--workers", "1000", "256"]),
    ("edges-eval --seed -3", 2, ["--seed", "-3"]),
    ("detect U/DIR", 1, ["U/DIR", "a folder, not an image file"]),
    ("detect U/LOOP", 1, ["U/LOOP", "loops"]),
    ("detect U/nothing.png", 1, ["U/nothing.png", "no such file"]),
    ("detect U/FILE --marker-radius -0.3", 2, ["--marker-radius", "-0.3"]),
    ("detect U/FILE --marker-radius nan", 2, ["--marker-radius", "nan"]),
    ("run --source folder --path U/FILE", 2, ["--path", "U/FILE", "is a file, not a folder"]),
    ("run --source folder --path U/nothing", 2, ["--path", "U/nothing", "no such folder"]),
    ("run --source video --path U/DIR", 2, ["--path", "U/DIR", "is a folder"]),
    ("run --config U/nothing.yaml", 2, ["U/nothing.yaml", "does not exist"]),
    ("run --domain-id 300", 2, ["--domain-id", "300", "232"]),
    ("demo --timeout 0", 2, ["--timeout", "0"]),
    ("demo --domain-id -1", 2, ["--domain-id", "-1"]),
    ("demo --report U/FILE", 2, ["--report", "U/FILE", "not a folder"]),
    ("demo --report U/bag", 2, ["U/bag", "not empty"]),
    ("soak --minutes 0", 2, ["--minutes", "0"]),
    ("soak --fault-every nan", 2, ["--fault-every", "nan"]),
    ("bench --latency --seconds 0", 2, ["--seconds", "0"]),
    ("bench --latency --rate inf", 2, ["--rate", "inf"]),
    ("bench --frames 0", 2, ["--frames", "0"]),
    ("monitor --domain-id abc", 2, ["--domain-id", "abc"]),
    ("monitor --once 0", 2, ["--once", "0"]),
    ("foxglove --port 0", 2, ["--port", "0", "65535"]),
    ("foxglove --port 70000", 2, ["--port", "70000"]),
    ("foxglove --seconds -1", 2, ["--seconds", "-1"]),
    ("calibrate U/FILE --board 9x6 --square nan", 2, ["--square", "nan"]),
    ("undistort U/FILE --camera-info U/cam640.yaml --output U/out/u.png --bogus", 2, ["--bogus"]),
]
# issue 19, 9 and 13: damaged recordings give what they hold and say what was lost
DAMAGED = [
    ("replay U/cut --output U/out/cut", ["cut short", "messages recovered"]),
    ("replay U/damaged --output U/out/damaged", ["of 30 frames could not be read", "after frame"]),
]


def _snapshot(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and not p.is_symlink()}


def _children() -> set[int]:
    mine = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            if int(stat.read_text().rsplit(")", 1)[1].split()[1]) == os.getpid():
                mine.add(int(stat.parent.name))
        except (OSError, ValueError):
            pass
    return mine


def _run(command: str, user: Path, capsys) -> tuple[int, str]:
    before_children = _children()
    capsys.readouterr()
    try:
        code = main(command.replace("U/", f"{user}/").split())
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    out, err = capsys.readouterr()
    assert _children() <= before_children, f"{command}: processes left running"
    return code, (out + err).replace(f"{user}/", "U/")


@pytest.mark.parametrize(("command", "code", "words"), BAD, ids=[c for c, _, _ in BAD])
def test_bad_input_fails_cleanly_and_names_itself(command, code, words, user, capsys, monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))  # no running system seen by monitor/foxglove
    before = _snapshot(user)
    exit_code, text = _run(command, user, capsys)
    assert exit_code == code, f"{command}: exit {exit_code}, expected {code}\n{text}"
    for word in words:
        assert word in text, f"{command}: the message does not name {word!r}:\n{text}"
    assert "Traceback" not in text
    assert _snapshot(user) == before, f"{command}: changed or created files the user gave"


@pytest.mark.parametrize(("command", "words"), DAMAGED, ids=[c for c, _ in DAMAGED])
def test_damaged_recordings_give_what_they_hold_and_say_what_was_lost(command, words, user, capsys):
    given = {k: v for k, v in _snapshot(user).items() if not k.startswith("out/")}
    exit_code, text = _run(command, user, capsys)
    assert exit_code == 0, text
    for word in words:
        assert word in text, f"{command}: {word!r} missing:\n{text}"
    assert {k: v for k, v in _snapshot(user).items() if not k.startswith("out/")} == given


def test_an_unusable_ros_domain_id_in_the_environment_is_named(monkeypatch, capsys, tmp_path):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    monkeypatch.setenv("ROS_DOMAIN_ID", "abc")
    with pytest.raises(SystemExit) as stopped:
        main(["monitor", "--once", "1"])
    assert stopped.value.code == 2 and "ROS_DOMAIN_ID: 'abc' is not a whole number" in capsys.readouterr().err


def test_the_shore_tools_do_not_guess_between_several_running_systems(monkeypatch, capsys, tmp_path):
    from auv_dock_guidance.launcher import registered

    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    other = subprocess.Popen([sys.executable, "-c",
                              "import sys, time\n"
                              "from auv_dock_guidance.launcher import registered\n"
                              "with registered(61, 'soak'):\n"
                              "    print('listed', flush=True); time.sleep(30)"],
                             stdout=subprocess.PIPE, text=True)
    try:
        assert other.stdout.readline().strip() == "listed"
        with registered(60, "demo"), pytest.raises(SystemExit) as stopped:
            main(["foxglove", "--seconds", "1"])
    finally:
        other.kill()
        other.wait()
    err = capsys.readouterr().err
    assert stopped.value.code == 2 and "several auv-dock runs" in err
    assert "domain 60" in err and "domain 61" in err and "--domain-id" in err


def _options() -> list[tuple[str, argparse.Action]]:
    """(command, option) for every option of every subcommand."""
    parser = build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return [(name, action) for name, sub in commands.choices.items() for action in sub._actions]


def test_every_numeric_option_declares_its_range():
    unchecked = [f"{command} {'/'.join(action.option_strings) or action.dest}"
                 for command, action in _options()
                 if action.type in (int, float)
                 or (action.type is None and isinstance(action.default, (int, float))
                     and not isinstance(action.default, bool) and action.nargs != 0)]
    assert not unchecked, f"numeric options without a declared range (use a Number from cli/common.py): {unchecked}"


def test_ranged_numbers_refuse_what_would_fail_later():
    assert Number(float, low=0, low_open=True)("2.5") == 2.5
    for kind, text in ((float, "nan"), (float, "inf"), (float, "-1e-9"), (float, "0"), (int, "1.5"), (int, "x")):
        with pytest.raises(argparse.ArgumentTypeError, match=text.replace(".", r"\.")):
            Number(kind, low=0, low_open=True)(text)
