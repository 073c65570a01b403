"""``vecpin diagnose``: where the residual lies, which effect causes it, how far it shrinks."""
from __future__ import annotations

from vecpin.cli.common import (CAMPAIGN_HELP, MACHINE_HELP, add_machine_args, add_model_args, add_noise_args,
                               add_quiet_arg, machine, noise, progress, say, zone_option)
from vecpin.cli.fitting import add_nest_height_args, nest_heights, table_face


def run_diagnose(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.workflows.diagnosing import diagnose_to_dir
    m = machine(args.machine, args)
    campaign = read_campaign(args.csv, m)
    run = diagnose_to_dir(m, campaign, args.out, noise(args, m), model=args.model, order=args.order,
                          effects=args.effects, folds=args.folds, alpha=args.alpha, basis=args.basis,
                          progress=progress(not args.quiet), base=args.base, zone=zone_option(args.zone),
                          nest_heights=nest_heights(args.nest_height, args.nest_heights, campaign),
                          table_face=table_face(args.table_face, m))
    say(args, *run.lines())
    return 0


def add_commands(sub) -> None:
    s = sub.add_parser("diagnose", help="where the residual lies, which unmodelled effect causes it, how far it shrinks")
    s.add_argument("machine", help=MACHINE_HELP)
    add_machine_args(s)
    s.add_argument("csv", help=CAMPAIGN_HELP)
    s.add_argument("--out", required=True, help="output folder: diagnosis.json (mm), model_base.json, model_best.json, "
                   "report.md with figures")
    add_model_args(s)
    s.add_argument("--base", metavar="MODEL_JSON", default=None,
                   help="model.json of vecpin fit: its kind, bases and orders are the base model (refitted on the rows "
                        "the diagnosis keeps), so the model choice is not repeated (default: chosen by held-out data)")
    s.add_argument("--zone", metavar="AXIS=LO:HI[,...]",
                   help="diagnose only the rows commanded in this region of axis space, mm/deg, for a machine used "
                        "there only: no axis counts as measured over part of its travel beyond it; the model files "
                        "record it (default: all rows, the model used over the whole travel)")
    add_nest_height_args(s)
    s.add_argument("--effects", default="all", help="effects to try: all, or a comma list of effect names (vecpin "
                   "simulate --help-effects lists them) (default %(default)s)")
    s.add_argument("--folds", type=int, default=5,
                   help="cross-validation folds grouped by command, for the base model and every effect (default %(default)s)")
    s.add_argument("--alpha", type=float, default=0.01,
                   help="family-wise false-alarm rate per round of the forward selection, a probability, dimensionless "
                        "(default %(default)s)")
    add_noise_args(s)
    add_quiet_arg(s)
    s.set_defaults(func=run_diagnose)
