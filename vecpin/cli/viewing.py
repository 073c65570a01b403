"""``vecpin view`` and ``report``: the meshcat scene and the HTML report."""
from __future__ import annotations

import math

from vecpin.cli.common import parse_orders, progress
from vecpin.errors import InputError
from vecpin.export.names import CONTROLLERS


def parse_exaggeration(text: str | None):
    """'500' (every group) or 'errors=500,residuals=3000' -> float or {group: factor}."""
    if text is None:
        return None

    def factor(v: str) -> float:
        f = float(v)
        if not (math.isfinite(f) and f > 0):
            raise ValueError
        return f
    try:
        if "=" not in text:
            return factor(text)
        out = {}
        for part in text.split(","):
            k, v = part.split("=")
            k = k.strip()
            if k not in ("errors", "residuals", "compensated") or k in out:
                raise ValueError
            out[k] = factor(v)
        return out
    except ValueError:
        raise InputError(f"--exaggerate '{text}': a factor > 0 for every group, or GROUP=FACTOR pairs "
                         "(groups: errors, residuals, compensated), e.g. errors=500,residuals=3000") from None


def run_view(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.models import ErrorModel
    from vecpin.viz.scene import legend_lines
    from vecpin.workflows.viewing import view
    ex = parse_exaggeration(args.exaggerate)
    model = ErrorModel.load(args.model)

    def ready(url, facts):
        print(f"meshcat scene at {url}, posed at row {facts['row']} of {args.csv}; one group is shown at a time "
              "(switch them in Open Controls > Scene > vecpin); Ctrl-C to stop", flush=True)
        print("\n".join(legend_lines(facts)), flush=True)
    facts = view(model, read_campaign(args.csv, model.machine), row=args.row, exaggerate=ex, show=args.show,
                 no_tables=args.no_tables, html=args.html, ready=ready)
    if args.html:
        print(f"wrote {args.html}: posed at row {facts['row']} of {args.csv}, {facts['commands']} scene commands; "
              "open it in a browser (no server needed); groups:")
        print("\n".join(legend_lines(facts)))
    return 0


def run_report(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.models import ErrorModel
    from vecpin.workflows.reporting import report
    models = [ErrorModel.load(p) for p in args.model]
    c = read_campaign(args.csv, models[0].machine)
    v = read_campaign(args.validation, models[0].machine) if args.validation else None
    page = report(models, c, args.out, validation=v, orders=parse_orders(args.orders) if args.orders else None,
                  controller=args.controller, max_tables=args.max_tables, progress=progress(not args.quiet),
                  profile=args.profile)
    print(f"wrote {page} (with figures/ and scene.html) for {len(models)} model{'s' if len(models) > 1 else ''}")
    return 0


def add_commands(sub) -> None:
    s = sub.add_parser("view", help="meshcat scene of measured vs modelled tool tips (interactive, or --html)")
    s.add_argument("model", help="fitted model file (JSON, from vecpin fit)")
    s.add_argument("csv", help="campaign CSV the model was fitted to (or one measured with the same tracker pose)")
    s.add_argument("--row", type=int, help="the campaign row to pose the machine at, counted as vecpin's messages "
                   "count rows: the line of the CSV file, the header being row 1 and the first measurement row 2 "
                   "(default: the first tracker row of station 0)")
    s.add_argument("--exaggerate", metavar="FACTOR|GROUP=FACTOR,...",
                   help="error vector scale, dimensionless: one factor for every group or per group (errors, "
                        "residuals, compensated); default: each group's largest vector = 8%% of the workspace")
    s.add_argument("--show", choices=["errors", "residuals", "compensated"], default="errors",
                   help="the group visible at first (default errors); the others can be switched on")
    s.add_argument("--html", help="write a self-contained page to this file instead of starting a server "
                   "(default: start a server)")
    s.add_argument("--no-tables", action="store_true", help="skip the compensated view (default: tables for a "
                   "generic controller)")
    s.set_defaults(func=run_view)

    s = sub.add_parser("report", help="one HTML page for one or more models: tables, the seed's figures "
                       "(Fig. 9-11), the 3D scene")
    s.add_argument("model", nargs="+", help="fitted model files (JSON), e.g. a 6-DoF and an AP model of the same "
                   "campaign")
    s.add_argument("csv", help="the identification campaign CSV")
    s.add_argument("--out", required=True, help="output folder (index.html, figures/, scene.html)")
    s.add_argument("--validation", help="validation CSV for the before/after table and the order sweep "
                   "(default: none; the sweep then cross-validates)")
    s.add_argument("--orders", help="also run the order sweep, e.g. 0-7 or 2,4,6 (default: no sweep; slow: "
                   "one fit per order and model, five per order without --validation)")
    s.add_argument("--controller", default="generic", choices=CONTROLLERS,
                   help="controller the tables are for (default generic: every table)")
    s.add_argument("--profile", metavar="JSON", help="the machine's controller profile, as vecpin tables takes it "
                   "(default: none); the tables' files go to OUT/tables_K/ and the page shows them as written")
    s.add_argument("--max-tables", type=int, help="cross tables to choose (default: the controller's limit)")
    s.add_argument("--quiet", action="store_true", help="no progress lines (default: progress on stderr)")
    s.set_defaults(func=run_report)
