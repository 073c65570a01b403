"""``vecpin fit``, ``evaluate``, ``orders`` and ``demo``: identification on the command line."""
from __future__ import annotations

import json

from vecpin.cli.common import (CAMPAIGN_HELP, MACHINE_HELP, add_machine_args, add_model_args, add_noise_args,
                               add_quiet_arg, machine, noise, noise_stated, parse_orders, progress, say, zone_option)


def read_fit_campaign(args, m):
    """The campaign CSV with the known target offsets of ``--targets`` (if given)."""
    from vecpin.measurement.campaign import attach_targets, read_campaign, read_targets
    c = read_campaign(args.csv, m)
    if getattr(args, "targets", None):
        attach_targets(c, read_targets(args.targets), args.targets)
    return c


def nest_heights(items: list[str] | None, path: str | None = None, campaign=None) -> dict | None:
    """``--nest-height ID=MM[:SD]`` (repeated) and ``--nest-heights CSV`` (the plan's nest_heights.csv, filled
    in) -> {id: mm, or (mm, sd mm)}; an id given twice is refused, and with ``campaign`` an id it has no nest
    for (a file's row named), before the fit."""
    from vecpin.errors import InputError
    from vecpin.measurement.nestheights import campaign_nest_ids, read_nest_heights
    ids = None if campaign is None else campaign_nest_ids(campaign)
    out = {}
    for nid, value in (read_nest_heights(path, ids) if path else {}).items():
        if any(str(i).partition("=")[0].strip() == nid for i in items or []):
            raise InputError(f"`--nest-height` {nid} is also in `--nest-heights` {path}; give each nest once")
        out[nid] = value
    for item in items or []:
        nid, sep, value = str(item).partition("=")
        nid = nid.strip()
        if not sep or not nid:
            raise InputError(f"`--nest-height` '{item}': write ID=MM, a nest id and its reflector centre's height "
                             "above the table face in mm, e.g. 1=19.05 (ID=MM:SD with the reading's standard "
                             "deviation, mm)")
        if nid in out:
            raise InputError(f"`--nest-height` {nid} is given twice; give each nest once")
        if ids is not None and nid not in ids:
            raise InputError(f"`nest_height` {item}: the campaign has no nest '{nid}' (its nests: "
                             f"{', '.join(sorted(ids)) or 'none'})")
        out[nid] = _height_item(item, value)
    return out or None


def _height_item(item: str, value: str):
    """The height [mm] of ``--nest-height`` ``item`` (its ``value`` after '='), or (height, sd) [mm] with ':SD'."""
    from vecpin.errors import InputError
    got = []
    for text, what in zip(value.split(":", 1), ("a height", "a standard deviation")):
        try:
            got.append(float(text))
        except ValueError:
            raise InputError(f"`--nest-height` '{item}': '{text.strip()}' is not {what}; write ID=MM, the reflector "
                             "centre's height above the table face in mm, e.g. 1=19.05, or ID=MM:SD with the "
                             "reading's standard deviation in mm, e.g. 1=19.05:0.01") from None
    return got[0] if len(got) == 1 else tuple(got)


def add_nest_height_args(s) -> None:
    """``--nest-height ID=MM[:SD]`` (repeated) and ``--nest-heights CSV``: the table nests' heights above its face;
    ``--table-face CSV``: an indicator's sweeps of the face."""
    s.add_argument("--nest-height", action="append", metavar="ID=MM[:SD]",
                   help="the height of a table nest's reflector centre above the table's face, mm, and optionally the "
                        "reading's standard deviation, mm (default 0.02, a height gauge's) (repeat for three or more "
                        "nests): the tables then keep the table's face square to the spindle as far as the heights "
                        "tell it, and every figure is judged on it (default: the machine's own reference lines or "
                        "mean orientation)")
    s.add_argument("--nest-heights", metavar="CSV", help="the nests' heights above the table's face in one file: the "
                   "nest_heights.csv vecpin plan writes, its height_mm column filled in, mm (its height_sd_mm: the "
                   "readings' standard deviations) (default: none, as above)")
    s.add_argument("--table-face", metavar="CSV", help="the table face's parallelism read with a dial test indicator "
                   "in the spindle, the rotary axes at zero, moving X and then Y across the face: the table_face.csv "
                   "vecpin plan writes, distance_mm (how far the axis moved) and change_um (the indicator's change, "
                   "µm, + when pushed in as the command increases) filled in, sd_um the reading's standard deviation "
                   "(default 2 µm); weighed with the nests' heights, or alone (default: none)")


