"""``vecpin diagnose``: where the residual lies, which effect causes it, how far it shrinks."""
from __future__ import annotations

from vecpin.cli.common import (CAMPAIGN_HELP, MACHINE_HELP, add_machine_args, add_model_args, add_noise_args, machine,
                               noise, progress)
from vecpin.errors import InputError


def run_diagnose(args) -> int:
    from vecpin.diagnosis.diagnose import diagnose
    from vecpin.measurement.campaign import read_campaign
    from vecpin.fileio import check_output_dir
    from vecpin.selection.orders import check_folds
    check_output_dir(args.out)
    m = machine(args.machine, args)
    nm = noise(args, m)
    c = read_campaign(args.csv, m)
    effects = "all" if args.effects == "all" else [e.strip() for e in args.effects.split(",") if e.strip()]
    from vecpin.models.effects import REGISTRY
    unknown = [e for e in effects if e not in REGISTRY] if effects != "all" else []
    if not effects or unknown:
        raise InputError(f"--effects '{args.effects}': 'all' or a comma list of effect names"
                         + (f"; unknown effect '{unknown[0]}'" if unknown else "") + f" (known: {', '.join(REGISTRY)})")
    check_folds(c, args.folds)
    if args.multilateration:
        from vecpin.measurement.instruments.multilateration import check_stations
        check_stations(c)
    d = diagnose(m, c, model=args.model, order=args.order, effects=effects, noise=nm, folds=args.folds,
                 alpha=args.alpha, basis=args.basis, progress=progress(not args.quiet))
    print(d.summary())
    for p in d.write(args.out).values():
        print(f"wrote {p}")
    print(f"diagnosis took {d.seconds:.1f} s")
    return 0


def register(sub) -> None:
    s = sub.add_parser("diagnose", help="where the residual lies, which unmodelled effect causes it, how far it shrinks")
    s.add_argument("machine", help=MACHINE_HELP)
    add_machine_args(s)
    s.add_argument("csv", help=CAMPAIGN_HELP)
    s.add_argument("--out", required=True, help="output folder: diagnosis.json (mm), model_base.json, model_best.json, "
                   "report.md with figures")
    add_model_args(s)
    s.add_argument("--effects", default="all", help="effects to try: all, or a comma list of effect names (vecpin "
                   "simulate --help-effects lists them) (default %(default)s)")
    s.add_argument("--folds", type=int, default=5,
                   help="cross-validation folds grouped by command, for the base model and every effect (default %(default)s)")
    s.add_argument("--alpha", type=float, default=0.01,
                   help="family-wise false-alarm rate per round of the forward selection, a probability, dimensionless "
                        "(default %(default)s)")
    add_noise_args(s)
    s.set_defaults(func=run_diagnose)
