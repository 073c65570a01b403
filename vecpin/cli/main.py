"""The parser and the entry point: every user error is one line and status 2."""
from __future__ import annotations

import argparse
import os
import sys
import warnings

from vecpin.cli import (compensating, diagnosing, fitting, importing, machines, planning, simulating, verifying,
                        viewing)
from vecpin.cli.options import as_flags, flag_table
from vecpin.errors import VecpinError, VecpinWarning
from vecpin.threads import blas_limited

COMMAND_MODULES = (machines, planning, simulating, importing, fitting, compensating, diagnosing, verifying, viewing)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="vecpin", description="Volumetric error compensation of machine tools.")
    p.add_argument("--version", action="version", version=f"vecpin {_version()}", help="print the version and exit")
    sub = p.add_subparsers(dest="command", required=True)
    for module in COMMAND_MODULES:
        module.register(sub)
    for name, command in sub.choices.items():
        command.set_defaults(flags=flag_table(command))
    return p


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
    args = build_parser().parse_args(argv)
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
