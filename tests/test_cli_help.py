"""The command line: ``vecpin --version`` and help text with units or defaults on every
option of the commands of the whole-day workflow."""
import argparse
import subprocess
import sys

import pytest

from vecpin.cli.main import build_parser

WORKFLOW_COMMANDS = ("plan", "simulate", "import", "assess", "verify", "view", "report")


def _subparsers():
    p = build_parser()
    return [a for a in p._actions if isinstance(a, argparse._SubParsersAction)][0].choices


def test_version(capsys):
    from importlib.metadata import version
    with pytest.raises(SystemExit) as e:
        build_parser().parse_args(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out.strip() == f"vecpin {version('vecpin')}"
    out = subprocess.run([sys.executable, "-m", "vecpin", "--version"], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.startswith("vecpin ")


@pytest.mark.parametrize("command", WORKFLOW_COMMANDS)
def test_every_option_has_help_with_its_default(command):
    sp = _subparsers()[command]
    for a in sp._actions:
        if isinstance(a, argparse._HelpAction):
            continue
        name = a.option_strings or a.dest
        assert a.help, f"{command} {name}: no help text"
        if a.option_strings and a.default not in (None, False, [], argparse.SUPPRESS):
            assert "default" in a.help.lower(), f"{command} {name}: the help does not say the default {a.default!r}"


def test_units_are_named_in_the_plan_help():
    text = _subparsers()["plan"].format_help()
    for needle in ("mm (default", "deg (default", "mm/min", "s (default 4)", "mm/deg"):
        assert needle in text