def table_face(path: str | None, machine) -> dict | None:
    """``--table-face CSV`` -> {axis: (distance mm, change µm, sd µm)} (the file's rows checked), or None."""
    if not path:
        return None
    from vecpin.measurement.tableface import read_table_face
    return read_table_face(path, machine)


def run_fit(args) -> int:
    from vecpin.fileio import check_output_file
    from vecpin.workflows.fitting import fit_campaign
    m = machine(args.machine, args)
    check_output_file(args.out)
    campaign = read_fit_campaign(args, m)
    run = fit_campaign(m, campaign, noise(args, m), kind=args.model, basis=args.basis,
                       order=args.order, tool_corrections=args.tool_corrections, prior_scale=args.prior_scale,
                       underdetermined=args.underdetermined, cv=args.folds, zone=zone_option(args.zone),
                       noise_from_data=not noise_stated(args),
                       nest_heights=nest_heights(args.nest_height, args.nest_heights, campaign),
                       table_face=table_face(args.table_face, m), progress=progress(not args.quiet))
    run.model.save(args.out)
    say(args, *run.lines())
    print(f"wrote {args.out}")
    return 0


def run_evaluate(args) -> int:
    if args.test_path:
        from vecpin.cli.compensating import run_sign_check
        return run_sign_check(args)
    from vecpin.fileio import check_output_file, write_text
    from vecpin.measurement.campaign import read_campaign
    from vecpin.models import ErrorModel
    from vecpin.workflows.evaluation import evaluate
    if args.json:
        check_output_file(args.json, "json")
    model = ErrorModel.load(args.model)
    camp = read_campaign(args.csv, model.machine)
    ev = evaluate(model, camp, reregister=args.reregister, zone=zone_option(args.zone), model_source=args.model)
    say(args, *ev.warnings)
    print(f"{model.label()} ({args.model}) on {args.csv}: {ev.rows} rows"
          + (" (tracker re-registered)" if args.reregister else ""))
    say(args, *ev.lines())
    if args.json:
        write_text(args.json, json.dumps({"model": str(args.model), "campaign": str(args.csv)} | ev.to_dict(), indent=1))
        print(f"wrote {args.json}")
    return 0


