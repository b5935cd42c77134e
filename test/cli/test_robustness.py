"""Bad input to every auv-dock command: a non-zero exit, one line naming the input, no traceback,
nothing the user gave changed, nothing left running."""

from __future__ import annotations

import argparse

from auv_dock_guidance.cli.common import Number
from auv_dock_guidance.cli.main import build_parser


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
        try:
            Number(kind, low=0, low_open=True)(text)
        except argparse.ArgumentTypeError as exc:
            assert text in str(exc)
        else:
            raise AssertionError(f"{text} accepted")
