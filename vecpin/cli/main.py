"""The parser and the entry point: every user error is one line and status 2."""
from __future__ import annotations

import argparse
import os
import sys
import warnings

from vecpin.cli import (compensating, diagnosing, fitting, importing, machines, planning, session, simulating,
                        verifying, viewing)
from vecpin.cli.options import as_flags, flag_table
from vecpin.cli.workbench import command as workbench
from vecpin.errors import VecpinError, VecpinWarning
from vecpin.fileio import set_command
from vecpin.threads import blas_limited

COMMAND_MODULES = (machines, planning, simulating, importing, fitting, compensating, diagnosing, verifying, viewing,
                   session, workbench)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="vecpin", description="Volumetric error compensation of machine tools.")
    p.add_argument("--version", action=_Version, help="print the version and exit")
    # the session commands run other commands' lines through this parser and main (vecpin/cli/session.py)
    p.set_defaults(parser_factory=build_parser, entry=main)
    sub = p.add_subparsers(dest="command", required=True)
    for module in COMMAND_MODULES:
        module.add_commands(sub)
    for name, command in sub.choices.items():
        command.set_defaults(flags=flag_table(command), once=_single_valued(command))
    return p


def _single_valued(command: argparse.ArgumentParser) -> tuple[str, ...]:
    """The long options of ``command`` that take one value (or none): given twice, argparse
    keeps the last one without a word."""
    return tuple(o for a in command._actions if not isinstance(a, (argparse._AppendAction, argparse._CountAction,
                                                                   argparse._HelpAction))
                 for o in a.option_strings if o.startswith("--"))


def repeated_option(argv: list[str], once: tuple[str, ...], every: tuple[str, ...] = ()) -> str | None:
    """The first single-valued option ``argv`` gives twice (written in full, or abbreviated
    as argparse accepts it), or None; a token that is one of ``every`` (the command's long
    options) in full is no abbreviation (--nest-height repeats, --nest-heights does not)."""
    seen = set()
    for token in argv:
        if token == "--":
            break
        if not token.startswith("--"):
            continue
        name = token.split("=", 1)[0]
        full = [o for o in once if o == name] or ([] if name in every else [o for o in once if o.startswith(name)])
        if len(full) != 1:
            continue
        if full[0] in seen:
            return full[0]
        seen.add(full[0])
    return None


class _Version(argparse.Action):
    """``--version``: the installed version, looked up only when asked (``importlib.metadata`` costs every other
    command about 0.1 s of CPU)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest, nargs=0, default=default, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"vecpin {_version()}")
        parser.exit()


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("vecpin")
    except PackageNotFoundError:  # running from a source tree that is not installed
        return "unknown (not installed)"


def _warning_printer(flags: dict[str, str]):
    """vecpin's warnings as one line on stderr, parameters named by their flags; other
    libraries' warnings as Python prints them."""
    def show(message, category, filename, lineno, file=None, line=None) -> None:
        if issubclass(category, VecpinWarning):
            print(f"vecpin: warning: {as_flags(message, flags)}", file=sys.stderr, flush=True)
        else:
            _PYTHON_SHOWWARNING(message, category, filename, lineno, file, line)
    return show


_PYTHON_SHOWWARNING = warnings.showwarning


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    set_command(["vecpin", *argv])   # what the output folders' manifests record
    twice = repeated_option(argv[1:], args.once, tuple(args.flags.values()))
    if twice:
        hint = " (a zone over several axes is one value: X=0:3000,Y=0:1200)" if twice == "--zone" else ""
        print(f"vecpin: error: {twice} is given twice, and only one value counts: give it once{hint}", file=sys.stderr)
        return 2
    with warnings.catch_warnings():
        warnings.simplefilter("always", VecpinWarning)
        warnings.showwarning = _warning_printer(args.flags)
        return _run(args)


def _run(args) -> int:
    try:
        with blas_limited():
            return args.func(args)
    except VecpinError as exc:
        print(f"vecpin: error: {as_flags(exc, args.flags)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("vecpin: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. piped into `head`
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
