"""``vecpin fit``, ``evaluate``, ``orders`` and ``demo``: identification on the command line."""
from __future__ import annotations

import json

import numpy as np

from vecpin.cli.common import (CAMPAIGN_HELP, MACHINE_HELP, add_machine_args, add_model_args, add_noise_args, machine,
                               noise, noise_stated, parse_orders, progress, zone_option)
from vecpin.units import MM_PER_M


def read_fit_campaign(args, m):
    """The campaign CSV with the known target offsets of ``--targets`` (if given)."""
    from vecpin.measurement.campaign import attach_targets, read_campaign, read_targets
    c = read_campaign(args.csv, m)
    if getattr(args, "targets", None):
        attach_targets(c, read_targets(args.targets), args.targets)
    return c


def run_fit(args) -> int:
    from vecpin.fileio import check_output_file
    from vecpin.units import norm_mm
    from vecpin.workflows.fitting import fit_campaign, zone_rows
    from vecpin.workflows.summary import per_tool_table
    m = machine(args.machine, args)
    check_output_file(args.out)
    c = read_fit_campaign(args, m)
    zone = zone_option(args.zone)
    for a in zone or {}:
        m.axis(a)
    run = fit_campaign(m, c, noise(args, m), kind=args.model, basis=args.basis, order=args.order,
                       tool_corrections=args.tool_corrections, prior_scale=args.prior_scale,
                       underdetermined=args.underdetermined, folds=args.folds, zone=zone,
                       noise_from_data=not noise_stated(args), progress=progress(not args.quiet))
    model = run.model
    model.save(args.out)
    if zone:
        print(f"zone {args.zone}: {run.rows_in_zone} of the {run.rows} rows were commanded in it")
        c = zone_rows(m, c, zone)
    if run.choice is not None:
        print(run.choice.table())
    rep = model.report_
    print(rep.summary())
    if run.noise_line():
        print(run.noise_line())
    if rep.removed:
        print(f"redundant terms removed ({len(rep.removed)}): {', '.join(rep.removed)}")
    c0 = c.primary()
    rows = [("uncompensated (nominal kinematics)", norm_mm(model.nominal_residuals(c0))),
            (model.label(), norm_mm(model.residuals(c0)))]
    print("\n".join(per_tool_table(rows, c0.tool)))
    if c.nest_rows.size:
        cn = c.subset(c.nest_rows[c.station[c.nest_rows] == 0])
        if len(cn):
            print(f"  table nest rows (station 0): {len(cn)}, residual mean "
                  f"{norm_mm(model.residuals(cn)).mean():.4f} mm (uncompensated "
                  f"{norm_mm(model.nominal_residuals(cn)).mean():.4f} mm)")
    print("\n".join(fitted_points_lines(model)))
    if c.ballbar_rows.size:
        d = np.abs(model.ballbar_residuals(c)) * MM_PER_M
        print(f"  ball bar rows: {d.size}, |radius residual| mean {d.mean():.4f} mm, max {d.max():.4f} mm")
    print(f"wrote {args.out}")
    return 0


def fitted_points_lines(model) -> list[str]:
    """The fitted table nests (workpiece frame) and tool targets (tool link frame), mm ± 1 sigma."""
    out = []
    su = model.setup_
    for kind, store, frame in (("nest", su.nests, "workpiece frame"), ("target", su.targets, "tool link frame")):
        for k, v in store.items():
            sd = [su.std.get(f"{kind}{k}.{c}", 0.0) * MM_PER_M for c in "xyz"]
            cells = ", ".join(f"{x * MM_PER_M:.4f} ± {e:.4f}" if e > 0 else f"{x * MM_PER_M:.4f} (fixed)" for x, e in zip(v, sd))
            out.append(f"  {kind} {k} ({frame}): {cells} mm")
    if any(s == 0 for s in su.std.values()) or (su.targets and not su.std):
        out.append("  (fixed: a coordinate the design cannot tell from the model's terms stays at its start value)")
    return out


def run_evaluate(args) -> int:
    if args.sign_test:
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
    camp.targets = dict(model.setup_.targets)  # the fitted offsets of the targets it saw
    ev = evaluate(model, camp, reregister=args.reregister, zone=zone_option(args.zone), model_source=args.model)
    for w in ev.warnings:
        print(w)
    print(f"{model.label()} ({args.model}) on {args.csv}: {ev.rows} rows"
          + (" (tracker re-registered)" if args.reregister else ""))
    print("\n".join(ev.lines()))
    if args.json:
        write_text(args.json, json.dumps({"model": str(args.model), "campaign": str(args.csv)} | ev.to_dict(), indent=1))
        print(f"wrote {args.json}")
    return 0


