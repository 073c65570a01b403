"""``vecpin simulate``: a laser-tracker campaign on a machine with known errors."""
from __future__ import annotations

import argparse

import numpy as np

from vecpin.cli.common import add_machine_args, machine, say
from vecpin.units import M_PER_MM


def run_simulate(args) -> int:
    from vecpin.cli.planning import parse_floats, parse_tools
    from vecpin.models.effects import parse_effect
    from vecpin.planning.zones import parse_zone
    from vecpin.simulation.simulate import Design
    from vecpin.workflows.simulating import simulate_to_dir, simulation_inputs
    m = machine(args.machine, args)
    targets = tuple(tuple(parse_floats(t, "--target", 3)) for t in args.targets_mm)
    design = Design(n_commands=args.n_commands, n_validation=args.n_validation, method=args.method,
                    exclude=[parse_zone(z, "exclude") for z in args.exclude],
                    tools_mm=parse_tools(args.tools_mm) if args.tools_mm else Design().tools_mm,
                    repeat_points=args.repeat[0] if args.repeat else 0, repeat_times=args.repeat[1] if args.repeat else 0,
                    stations=args.stations, ballbar_points=args.ballbar_points, nests=args.nests, targets_mm=targets,
                    known_targets=args.known_targets)
    inputs = simulation_inputs(m, plan=args.plan, tables=args.tables, truth=args.truth,
                               temperature_profile=args.temperature_profile, validation_after_h=args.validation_after,
                               thermal=args.thermal)
    tracker = None
    if args.tracker_position:
        tracker = np.array(parse_floats(args.tracker_position, "--tracker", 3)) * M_PER_MM
    run = simulate_to_dir(m, args.out, seed=args.seed, design=design, effects=[parse_effect(e, m) for e in args.effect],
                          tracker_position=tracker, mean_error_mm=args.mean_error_mm, **inputs)
    say(args, *run.lines())
    return 0


class _HelpEffects(argparse.Action):
    """--help-effects: every effect's keys with units and defaults, then exit."""

    def __init__(self, option_strings, dest, **kw):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kw)

    def __call__(self, parser, namespace, values, option_string=None):
        from vecpin.models.effects import effects_help
        print(effects_help())
        parser.exit()


def add_commands(sub) -> None:
    s = sub.add_parser("simulate", help="simulate a laser-tracker campaign on a machine with known errors")
    s.add_argument("--help-effects", action=_HelpEffects, help="list the effects of --effect with their keys, units "
                   "and defaults, then exit")
    s.add_argument("machine", help="bundled machine name or URDF path")
    add_machine_args(s)
    s.add_argument("--out", required=True, help="output folder (campaign.csv, validation.csv, validation_truth.csv, "
                   "truth.json; with --tables also validation_compensated.csv and its noise-free twin)")
    s.add_argument("--seed", type=int, default=0, help="random seed: the same seed gives the same true machine and "
                   "files (default 0)")
    s.add_argument("--points", dest="n_commands", type=int, default=295, help="commands, each measured with every tool (default 295 as "
                   "Paper I; ignored with --plan)")
    s.add_argument("--validation-count", dest="n_validation", type=int, default=35, help="quasi-random validation commands, short tool "
                   "(default 35 as Paper I; with --plan: the plan's validation run, its validation.csv, when there)")
    s.add_argument("--tools", dest="tools_mm", nargs="+", metavar="L", help="tool lengths in mm, separated by spaces "
                   "or commas (default 214.88 312.86 as Paper I)")
    s.add_argument("--method", default="random", choices=["random", "sobol", "halton"],
                   help="how the commands are chosen: drawn at random, or from a scrambled Sobol or Halton "
                        "sequence (default random, as Paper I)")
    s.add_argument("--plan", help="measure a plan's template (plan.csv from vecpin plan) in its order instead of "
                   "drawing commands, timed as its NC program runs (plan.json beside it), validated on its validation "
                   "run (validation.csv beside it) (default: none)")
    s.add_argument("--tables", help="tables.json (or its folder, from vecpin tables): also run the validation commands "
                   "on the true machine through these tables (default: none)")
    s.add_argument("--temperature-profile", metavar="PROFILE",
                   help="the hall's temperature the simulated machine follows: warmup:START:END:HOURS (a ramp, then "
                        "END), cycle:MEAN:AMPL:PERIOD_H, or a CSV with columns time [s], temperature [degC] "
                        "(default: the workshop, 20 degC with a daily swing and a slow drift)")
    s.add_argument("--validation-after", type=float, metavar="HOURS",
                   help="hours from the campaign's last row to the validation run (default 10 minutes)")
    s.add_argument("--thermal", metavar="JSON", help="thermal.json (from vecpin tables --thermal): the controller's "
                   "thermal terms, active in the run through --tables (default: none)")
    s.add_argument("--truth", help="truth.json of an earlier simulation: simulate that true machine instead of a new "
                   "random one (default: random from --seed and --mean-error)")
    s.add_argument("--tracker", dest="tracker_position", metavar="X,Y,Z", help="where the simulated tracker stands, machine base frame, mm "
                   "(e.g. the plan's position; default: 2 m in front of the workspace, random offset)")
    s.add_argument("--exclude", action="append", default=[], metavar="AXIS=LO:HI[,...]",
                   help="exclusion zone in mm/deg (repeatable; default none)")
    s.add_argument("--mean-error", dest="mean_error_mm", type=float, default=0.65, help="mean volumetric error of the true machine, mm "
                   "(default 0.65)")
    s.add_argument("--stations", type=int, default=1, help="tracker positions measuring every command (default 1)")
    s.add_argument("--nests", type=int, metavar="N",
                   help="reflectors in N nests fixed on the table, read at every command (nest rows; their positions "
                        "are found by the fit). Default: 3 on a machine with a table branch (a 'workpiece' link), "
                        "else 0")
    s.add_argument("--target", dest="targets_mm", action="append", default=[], metavar="X,Y,Z",
                   help="a reflector on the tool at this offset from the tool link origin, mm in the tool link frame "
                        "(repeatable: several targets per pose, ids T1, T2, ...; read instead of the --tools; the true "
                        "offsets go to targets.csv; default: the tool tips)")
    s.add_argument("--known-targets", action="store_true",
                   help="the campaign's targets are known (else the fit finds their offsets; default unknown)")
    s.add_argument("--ballbar", dest="ballbar_points", type=int, default=0, metavar="N", help="add N ball bar rows on a 254 mm sphere "
                   "(eq. 63-64; default 0)")
    s.add_argument("--repeat", type=int, nargs=2, metavar=("POINTS", "TIMES"),
                   help="append a repeatability sequence: POINTS commands measured TIMES times each (eq. 22; "
                        "default none)")
    s.add_argument("--effect", action="append", default=[], metavar="NAME:key=value,...",
                   help="add an unmodelled effect to the true machine, e.g. gantry_skew:axes=Y,about=x,depends=X,"
                        "strength=0.05 (strength: RMS tool-tip displacement, mm); repeatable (default none)")
    s.set_defaults(func=run_simulate)
