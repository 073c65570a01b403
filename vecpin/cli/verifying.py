"""``vecpin assess`` (is compensation worth it?) and ``vecpin verify`` (before and after)."""
from __future__ import annotations

import math

from vecpin.cli.common import add_machine_args, add_tracker_noise_arg, machine, progress, say
from vecpin.errors import InputError


def run_assess(args) -> int:
    from vecpin.workflows.assessing import assess_campaign, assess_numbers
    if args.json:
        from vecpin.fileio import check_output_file
        check_output_file(args.json, "json")
    if args.csv:
        if not args.machine:
            raise InputError("assess CSV needs --machine (bundled name or URDF path)")
        from vecpin.measurement.campaign import read_campaign
        from vecpin.measurement.noise import noise_from_options
        m = machine(args.machine, args)
        noise = None
        if args.tracker_noise:
            noise = noise_from_options(m, "spherical", tracker_noise=args.tracker_noise).tracker
        if not (math.isfinite(args.session_gap_min) and args.session_gap_min > 0):
            raise InputError(f"--session-gap-min {args.session_gap_min}: minutes > 0 (default 30)")
        res = assess_campaign(read_campaign(args.csv, m), m, noise, session_gap=args.session_gap_min * 60.0)
    else:
        if args.mean_error is None:
            raise InputError("give a campaign CSV with repeated points, or the numbers: --mean-error and --long-term "
                             "(and --short-term, --max-error) in mm")
        res = assess_numbers(args.mean_error, args.long_term, args.short_term, args.max_error)
    say(args, *res.lines())
    if args.json:
        import json

        from vecpin.fileio import write_text
        write_text(args.json, json.dumps(res.to_dict(), indent=1) + "\n")
        print(f"  wrote {args.json}")
    return 0


def run_verify(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.workflows.verifying import load_tables, verify_to_dir
    if args.out:
        from vecpin.fileio import check_output_dir
        check_output_dir(args.out)
    model = None
    if args.model_file:
        from vecpin.models import ErrorModel
        model = ErrorModel.load(args.model_file)
    if model is None and not args.machine:
        raise InputError("verify needs --machine, or --model-file (whose machine is used)")
    m = model.machine if model is not None else machine(args.machine, args)
    if model is not None and args.machine:
        from vecpin.models.modelfile import check_same_machine
        check_same_machine(machine(args.machine, args), model.machine, f"--machine {args.machine}", f"--model-file {args.model_file}")
    tables, src = load_tables(args.tables, m) if args.tables else (None, None)
    thermal, thermal_src = (None, None)
    if args.tables:
        from vecpin.workflows.verifythermal import load_thermal
        thermal, thermal_src = load_thermal(args.tables, m)
    before, after = read_campaign(args.before, m), read_campaign(args.after, m)
    v = verify_to_dir(m, before, after, args.out, model=model, tables=tables, tables_source=src,
                      progress=progress(not args.quiet), thermal=thermal, thermal_source=thermal_src)
    say(args, *v.lines())
    return 0


def add_commands(sub) -> None:
    s = sub.add_parser("assess", help="is volumetric compensation worth it? repeatability (eq. 22, Table 2.8) against "
                       "the uncompensated error, with what limits the result (Section 2.4)")
    s.add_argument("csv", nargs="?", help="campaign CSV with repeated points (same command and tool measured several "
                   "times; vecpin plan --repeat)")
    s.add_argument("--machine", help="bundled machine name or URDF path (needed with a CSV; default: none)")
    add_machine_args(s)
    s.add_argument("--session-gap-min", type=float, default=30.0,
                   help="repeats further apart than this are different sessions (short vs long term), min (default 30)")
    add_tracker_noise_arg(s, "tracker noise for the instrument floor")
    s.add_argument("--mean-error", type=float, help="without a CSV: uncompensated mean volumetric error, mm (default: none)")
    s.add_argument("--max-error", type=float, help="without a CSV: uncompensated max volumetric error, mm (optional; default: none)")
    s.add_argument("--long-term", type=float, help="without a CSV: long-term repeatability (mean of eq. 22), mm (default: none)")
    s.add_argument("--short-term", type=float, help="without a CSV: short-term repeatability (mean of eq. 22), mm (default: none)")
    s.add_argument("--json", help="also write the figures to this JSON file (default: none)")
    s.set_defaults(func=run_assess)

    s = sub.add_parser("verify", help="uncompensated and compensated validation runs side by side (Paper I Table 3, "
                       "Fig. 11), with the model's prediction (on a table machine whose runs read the table nests: the "
                       "tip relative to the table)")
    s.add_argument("before", help="validation run of the machine WITHOUT the tables (campaign CSV)")
    s.add_argument("after", help="validation run WITH the tables active (campaign CSV; commands as programmed)")
    s.add_argument("--machine", help="bundled machine name or URDF path (default: the model's machine)")
    add_machine_args(s)
    s.add_argument("--model-file", help="fitted model file: its predicted errors beside the measured ones (default: none)")
    s.add_argument("--tables", help="the table set that was active (tables.json or its folder): its gauge-line change "
                   "enters the commanded positions; a thermal.json beside it: the runs are judged with the thermal terms at "
                   "their temperatures (default: none, 0 mm assumed)")
    s.add_argument("--out", help="folder for verify.json and verify.png (Fig. 11) (default: print only)")
    s.add_argument("--quiet", action="store_true", help="no progress lines (default: progress on stderr)")
    s.set_defaults(func=run_verify)
