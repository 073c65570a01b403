"""The parser and the entry point: every user error is one line and status 2."""
from __future__ import annotations

import argparse
import os
import sys

from vecpin.cli import (compensating, diagnosing, fitting, importing, machines, planning, simulating, verifying,
                        viewing)
from vecpin.errors import VecpinError

COMMAND_MODULES = (machines, planning, simulating, importing, fitting, compensating, diagnosing, verifying, viewing)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="vecpin", description="Volumetric error compensation of machine tools.")
    p.add_argument("--version", action="version", version=f"vecpin {_version()}", help="print the version and exit")
    sub = p.add_subparsers(dest="command", required=True)
    for module in COMMAND_MODULES:
        module.register(sub)
    return p


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("vecpin")
    except PackageNotFoundError:  # running from a source tree that is not installed
        return "unknown (not installed)"


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except VecpinError as exc:
        print(f"vecpin: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("vecpin: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. piped into `head`
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
