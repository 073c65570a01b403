"""``vecpin plan``: choose the commands of a campaign and write the template, NC programs
and the point-distribution figure."""
from __future__ import annotations

from vecpin.cli.common import add_machine_args, add_noise_args, machine, noise, progress, say
from vecpin.errors import InputError

#: --basis as the fit takes it (vecpin.planning.problem.BASES: how a plan builds each)
BASES = ("auto", "chebyshev", "fourier", "fourier_trend", "spline", "pspline", "smooth")


def parse_floats(text: str, option: str, count: int | None = None) -> tuple[float, ...]:
    """'1,2,3' -> (1.0, 2.0, 3.0); ``count`` numbers exactly when given."""
    try:
        vals = tuple(float(v) for v in str(text).split(","))
    except ValueError:
        vals = ()
    if not vals or (count is not None and len(vals) != count):
        what = f"{count} numbers" if count else "numbers"
        raise InputError(f"{option} '{text}': write {what} separated by commas, e.g. "
                         + ("3000,-2200,-300" if count == 3 else "214.88,312.86"))
    return vals


def parse_nest_options(texts: list[str]) -> dict[str, tuple[float, float, float]] | None:
    """--nest ID=X,Y,Z (mm, workpiece frame), repeatable -> {id: (x, y, z) mm}."""
    from vecpin.planning.nests import parse_nest
    from vecpin.units import to_mm
    out: dict[str, tuple[float, float, float]] = {}
    for t in texts or []:
        nid, xyz = parse_nest(t)
        if nid in out:
            raise InputError(f"--nest '{t}': nest {nid} is given twice; one position per nest id")
        out[nid] = tuple(float(v) for v in to_mm(xyz))
    return out or None


def parse_tools(texts: list[str], option: str = "--tools") -> tuple[float, ...]:
    """``--tools`` as plan and simulate take it: lengths in mm separated by spaces or commas
    (``214.88 312.86`` or ``214.88,312.86``)."""
    return tuple(v for t in texts for v in parse_floats(t, option))


def plan_order(text: str) -> int | str:
    """``--order`` of a plan: a whole number >= 0, or "auto" (the plan takes 6, Paper I's:
    a plan is made before the data can choose; its messages say it was auto)."""
    if str(text).strip().lower() == "auto":
        return "auto"
    try:
        order = int(text)
    except ValueError:
        order = -1
    if order < 0:
        raise InputError(f"--order '{text}': a whole number >= 0, or auto")
    return order


def run_plan(args) -> int:
    from vecpin.measurement.campaign import PAPER_I_TOOLS_MM
    from vecpin.planning.plan import PlanSettings
    from vecpin.planning.zones import parse_zone
    from vecpin.workflows.planning import plan_to_dir
    from vecpin.workflows.tables import parse_axis_map
    m = machine(args.machine, args)
    settings = PlanSettings(
        n_commands=args.n_commands, tools_mm=parse_tools(args.tools_mm) if args.tools_mm else PAPER_I_TOOLS_MM,
        model=args.model, order=plan_order(args.order), basis=args.basis, noise=noise(args, m),
        tracker_mm=parse_floats(args.tracker_mm, "--tracker", 3) if args.tracker_mm else None,
        exclude=[parse_zone(z, "exclude") for z in args.exclude],
        zone=parse_zone(args.zone, "zone") if args.zone else None, method=args.method, approach=args.approach,
        approach_mm=args.approach_mm, approach_deg=args.approach_deg,
        repeat_points=args.repeat[0] if args.repeat else 0, repeat_times=args.repeat[1] if args.repeat else 0,
        sight=not args.no_sight, geometry=args.geometry, tool_radius_mm=args.tool_radius_mm,
        target_clearance_mm=args.target_clearance_mm, rapid_mm_min=args.rapid_mm_min, rapid_deg_min=args.rapid_deg_min,
        candidates=args.candidates, seed=args.seed, n_validation=args.n_validation,
        expected_error_mm=args.expected_error_mm, nests=args.nests, nest_mm=parse_nest_options(args.nest_mm))
    run = plan_to_dir(m, args.out, settings, dialects=tuple(args.dialect) if args.dialect else None,
                      dwell_s=args.dwell_s, nest_dwell_s=args.nest_dwell_s, feed_mm_min=args.feed_mm_min,
                      safe_z_mm=args.safe_z_mm, retract=args.retract, axis_map=parse_axis_map(args.axis_map, m),
                      compare_with=args.compare_with, progress=progress(not args.quiet),
                      holder_change_s=args.holder_change_s, tracker_move_s=args.tracker_move_s,
                      read_dwell_s=args.read_dwell_s, nest_heights=not args.no_nest_heights)
    say(args, *run.lines())
    return 0


