"""``vecpin workbench [FOLDER]``: the local web page of the day (vecpin.cli.workbench.server)."""
from __future__ import annotations

from pathlib import Path


def run_workbench(args) -> int:
    from vecpin.cli.workbench.server import serve
    return serve(Path(args.folder), args.parser_factory(), port=args.port, open_browser=not args.no_browser)


def add_commands(sub) -> None:
    w = sub.add_parser("workbench", help="the day in a browser: a local web page (127.0.0.1 only) that walks the "
                       "stages, runs the same commands and keeps the choices in FOLDER/session.json")
    w.add_argument("folder", nargs="?", default=".", help="the day's folder: session.json and every stage's files "
                   "(default: the current folder; an empty one starts a new day)")
    w.add_argument("--port", type=int, default=8745, help="local port (default 8745; 0: any free port)")
    w.add_argument("--no-browser", action="store_true", help="do not open a browser (default: open one)")
    w.set_defaults(func=run_workbench)
