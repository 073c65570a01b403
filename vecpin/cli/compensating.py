"""``vecpin tables``: compensation tables of a fitted model for a controller."""
from __future__ import annotations

from vecpin.cli.common import progress


def run_tables(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.models import ErrorModel
    from vecpin.workflows.tables import make_tables, parse_axis_map
    model = ErrorModel.load(args.model)
    m = model.machine
    for a in args.forbid_output:
        m.axis(a)
    commands = read_campaign(args.commands, m) if args.commands else None
    run = make_tables(model, args.out, args.controller, max_tables=args.max_tables, no_circular=args.no_circular,
                      forbid_output=args.forbid_output, method=args.method, points=args.points, tools_mm=args.tools,
                      modulo_axes=args.modulo, commands=commands, axis_map=parse_axis_map(args.axis_map, m),
                      progress=progress(not args.quiet))
    print("\n".join(run.lines(args.model, args.controller, args.points)))
    return 0


def register(sub) -> None:
    s = sub.add_parser("tables", help="compensation tables of a fitted model for a controller (Paper I §3.3, Paper II)")
    s.add_argument("model")
    s.add_argument("--controller", default="generic", choices=["siemens-840d", "fanuc-30i", "generic"])
    s.add_argument("--max-tables", type=int, help="cross tables to choose (pitch tables are always in)")
    s.add_argument("--no-circular", action="store_true", help="never use table ij together with ji")
    s.add_argument("--forbid-output", action="append", default=[], metavar="AXIS", help="axis that cannot be corrected")
    s.add_argument("--method", default="exact", choices=["exact", "ga", "heuristic"], help="subset selection method")
    s.add_argument("--points", type=int, default=1024, help="points per table (default 1024)")
    s.add_argument("--tools", type=float, nargs="+", help="tool lengths in mm (default: those of the fit)")
    s.add_argument("--axis-map", action="append", default=[], metavar="JOINT=NCNAME", help="NC axis names (Siemens)")
    s.add_argument("--modulo", action="append", default=[], metavar="AXIS", help="rotary input axis with modulo tables (one turn)")
    s.add_argument("--commands", help="campaign CSV whose commands (and tools) the tables are fitted and judged on")
    s.add_argument("--out", required=True)
    s.add_argument("--quiet", action="store_true")
    s.set_defaults(func=run_tables)