def add_commands(sub) -> None:
    s = sub.add_parser("plan", help="plan a laser-tracker campaign: D-optimal commands, exclusion zones, line of "
                       "sight, short travel; writes the campaign template, NC programs and Paper I Fig. 6")
    s.add_argument("machine", help="bundled machine name or URDF path")
    add_machine_args(s)
    s.add_argument("--out", required=True, help="output folder (plan.csv, PLAN_840D.MPF, O1000.nc, plan.ngc, the validation run "
                   "validation.csv, VALID_840D.MPF, O1001.nc, validation.ngc, plan.png, "
                   "plan.json; with table nests nest_heights.csv)")
    _add_setup_args(s)
    _add_choice_args(s)
    _add_route_args(s)
    _add_program_args(s)
    add_noise_args(s, multilateration=False, ballbar=False)  # a plan has no range-only or ball bar rows
    s.add_argument("--seed", type=int, default=0, help="seed of the candidate set and random choices (default 0)")
    s.add_argument("--quiet", action="store_true", help="no progress lines (default: progress on stderr)")
    s.set_defaults(func=run_plan)


def _add_setup_args(s) -> None:
    """What is measured and with what: commands, holders, tracker, table nests, zones."""
    s.add_argument("--points", dest="n_commands", type=int, default=100, help="commands to measure, each with every "
                   "holder length (default 100; Paper I measured 295; at most 10000: under a minute to plan on a head "
                   "machine; with table nests above 5500 it takes longer and the plan warns; under 1 GB)")
    s.add_argument("--tools", dest="tools_mm", nargs="+", metavar="L",
                   help="target holder lengths from the gauge line, mm, separated by spaces or commas (default "
                        "214.88 312.86 as Paper I)")
    s.add_argument("--tracker", dest="tracker_mm", metavar="X,Y,Z", help="tracker head position in the machine base "
                   "frame, mm (default: 2 m beyond the tool-tip workspace on the side from which the tips are in "
                   "sight: in front, at its lowest height, unless the machine's geometry hides them there)")
    s.add_argument("--nests", type=int, help="reflectors in table nests read at every command's dwell, on a machine "
                   "with table axes (a 'workpiece' link): the only readings that see the table axes (default 3 there, "
                   "0 elsewhere; at most 20)")
    s.add_argument("--nest", dest="nest_mm", action="append", default=[], metavar="ID=X,Y,Z",
                   help="a table nest where you place it: its id and position, mm in the workpiece (table) frame; "
                        "repeatable, replaces the default places (default: on a circle on the table at 20-80 mm)")
    s.add_argument("--no-nest-heights", action="store_true",
                   help="do not ask for the nests' heights above the table's face (default: with table nests the plan "
                        "writes nest_heights.csv for the heights you measure, mm; vecpin fit --nest-heights reads it "
                        "and keeps the table's face; without it the table is taken where the model places it)")
    s.add_argument("--exclude", action="append", default=[], metavar="AXIS=LO:HI[,...]",
                   help="exclusion zone in axis space, mm/deg: commands inside are not measured (collision "
                        "avoidance); repeatable (default: none)")
    s.add_argument("--zone", metavar="AXIS=LO:HI[,...]", help="measurement zone in axis space, mm/deg: plan only "
                   "inside it (calibration in zones); default: the whole travel")


def _add_choice_args(s) -> None:
    """The model the campaign is planned for and how the commands are chosen and judged."""
    s.add_argument("--model", choices=["auto", "ap", "6dof"], default="auto",
                   help="error model the campaign is planned for: 6dof or ap, or auto: vecpin chooses (before any "
                        "data: 6dof on a machine with table axes, whose tilt and wobble only nest readings see, ap "
                        "elsewhere, as Paper I) (default auto)")
    s.add_argument("--order", default="auto", help="series order of that model, as the fit takes it (a whole number; "
                   "with --basis spline or pspline the number of interior knots per axis), or auto: vecpin chooses "
                   "(before any data: 6, as Paper I) (default auto)")
    s.add_argument("--basis", default="auto", choices=BASES,
                   help="basis of the error functions, as the fit takes it: chebyshev over the travel, fourier (per "
                        "turn on rotary axes travelling more than a turn), fourier_trend (per turn plus a trend), "
                        "spline (cubic B-splines; pspline and smooth: planned as spline, their smoothing or smoothness "
                        "prior only adds information), "
                        "or auto: vecpin chooses (before any data: fourier where it applies, chebyshev elsewhere) "
                        "(default auto)")
    s.add_argument("--method", choices=["doptimal", "random"], default="doptimal",
                   help="how the commands are chosen: doptimal, greedy D-optimal (default); random, at random, as "
                        "Paper I did")
    s.add_argument("--candidates", type=int, help="candidate commands to choose from (default 10 x points, at least "
                   "2000; beyond 10000 candidates 3 x points, so that 10000 points take about a minute)")
    s.add_argument("--repeat", type=int, nargs=2, metavar=("POINTS", "TIMES"),
                   help="repeated points (eq. 22): POINTS commands measured TIMES times, half of the sequences at the "
                        "start and half at the end (default: none)")
    s.add_argument("--validation-count", dest="n_validation", type=int, default=35, metavar="N",
                   help="commands of the validation run (validation.csv and its NC programs: inside the zone, free and "
                        "in sight with the first holder; measure them without and with the tables) (default 35)")
    s.add_argument("--expected-error", dest="expected_error_mm", type=float, default=0.2, metavar="MM",
                   help="the machine's mean volumetric error uncompensated, as a tracker measures it (rigid motion "
                        "removed), mm: the plan warns when its predicted error exceeds half of it (default 0.2)")
    s.add_argument("--compare", dest="compare_with", action="append", default=[], metavar="PLAN.csv|random",
                   help="also judge another plan's template (or 'random': the same number of commands at random) "
                        "with the same model and noise; repeatable (default: none)")


