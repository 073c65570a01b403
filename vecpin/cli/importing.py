"""``vecpin import``: a tracker-software export into a campaign CSV."""
from __future__ import annotations

from vecpin.cli.common import add_machine_args, machine, say


def run_import(args) -> int:
    from vecpin.workflows.importing import import_to_file
    m = machine(args.machine, args)
    res = import_to_file(args.export, m, args.out, args.plan, export_format=args.export_format, columns=args.columns,
                         units=args.units, delimiter=args.delimiter, decimal=args.decimal,
                         time_format=args.time_format, temperature_unit=args.temperature_unit, tool_mm=args.tool_mm,
                         ignore_unmatched=args.ignore_unmatched)
    say(args, *res.lines(), f"  wrote {args.out}")
    return 0


def add_commands(sub) -> None:
    s = sub.add_parser("import", help="read a tracker-software export (any column names, delimiter, decimal comma, "
                       "inches) and join it with the plan into a campaign CSV")
    s.add_argument("export", help="the tracker software's export (CSV/TXT)")
    s.add_argument("--machine", required=True, help="bundled machine name (vecpin info lists them) or URDF path")
    add_machine_args(s)
    s.add_argument("--format", dest="export_format", choices=["tracker", "ipa-robot-accuracy"], default="tracker",
                   help="tracker: a tracker program's export (default); ipa-robot-accuracy: a measurements_*.csv of "
                        "the public UR10 dataset github.com/christianlandgraf/ipa-robot-accuracy (machine ur10; joints "
                        "in rad, T-Mac centre in mm, tool 109 mm unless --tool-mm)")
    s.add_argument("--plan", help="the plan's campaign template (plan.csv from vecpin plan): commands and holder lengths "
                   "(default: none; then the export must have the axis columns)")
    s.add_argument("--out", required=True, help="campaign CSV to write (mm, deg, comma-separated)")
    s.add_argument("--columns", metavar="FIELD=COLUMN,...",
                   help="which export column holds what, e.g. 'x=Meas X,y=Meas Y,z=Meas Z,point=Name,"
                        "time=Timestamp,temperature=Air Temp' (fields: x y z point time temperature tool and the "
                        "axis names); default: recognised from the header")
    s.add_argument("--units", choices=["auto", "mm", "in", "m"], default="auto",
                   help="units of x, y, z in the export (default auto: header, preamble, and the spread of the points "
                        "against the plan)")
    s.add_argument("--delimiter", default="auto", choices=["auto", "comma", "semicolon", "tab"],
                   help="cell separator (default auto: from the header line)")
    s.add_argument("--decimal", default="auto", choices=["auto", ".", ","],
                   help="decimal mark (default auto: from the numbers)")
    s.add_argument("--time-format", help="strptime format of text time stamps, e.g. '%%d.%%m.%%Y %%H:%%M:%%S' "
                   "(default: seconds, or ISO and common date-time forms)")
    s.add_argument("--temperature-unit", choices=["auto", "C", "F", "K"], default="auto",
                   help="unit of the temperature column (default auto: from the header; written in °C)")
    s.add_argument("--tool-mm", type=float, help="holder length in mm when there is neither a plan nor a tool column "
                   "(default: none)")
    s.add_argument("--ignore-unmatched", action="store_true",
                   help="skip export rows whose point is not in the plan (default: an error)")
    s.set_defaults(func=run_import)
