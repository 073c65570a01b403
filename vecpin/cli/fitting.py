"""``vecpin fit``, ``evaluate``, ``orders`` and ``demo``: identification on the command line."""
from __future__ import annotations

import json

import numpy as np

from vecpin.cli.common import add_model_args, add_noise_args, machine, noise, parse_orders, progress


def run_fit(args) -> int:
    from vecpin.fileio import check_output_file
    from vecpin.measurement.campaign import read_campaign
    from vecpin.units import norm_mm
    from vecpin.workflows.fitting import fit_campaign
    from vecpin.workflows.summary import per_tool_table
    m = machine(args.machine)
    check_output_file(args.out)
    c = read_campaign(args.csv, m)
    run = fit_campaign(m, c, noise(args, m), kind=args.model, basis=args.basis, order=args.order,
                       tool_corrections=args.tool_corrections, prior_scale=args.prior_scale,
                       underdetermined=args.underdetermined, folds=args.folds, progress=progress(not args.quiet))
    model = run.model
    model.save(args.out)
    if run.choice is not None:
        print(run.choice.table())
    rep = model.report_
    print(rep.summary())
    if rep.removed:
        print(f"redundant terms removed ({len(rep.removed)}): {', '.join(rep.removed)}")
    c0 = c.primary()
    rows = [("uncompensated (nominal kinematics)", norm_mm(c0.xyz - model.predict_nominal(c0.q, c0.tool))),
            (model.label(), norm_mm(model.residuals(c0)))]
    print("\n".join(per_tool_table(rows, c0.tool)))
    if c.ballbar_rows.size:
        d = np.abs(model.ballbar_residuals(c)) * 1e3
        print(f"  ball bar rows: {d.size}, |radius residual| mean {d.mean():.4f} mm, max {d.max():.4f} mm")
    print(f"wrote {args.out}")
    return 0


def run_evaluate(args) -> int:
    if args.sign_test:
        from vecpin.cli.compensating import run_sign_check
        return run_sign_check(args)
    from vecpin.fileio import check_output_file, write_text
    from vecpin.measurement.campaign import read_campaign
    from vecpin.models import ErrorModel
    from vecpin.workflows.evaluation import evaluate
    if args.json:
        check_output_file(args.json, "--json")
    model = ErrorModel.load(args.model)
    ev = evaluate(model, read_campaign(args.csv, model.machine), reregister=args.reregister, model_source=args.model)
    print(f"{model.kind} model, order {model.order} ({args.model}) on {args.csv}: {ev.rows} rows"
          + (" (tracker re-registered)" if args.reregister else ""))
    print("\n".join(ev.lines()))
    if args.json:
        write_text(args.json, json.dumps({"model": str(args.model), "campaign": str(args.csv)} | ev.to_dict(), indent=1))
        print(f"wrote {args.json}")
    return 0


def run_orders(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.selection.orders import order_sweep
    m = machine(args.machine)
    c = read_campaign(args.csv, m)
    v = read_campaign(args.validation, m) if args.validation else None
    say = progress(not args.quiet)
    orders = parse_orders(args.orders)
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
    print(f"the same by hand: vecpin fit flow_xyzcb {out / 'campaign.csv'} --spherical --out {out / 'model.json'}; "
          f"vecpin evaluate {out / 'model.json'} {out / 'validation.csv'}")
    return 0


def register(sub) -> None:
    s = sub.add_parser("fit", help="identify an error model from a campaign CSV (maximum likelihood)")
    s.add_argument("machine")
    s.add_argument("csv")
    add_model_args(s)
    s.add_argument("--folds", type=int, default=5, help="cross-validation folds of the model choice (default 5)")
    s.add_argument("--out", required=True, help="model file to write (JSON)")
    s.add_argument("--tool-corrections", action="store_true", help="also fit a length correction per tool")
    s.add_argument("--prior-scale", type=float, default=1.0, help="multiply every parameter prior sigma")
    s.add_argument("--underdetermined", action="store_true",
                   help="accept fewer equations than parameters (the priors decide the rest)")
    add_noise_args(s)
    s.set_defaults(func=run_fit)

    s = sub.add_parser("evaluate", help="residuals of a fitted model on a campaign CSV")
    s.add_argument("model")
    s.add_argument("csv")
    s.add_argument("--json", help="also write the figures to this JSON file")
    s.add_argument("--reregister", action="store_true", help="the tracker was moved: register its pose to this file first")
    s.add_argument("--sign-test", metavar="JSON", help="CSV is a sign-test check (compensation,command,reading): say "
                                                       "whether the controller applies the table with the right sign")
    s.set_defaults(func=run_evaluate)

    s = sub.add_parser("orders", help="choose the series order on held-out data (Paper I Table 2)")
    s.add_argument("machine")
    s.add_argument("csv")
    s.add_argument("--model", choices=["6dof", "ap"], nargs="+", default=["6dof", "ap"])
    s.add_argument("--orders", default="0-7", help="e.g. 0-7 or 2,4,6")
    s.add_argument("--validation", help="validation CSV: every order fitted and judged on it (Paper I Table 2); "
                   "default: k-fold cross-validation of the linearised candidates")
    s.add_argument("--basis", choices=["chebyshev", "fourier"], default="chebyshev",
                   help="chebyshev everywhere (the seed's, default) or fourier per turn on rotary axes travelling "
                        "more than a turn")
    s.add_argument("--folds", type=int, default=5)
    add_noise_args(s)
    s.set_defaults(func=run_orders)

    s = sub.add_parser("demo", help="simulate Paper I's campaign, fit both models, print the before/after table")
    s.add_argument("--out", default="demo")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--order", type=int, default=6)
    s.add_argument("--quiet", action="store_true")
    s.set_defaults(func=run_demo)