def _add_route_args(s) -> None:
    """Line of sight, approach and the speeds of the moves between the points."""
    s.add_argument("--approach", choices=["below", "above", "both", "none"], default="below",
                   help="approach every point from below on every axis (default), from above, both (each point "
                        "twice, to measure backlash), or none")
    s.add_argument("--approach-mm", type=float, default=5.0, help="approach distance on linear axes, mm (default 5)")
    s.add_argument("--approach-deg", type=float, default=1.0, help="approach distance on rotary axes, deg (default 1)")
    s.add_argument("--no-sight", action="store_true", help="do not test the line of sight (default: test it)")
    s.add_argument("--geometry", choices=["auto", "collision", "visual"], default="auto",
                   help="URDF geometry that blocks the sight line (default auto: collision if any, else visual)")
    s.add_argument("--tool-radius-mm", type=float, default=10.0,
                   help="radius of the target holder, which can block its own target, mm (default 10; 0: ignore); "
                        "on an arm also the holder's radius in the collision check of every pose its program visits")
    s.add_argument("--target-clearance-mm", type=float, default=19.1,
                   help="radius of the retroreflector; the sight line ends this far from the target centre, mm "
                        "(default 19.1, a 1.5 in SMR)")
    s.add_argument("--rapid-mm-min", type=float, help="rapid speed of the linear axes for the order, mm/min "
                   "(default: URDF velocity limits)")
    s.add_argument("--rapid-deg-min", type=float, help="rapid speed of the rotary axes, deg/min "
                   "(default: URDF velocity limits)")


def _add_program_args(s) -> None:
    """The NC programs: dwells, retract, feed, addresses, dialects, holder changes."""
    s.add_argument("--dwell", dest="dwell_s", type=float, default=4.0, help="dwell at every point for the tracker to "
                   "read the tool target, s (default 4)")
    s.add_argument("--nest-dwell", dest="nest_dwell_s", type=float, default=15.0, help="further dwell per table nest "
                   "read at a point, s (default 15: the operator moves the tracker to each nest)")
    s.add_argument("--read-dwell", dest="read_dwell_s", type=float, default=2.0, metavar="S", help="dwell per further "
                   "reading of a point at its standstill (a table machine's validation run reads the tool and each "
                   "nest 4 times), the tracker's reading time, s (default 2, an assumption: time your tracker)")
    s.add_argument("--safe-z", dest="safe_z_mm", type=float, metavar="MM", help="machine coordinate the retract axis "
                   "(see --retract-axis) moves to before every move between points, mm; the other linear axes, then "
                   "the rotary axes move there and it plunges to the next point (default: the end of its travel away "
                   "from the work)")
    s.add_argument("--retract-axis", dest="retract", metavar="AXIS", help="linear axis that lifts the tool off the "
                   "work between points (default: the one along the tool at zero rotary angles, usually Z)")
    s.add_argument("--holder-change", dest="holder_change_s", type=float, default=120.0, metavar="S",
                   help="time to change the target holder at the program's stop, s, for the campaign's time (default 120)")
    s.add_argument("--tracker-move", dest="tracker_move_s", type=float, default=1200.0, metavar="S",
                   help="time to move the tracker to the plan's next station (carry, level, settle, lock on), s, for "
                        "the campaign's time (default 1200, an assumption: time yours)")
    s.add_argument("--feed", dest="feed_mm_min", type=float, default=1000.0, help="feed of the final approach move, "
                   "mm/min (default 1000)")
    s.add_argument("--dialect", action="append",
                   choices=["siemens-840d", "fanuc", "gcode", "heidenhain", "urscript", "joint-list"],
                   help="program to write; repeatable: siemens-840d, fanuc, gcode, heidenhain (Klartext) for a machine "
                        "tool (default: the first three); urscript (Universal Robots, plan.script) or joint-list "
                        "(joint positions in degrees, plan_joints.csv) for an arm (default: both)")
    s.add_argument("--axis-map", action="append", default=[], metavar="JOINT=NCNAME",
                   help="NC address of an axis when it is not the URDF joint name; repeatable (default: joint names)")

