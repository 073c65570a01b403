"""``vecpin simulate``: a laser-tracker campaign on a machine with known errors."""
from __future__ import annotations

import argparse

from vecpin.cli.common import machine


def run_simulate(args) -> int:
    from vecpin.simulation.simulate import Design, parse_zone
    from vecpin.models.effects import parse_effect
    from vecpin.workflows.simulating import simulate_to_dir
    m = machine(args.machine)
    design = Design(n_commands=args.points, n_validation=args.validation, method=args.method,
                    exclusion_zones=[parse_zone(z) for z in args.exclude],
                    tools_mm=tuple(args.tools) if args.tools else Design().tools_mm,
                    repeat_points=args.repeat[0] if args.repeat else 0, repeat_times=args.repeat[1] if args.repeat else 0,
                    stations=args.stations, ballbar_points=args.ballbar)
    effects = [parse_effect(e, m) for e in args.effect]
    run = simulate_to_dir(m, args.out, seed=args.seed, design=design, effects=effects, mean_error_mm=args.mean_error)
    print("\n".join(run.lines()))
    return 0


class _HelpEffects(argparse.Action):
    """--help-effects: every effect's keys with units and defaults, then exit."""

    def __init__(self, option_strings, dest, **kw):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kw)

    def __call__(self, parser, namespace, values, option_string=None):
        from vecpin.models.effects import effects_help
        print(effects_help())
        parser.exit()


def register(sub) -> None:
    s = sub.add_parser("simulate", help="simulate a laser-tracker campaign on a machine with known errors")
    s.add_argument("--help-effects", action=_HelpEffects, help="list the effects of --effect with their keys, units "
                   "and defaults, then exit")
    s.add_argument("machine")
    s.add_argument("--out", required=True, help="output folder (campaign.csv, validation.csv, validation_truth.csv, truth.json)")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--points", type=int, default=295, help="commands (each measured with every tool); default 295 as Paper I")
    s.add_argument("--validation", type=int, default=35, help="validation commands (short tool); default 35")
    s.add_argument("--tools", type=float, nargs="+", help="tool lengths in mm (default 214.88 312.86)")
    s.add_argument("--method", default="random", choices=["random", "sobol", "halton"])
    s.add_argument("--exclude", action="append", default=[], metavar="AXIS=LO:HI[,...]",
                   help="exclusion zone in mm/deg (repeatable)")
    s.add_argument("--mean-error", type=float, default=0.65, help="mean volumetric error of the true machine, mm")
    s.add_argument("--stations", type=int, default=1, help="tracker positions measuring every command (default 1)")
    s.add_argument("--ballbar", type=int, default=0, metavar="N", help="add N ball bar rows on a 254 mm sphere (eq. 63-64)")
    s.add_argument("--repeat", type=int, nargs=2, metavar=("POINTS", "TIMES"),
                   help="append a repeatability sequence: POINTS commands measured TIMES times each (eq. 22)")
    s.add_argument("--effect", action="append", default=[], metavar="NAME:key=value,...",
                   help="add an unmodelled effect to the true machine, e.g. gantry_skew:axes=Y,about=x,depends=X,"
                        "strength=0.05 (strength: RMS tool-tip displacement, mm); repeatable")
    s.set_defaults(func=run_simulate)
