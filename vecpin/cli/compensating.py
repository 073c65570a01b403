"""``vecpin tables``: compensation tables of a fitted model for a controller; the sign check."""
from __future__ import annotations

import argparse

from vecpin.cli.common import progress, say, zone_option


def run_tables(args) -> int:
    from vecpin.export.common import UserCommands
    from vecpin.measurement.campaign import read_campaign
    from vecpin.models import ErrorModel
    from vecpin.workflows.tables import make_tables, parse_axis_map
    model = ErrorModel.load(args.model)
    m = model.machine
    commands = read_campaign(args.commands, m) if args.commands else None
    thermal = None
    if args.thermal:   # checked before the tables are computed
        from vecpin.workflows.thermal import check_campaign, check_controller
        check_controller(args.controller)
        thermal = read_campaign(args.thermal, m)
        check_campaign(thermal)
    zone = zone_option(args.zone)
    for a in zone or {}:
        m.axis(a)
    profile = f" --profile {args.profile}" if args.profile else ""
    how = UserCommands(sign_test=f"`vecpin tables {args.model} --controller {args.controller} --sign-test AXIS`",
                       sign_check=f"`vecpin evaluate {args.model} SIGNTEST_{{tag}}.csv --sign-test-file SIGNTEST_{{tag}}.json`",
                       pitch_only=f"`vecpin tables {args.model} --controller {args.controller}{profile} --max-tables 0 "
                                  "--out DIR`")
    run = make_tables(model, args.out, args.controller, profile=args.profile, axis_map=parse_axis_map(args.axis_map, m),
                      max_tables=args.max_tables, no_circular=args.no_circular, forbid_output=args.forbid_output,
                      method=args.method, points=args.points, tools_mm=args.tools, modulo_axes=args.modulo,
                      commands=commands, sign_test=args.sign_test, zone=zone, user_commands=how,
                      progress=progress(not args.quiet), products=args.products)
    say(args, *run.lines(args.model))
    if thermal is not None:
        from vecpin.workflows.thermal import make_thermal
        th = make_thermal(model, thermal, args.out, args.controller, profile=args.profile,
                          axis_map=parse_axis_map(args.axis_map, m))
        say(args, *th.lines())
    return 0


def run_sign_check(args) -> int:
    """``vecpin evaluate MODEL CHECK.csv --sign-test-file SIGNTEST_X.json``."""
    from vecpin.models import ErrorModel
    from vecpin.workflows.tables import check_sign
    model = ErrorModel.load(args.model)
    verdict = check_sign(args.test_path, args.csv, model.machine)
    say(args, *verdict.lines())
    return 0


def add_commands(sub) -> None:
    from vecpin.export.names import CONTROLLERS
    s = sub.add_parser("tables", help="compensation tables of a fitted model for a controller (Paper I §3.3, Paper II)")
    s.add_argument("model", help="fitted model file (JSON)")
    s.add_argument("--controller", default="generic", choices=CONTROLLERS,
                   help="controller whose files to write (default generic: tables.json/csv only)")
    s.add_argument("--profile", metavar="JSON",
                   help="the machine's controller profile: NC axis names, reference positions [mm/deg], modulo axes, "
                        "detection units, limits (see docs/compensation.md; vecpin profile writes a template); default: none (enough for generic and iso230)")
    s.add_argument("--axis-map", action="append", default=[], metavar="JOINT=NCNAME",
                   help="NC axis name of a joint, wins over the profile's nc_name; repeatable (default: the "
                        "profile's names)")
    s.add_argument("--max-tables", type=int, help="cross tables to choose (default: as many as the controller "
                                                  "holds; pitch tables are always in)")
    s.add_argument("--no-circular", action="store_true", help="never use table ij together with ji (default: "
                   "allowed unless the controller forbids it)")
    s.add_argument("--forbid-output", action="append", default=[], metavar="AXIS",
                   help="axis whose command no table may change; repeatable (default: none)")
    s.add_argument("--method", default="exact", choices=["exact", "ga", "heuristic"],
                   help="subset selection method (default exact)")
    s.add_argument("--table-points", dest="points", type=int,
                   help="points per table (default: 1024 or the controller's maximum if smaller)")
    s.add_argument("--tools", type=float, nargs="+", help="tool lengths in mm (default: those of the fit)")
    s.add_argument("--modulo", action="append", default=[], metavar="AXIS",
                   help="rotary input axis with modulo tables over one turn 0..360 deg (also: \"modulo\": true in "
                        "the profile); repeatable (default: none)")
    s.add_argument("--commands", help="campaign CSV whose commands (and tools) the tables are fitted and judged on "
                   "(default: quasi-random commands in the measured region, with the fit's tools: at least 1000, more when the "
                   "table set has many coefficients, 40 equations each; the printout gives the number)")
    s.add_argument("--sign-test", metavar="AXIS|TABLE",
                   help="also write a sign-test NC program and instructions for this axis' pitch table or this "
                        "table (e.g. X or yx); judge it with vecpin evaluate --sign-test-file (default: none)")
    s.add_argument("--zone", metavar="AXIS=LO:HI[,...]",
                   help="fit the tables in this region of axis space only, mm/deg (default: the zone the model was "
                        "fitted in, else the whole measured region)")
    s.add_argument("--out", required=True, help="output folder: tables.json, tables.csv (mm, deg), the controller's "
                   "files and their README")
    s.add_argument("--products", action=argparse.BooleanOptionalAction, default=None,
                   help="on a machine whose table turns, add product terms (a table of the rotary axis times a ramp of "
                        "a linear axis: a tilt fixed to the table) where they lower the error; generic files, LinuxCNC "
                        "(vecpin's HAL component) and SINUMERIK ($AN_CEC_MULT_BY_TABLE). Default: on where the model "
                        "was fitted with the nests' heights above the table's face (--nest-height) and the controller "
                        "carries them as planned (generic, LinuxCNC); on SINUMERIK only with --products (the unit of "
                        "its product is inferred from the manual: confirm on the machine); --no-products: none")
    s.add_argument("--thermal", metavar="CSV", help="campaign with time and temperature columns: also fit the "
                   "controller's thermal terms (offset and slope per linear axis, tool growth) and write them "
                   "(thermal.json, the controller's thermal files; default: none)")
    s.add_argument("--quiet", action="store_true", help="no progress lines (default: progress on stderr)")
    s.set_defaults(func=run_tables)
    add_profile_command(sub)


def run_profile(args) -> int:
    from vecpin.cli.common import machine
    from vecpin.workflows.tables import write_profile_template
    m = machine(args.machine, args)
    path, needed, optional = write_profile_template(m, args.controller, args.out)
    print(f"wrote {path}: the {args.controller} profile of {m.name} with {needed} field(s) the controller's files "
          f"need and {optional} optional one(s) to fill in (null); each field's meaning and where it is found on the "
          "control are in its \"comment\"")
    return 0


def add_profile_command(sub) -> None:
    from vecpin.cli.common import add_machine_args
    from vecpin.export.names import CONTROLLERS
    s = sub.add_parser("profile", help="write a controller profile to fill in: every field the controller's files "
                                       "need, what it is and where it is on the control")
    s.add_argument("machine", help="bundled machine name or URDF path")
    s.add_argument("--controller", required=True, choices=CONTROLLERS, help="the controller of the machine")
    s.add_argument("--out", required=True, help="the profile file to write (JSON); an existing file is not replaced")
    add_machine_args(s)
    s.set_defaults(func=run_profile)
