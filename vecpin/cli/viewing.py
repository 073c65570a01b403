"""``vecpin view`` and ``report``: the meshcat scene and the HTML report."""
from __future__ import annotations

from vecpin.cli.common import parse_orders, progress
from vecpin.errors import InputError
from vecpin.export.registry import controller_names


def run_view(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.models import ErrorModel
    from vecpin.viz.scene import serve, write_html
    model = ErrorModel.load(args.model)
    c = read_campaign(args.csv, model.machine)
    if not 0 <= args.row < len(c):
        raise InputError(f"--row {args.row}: the campaign has rows 0 .. {len(c) - 1}")
    tables = None
    if not args.no_tables:
        from vecpin.compensation.plan import plan_tables
        tables = plan_tables(model, n_commands=400).tables
    if args.html:
        facts = write_html(args.html, model, c, args.row, args.exaggerate, tables)
        print(f"wrote {args.html}: errors x{facts['exaggeration']:.0f}, largest {facts['max_error_mm']:.3f} mm, "
              f"{facts['commands']} scene commands; open it in a browser (no server needed)")
        return 0

    def ready(url, facts):
        print(f"meshcat scene at {url}  (errors x{facts['exaggeration']:.0f}; groups under /vecpin can be "
              "switched on and off in Open Controls > Scene); Ctrl-C to stop", flush=True)
    serve(model, c, args.row, args.exaggerate, tables, ready)
    return 0


def run_report(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.models import ErrorModel
    from vecpin.viz.report import write_report
    model = ErrorModel.load(args.model)
    c = read_campaign(args.csv, model.machine)
    v = read_campaign(args.validation, model.machine) if args.validation else None
    page = write_report(model, c, args.out, validation=v, orders=parse_orders(args.orders) if args.orders else None,
                        controller=args.controller, max_tables=args.max_tables, progress=progress(not args.quiet))
    print(f"wrote {page} (with figures/ and scene.html)")
    return 0


def register(sub) -> None:
    s = sub.add_parser("view", help="meshcat scene of measured vs modelled tool tips (interactive, or --html)")
    s.add_argument("model")
    s.add_argument("csv")
    s.add_argument("--row", type=int, default=0, help="measurement row to pose the machine at (0-based)")
    s.add_argument("--exaggerate", type=float, help="error vector scale (default: largest error = 8%% of the workspace)")
    s.add_argument("--html", help="write a self-contained page instead of starting a server")
    s.add_argument("--no-tables", action="store_true", help="skip the compensated view")
    s.set_defaults(func=run_view)

    s = sub.add_parser("report", help="one HTML page: tables, the seed's figures, the 3D scene")
    s.add_argument("model")
    s.add_argument("csv")
    s.add_argument("--out", required=True)
    s.add_argument("--validation", help="validation CSV for the before/after table and the order sweep")
    s.add_argument("--orders", help="also run the order sweep, e.g. 0-7")
    s.add_argument("--controller", default="generic", choices=controller_names(),
                   help="controller whose limits and files the report uses (default generic)")
    s.add_argument("--max-tables", type=int)
    s.add_argument("--quiet", action="store_true")
    s.set_defaults(func=run_report)