def run_orders(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.selection.orders import order_sweep
    m = machine(args.machine, args)
    c = read_campaign(args.csv, m)
    v = read_campaign(args.validation, m) if args.validation else None
    say = progress(not args.quiet)
    orders = parse_orders(args.orders)
    from vecpin.selection.choice import check_basis
    check_basis(m, args.basis, "chebyshev")
    nm = noise(args, m)
    if args.multilateration:
        from vecpin.measurement.instruments.multilateration import check_stations
        check_stations(c)
    from vecpin.selection.orders import check_orders
    check_orders(m, c, args.model, orders, folds=None if v is not None else args.folds, noise=nm,
                 basis="chebyshev" if args.basis == "chebyshev" else "auto")
    if v is None:  # a view of the model choice: linearised CV over the same candidates
        from vecpin.selection.choice import choose_model
        fam = tuple(dict.fromkeys((args.basis, "chebyshev")))
        choice = choose_model(m, c, nm, kinds=tuple(args.model), families=fam, plans=(args.basis,),
                              orders=orders, per_axis=False, folds=args.folds, progress=say)
        print(choice.table(limit=len(choice.candidates)))
        for kind in args.model:
            best = min((x for x in choice.candidates if x.kind == kind), key=lambda x: x.mean)
            print(f"best {kind} order on held-out data ({args.folds}-fold CV, linearised): {best.axes[0].order}")
        return 0
    for kind in args.model:  # Paper I Table 2: every order fitted, judged on the validation file
        sweep = order_sweep(m, c, kind, orders, validation=v, folds=args.folds, noise=nm,
                            basis="chebyshev" if args.basis == "chebyshev" else "auto", progress=say)
        print(sweep.table())
        print(f"best {kind} order on held-out data ({sweep.method}): {sweep.best.order}\n")
    return 0


def run_demo(args) -> int:
    from pathlib import Path

    from vecpin.workflows.demo import run_demo as demo
    res = demo(args.out, seed=args.seed, order=args.order, progress=progress(not args.quiet))
    print("\n".join(res.table()))
    print(f"files in {args.out}: " + ", ".join(p.name for p in res.files))
    out = Path(args.out)
    print(f"the same by hand: vecpin fit flow_xyzcb {out / 'campaign.csv'} --out {out / 'model.json'}; "
          f"vecpin evaluate {out / 'model.json'} {out / 'validation.csv'}")
    return 0


def register(sub) -> None:
    s = sub.add_parser("fit", help="choose and identify an error model from a campaign CSV (maximum likelihood)")
    s.add_argument("machine", help=MACHINE_HELP)
    s.add_argument("csv", help=CAMPAIGN_HELP)
    add_model_args(s)
    s.add_argument("--folds", type=int, default=5,
                   help="cross-validation folds of the model choice, grouped by command (default %(default)s)")
    s.add_argument("--out", required=True, help="model file to write (JSON, mm and deg)")
    s.add_argument("--tool-corrections", action="store_true",
                   help="also fit a length correction per tool, mm (default: the gauge-line correction T_offset only)")
    s.add_argument("--prior-scale", type=float, default=1.0,
                   help="factor on every parameter's prior standard deviation (Σ_b), dimensionless, > 0 "
                        "(default %(default)s)")
    s.add_argument("--underdetermined", action="store_true",
                   help="accept fewer equations than unknowns, the priors deciding the rest: the model choice then "
                        "also tries candidates larger than the campaign supports (default: the choice leaves them "
                        "out, and a fixed model that large is refused)")
    s.add_argument("--zone", metavar="AXIS=LO:HI[,...]",
                   help="fit only the rows commanded in this region of axis space, mm/deg (a machine calibrated in "
                        "zones, seed Table 2.12); the model file records it and vecpin tables uses it (default: all rows)")
    s.add_argument("--targets", metavar="CSV",
                   help="known tool-target offsets: a CSV 'target,x,y,z' in mm in the tool link frame; targets of the "
                        "campaign's 'target' column not in it are found by the fit (default: all found by the fit)")
    add_machine_args(s)
    add_noise_args(s)
    s.set_defaults(func=run_fit)

    s = sub.add_parser("evaluate", help="residuals of a fitted model on a campaign CSV (on a table machine with nest "
                       "rows: the tool tip relative to the table)")
    s.add_argument("model", help="fitted model file (JSON, from vecpin fit)")
    s.add_argument("csv", help=CAMPAIGN_HELP + "; measured from the model's tracker pose unless --reregister")
    s.add_argument("--json", help="also write the figures (mm) to this JSON file (default: print only)")
    s.add_argument("--reregister", action="store_true",
                   help="the tracker was moved: register its pose to this file first (default: the model's pose)")
    s.add_argument("--sign-test", metavar="JSON", help="CSV is a sign-test check (compensation,command,reading): say "
                                                       "whether the controller applies the table with the right sign; "
                                                       "JSON is the SIGNTEST_*.json of vecpin tables (default: none)")
    s.add_argument("--zone", metavar="AXIS=LO:HI[,...]", help="judge only the rows commanded in this region, mm/deg "
                                                             "(default: all rows)")
    s.set_defaults(func=run_evaluate)

    s = sub.add_parser("orders", help="choose the series order on held-out data (Paper I Table 2)")
    s.add_argument("machine", help=MACHINE_HELP)
    s.add_argument("csv", help=CAMPAIGN_HELP)
    s.add_argument("--model", choices=["6dof", "ap"], nargs="+", default=["6dof", "ap"],
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