def run_orders(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.workflows.orders import choose_orders
    m = machine(args.machine, args)
    c = read_campaign(args.csv, m)
    v = read_campaign(args.validation, m) if args.validation else None
    run = choose_orders(m, c, noise(args, m), kinds=args.kinds, orders=parse_orders(args.orders), basis=args.basis,
                        validation=v, folds=args.folds, progress=progress(not args.quiet))
    say(args, *run.lines())
    return 0


def run_demo(args) -> int:
    from pathlib import Path

    from vecpin.workflows.demo import run_demo as demo
    res = demo(args.out, seed=args.seed, order=args.order, progress=progress(not args.quiet))
    say(args, *res.table())
    print(f"files in {args.out}: " + ", ".join(p.name for p in res.files))
    out = Path(args.out)
    print(f"the same by hand: vecpin fit flow_xyzcb {out / 'campaign.csv'} --out {out / 'model.json'}; "
          f"vecpin evaluate {out / 'model.json'} {out / 'validation.csv'}")
    return 0


def add_commands(sub) -> None:
    from vecpin.fitting.settings import default  # the fit's one table of defaults (no numpy: the help stays fast)
    s = sub.add_parser("fit", help="choose and identify an error model from a campaign CSV (maximum likelihood)")
    s.add_argument("machine", help=MACHINE_HELP)
    s.add_argument("csv", help=CAMPAIGN_HELP)
    add_model_args(s)
    s.add_argument("--folds", type=int, default=default("cv"),
                   help="cross-validation folds of the model choice, grouped by pose; whole sweeps where the design "
                   "moves one joint at a time (default %(default)s)")
    s.add_argument("--out", required=True, help="model file to write (JSON, mm and deg)")
    s.add_argument("--tool-corrections", action="store_true",
                   help="also fit a length correction per tool, mm (default: the gauge-line correction T_offset only)")
    s.add_argument("--prior-scale", type=float, default=default("prior_scale"),
                   help="factor on every parameter's prior standard deviation (Σ_b), dimensionless, > 0 "
                        "(default %(default)s)")
    s.add_argument("--underdetermined", action="store_true",
                   help="accept fewer equations than unknowns, the priors deciding the rest: the model choice then "
                        "also tries candidates larger than the campaign supports (default: the choice leaves them "
                        "out, and a fixed model that large is refused)")
    s.add_argument("--zone", metavar="AXIS=LO:HI[,...]",
                   help="fit only the rows commanded in this region of axis space, mm/deg (a machine calibrated in "
                        "zones, seed Table 2.12); the model file records it and vecpin tables uses it (default: all rows)")
    add_nest_height_args(s)
    s.add_argument("--targets", metavar="CSV",
                   help="known tool-target offsets: a CSV 'target,x,y,z' in mm in the tool link frame; targets of the "
                        "campaign's 'target' column not in it are found by the fit (default: all found by the fit)")
    add_machine_args(s)
    add_noise_args(s)
    add_quiet_arg(s)
    s.set_defaults(func=run_fit)

    s = sub.add_parser("evaluate", help="residuals of a fitted model on a campaign CSV (on a table machine with nest "
                       "rows: the tool tip relative to the table)")
    s.add_argument("model", help="fitted model file (JSON, from vecpin fit)")
    s.add_argument("csv", help=CAMPAIGN_HELP + "; measured from the model's tracker pose unless --reregister")
    s.add_argument("--json", help="also write the figures (mm) to this JSON file (default: print only)")
    s.add_argument("--reregister", action="store_true",
                   help="the tracker was moved: register its pose to this file first (default: the model's pose)")
    s.add_argument("--sign-test-file", dest="test_path", metavar="JSON", help="CSV is a sign-test check (compensation,command,reading): say "
                                                       "whether the controller applies the table with the right sign; "
                                                       "JSON is the SIGNTEST_*.json of vecpin tables (default: none)")
    s.add_argument("--zone", metavar="AXIS=LO:HI[,...]", help="judge only the rows commanded in this region, mm/deg "
                                                             "(default: all rows)")
    s.set_defaults(func=run_evaluate)

    s = sub.add_parser("orders", help="choose the series order on held-out data (Paper I Table 2)")
    s.add_argument("machine", help=MACHINE_HELP)
    s.add_argument("csv", help=CAMPAIGN_HELP)
    s.add_argument("--models", dest="kinds", choices=["6dof", "ap"], nargs="+", default=["6dof", "ap"],
                   help="model kinds to sweep, one or both (default: 6dof ap)")
    s.add_argument("--orders", default="0-7",
                   help="series orders to try: a range like 0-7 or a list like 2,4,6 (default %(default)s)")
    s.add_argument("--validation", help="validation CSV: every order fitted and judged on it (Paper I Table 2); "
                   "default: k-fold cross-validation of the linearised candidates")
    s.add_argument("--basis", choices=["chebyshev", "fourier"], default="chebyshev",
                   help="chebyshev everywhere (the seed's, default) or fourier per turn on rotary axes travelling "
                        "more than a turn")
    s.add_argument("--folds", type=int, default=5, help="cross-validation folds grouped by command, without "
                   "--validation (default %(default)s)")
    add_machine_args(s)
    add_noise_args(s)
    add_quiet_arg(s)
    s.set_defaults(func=run_orders)

    s = sub.add_parser("demo", help="simulate Paper I's campaign, fit the model the data choose and the seed's two "
                       "models, print the before/after table")
    s.add_argument("--out", default="demo", help="output folder: campaign.csv, validation.csv, validation_truth.csv, "
                   "truth.json, model.json (the chosen model), model_6dof.json, model_ap.json (default %(default)s)")
    s.add_argument("--seed", type=int, default=0, help="random seed of the simulated machine and campaign: the same seed "
                   "writes the same files (default %(default)s)")
    s.add_argument("--order", type=int, default=6, help="series order of the 6-DoF and AP models fitted beside the "
                   "chosen one, as Paper I (default %(default)s)")
    s.add_argument("--quiet", action="store_true", help="no progress lines (default: progress on stderr)")
    s.set_defaults(func=run_demo)
