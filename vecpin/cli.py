"""Command line: a thin layer over the Python API.

Every user error (bad file, unknown machine, ...) prints one clear line and exits
with status 2; nothing prints a traceback for bad input.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from vecpin.errors import VecpinError


def _machine(name: str):
    from vecpin.kinematics.machine import Machine
    return Machine.load(name)


def cmd_info(args) -> int:
    from vecpin.kinematics.machine import bundled_machines
    m = _machine(args.machine)
    print(m.describe())
    if args.machine not in bundled_machines():
        print(f"  (bundled machines: {', '.join(bundled_machines())})")
    return 0


def _error_summary(label: str, err_mm: np.ndarray) -> str:
    d = np.linalg.norm(err_mm, axis=1)
    return f"  {label:<42s} mean {d.mean():8.4f} mm   max {d.max():8.4f} mm   RMS {np.sqrt((d**2).mean()):8.4f} mm"


def parse_effect(text: str, machine):
    """'gantry_skew:axes=Y,about=x,depends=X,strength=0.05' -> TrueEffect."""
    from vecpin.simulation.trueeffects import TrueEffect
    name, _, rest = text.partition(":")
    known = ("gantry_skew", "coupled_axes", "thermal", "backlash", "rotary_periodic", "instrument_shift", "outliers")
    if name not in known:
        raise VecpinError(f"--effect '{text}': unknown effect '{name}' (known: {', '.join(known)})")
    axes, strength, seed, options = (), 0.05, 0, {}
    for part in filter(None, rest.split(",")):
        if "=" not in part:
            raise VecpinError(f"--effect '{text}': write NAME:key=value,... (axes=Y+X, strength=MM, seed=N, ...)")
        k, v = part.split("=", 1)
        if k == "axes":
            axes = tuple(a for a in v.split("+") if a)
            for a in axes:
                machine.axis(a)
        elif k == "strength":
            strength = float(v)
        elif k == "seed":
            seed = int(v)
        else:
            try:
                options[k] = float(v)
            except ValueError:
                options[k] = v
    return TrueEffect(name, axes, strength, options, seed)


def cmd_simulate(args) -> int:
    from vecpin.measurement.registration import registered_errors
    from vecpin.simulation.simulate import Design, parse_zone, simulate
    m = _machine(args.machine)
    design = Design(n_commands=args.points, n_validation=args.validation, method=args.method,
                    exclusion_zones=[parse_zone(z) for z in args.exclude],
                    tools_mm=tuple(args.tools) if args.tools else Design().tools_mm,
                    repeat_points=args.repeat[0] if args.repeat else 0, repeat_times=args.repeat[1] if args.repeat else 0,
                    stations=args.stations, ballbar_points=args.ballbar)
    effects = [parse_effect(e, m) for e in args.effect]
    sim = simulate(m, seed=args.seed, design=design, mean_error_mm=args.mean_error, effects=effects or None)
    paths = sim.write(args.out)
    c = sim.campaign
    c = c.subset(c.tracker_rows[c.station[c.tracker_rows] == 0])  # the summary: station 0's tracker rows
    nominal = m.tool_tip(c.q, c.tool)
    true_tip = sim.truth.tool_tip(c.q, c.tool)
    extra = sim.campaign
    more = ""
    if extra.mixed:
        more = (f" + {len(extra) - len(c)} rows of {design.stations - 1} more stations and "
                f"{extra.ballbar_rows.size} ball bar rows")
    print(f"simulated {m.name}, seed {args.seed}: {len(c)} rows{more} ({design.n_commands} commands x "
          f"{len(design.tools_mm)} tools {', '.join(f'{t:g}' for t in design.tools_mm)} mm), "
          f"{len(sim.validation)} validation rows")
    print(_error_summary("true vs nominal tip (machine frame)", (true_tip - nominal) * 1e3))
    print(_error_summary("uncompensated (measured, registered)", registered_errors(nominal, c.xyz) * 1e3))
    dist = np.linalg.norm(c.xyz, axis=1)
    print(f"  tracker range {dist.min():.2f} .. {dist.max():.2f} m; campaign takes {c.time[-1] / 3600:.2f} h")
    for k, p in paths.items():
        print(f"  wrote {p}  ({k})")
    return 0


def _progress(enabled: bool = True):
    import time
    t0 = time.perf_counter()

    def say(msg: str) -> None:
        if enabled:
            print(f"  [{time.perf_counter() - t0:6.1f} s] {msg}", file=sys.stderr, flush=True)
    return say


def _noise(args, machine):
    from vecpin.measurement.noise import NoiseModel
    from vecpin.measurement.tracker import TrackerNoise
    kind = "range" if getattr(args, "multilateration", False) else ("spherical" if args.spherical else "cartesian")
    noise = NoiseModel.default(machine, kind)
    if getattr(args, "ballbar_sigma_mm", None) is not None:
        noise.ballbar_sigma = args.ballbar_sigma_mm * 1e-3
    sig = noise.axis_sigma.copy()
    for k, a in enumerate(machine.axes):
        if a.kind == "linear" and args.repeatability_mm is not None:
            sig[k] = args.repeatability_mm * 1e-3
        if a.kind == "rotary" and args.repeatability_deg is not None:
            sig[k] = np.radians(args.repeatability_deg)
    noise.axis_sigma = sig
    if args.tracker_sigma_mm is not None:
        noise.cartesian_sigma = args.tracker_sigma_mm * 1e-3
    if args.tracker_noise is not None:
        a, b, c, d = args.tracker_noise
        noise.tracker = TrackerNoise(a * 1e-3, b * 1e-6, c * 1e-3, d * 1e-6)
    return noise


def _per_tool_table(rows: list[tuple[str, np.ndarray]], tool: np.ndarray) -> list[str]:
    from vecpin.identification.fit import distance_stats
    lines = [f"  {'':<40s} {'n':>5s} {'mean mm':>9s} {'max mm':>9s} {'RMS mm':>9s}"]
    for label, d in rows:
        st = distance_stats(d, tool)
        keys = list(st) if len(st) > 2 else ["all"]  # per tool only when there are several
        for k in keys:
            s = st[k]
            name = label if k == "all" else f"    {k}"
            lines.append(f"  {name:<40s} {s['n']:5d} {s['mean']:9.4f} {s['max']:9.4f} {s['rms']:9.4f}")
    return lines


def cmd_fit(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.models import make_model
    m = _machine(args.machine)
    c = read_campaign(args.csv, m)
    say = _progress(not args.quiet)
    tools = [float(t) for t in c.tool_lengths()] if args.tool_corrections else None
    model = make_model(args.model, m, args.order, basis=args.basis, tool_lengths=tools, prior_scale=args.prior_scale)
    say(f"fitting {args.model} order {args.order} ({model.n_parameters + 6} parameters) to {len(c)} rows of {args.csv}")
    model.fit(c, _noise(args, m), progress=say, underdetermined=args.underdetermined)
    model.save(args.out)
    rep = model.report_
    print(rep.summary())
    if rep.removed:
        print(f"redundant terms removed ({len(rep.removed)}): {', '.join(rep.removed)}")
    sel = c.tracker_rows[c.station[c.tracker_rows] == 0]
    c0 = c.subset(sel)
    nominal = model.predict_nominal(c0.q, c0.tool)
    rows = [("uncompensated (nominal kinematics)", np.linalg.norm(c0.xyz - nominal, axis=1) * 1e3),
            (f"{args.model} model, order {args.order}", np.linalg.norm(model.residuals(c)[sel], axis=1) * 1e3)]
    print("\n".join(_per_tool_table(rows, c0.tool)))
    if c.ballbar_rows.size:
        d = np.abs(model.ballbar_residuals(c)) * 1e3
        print(f"  ball bar rows: {d.size}, |radius residual| mean {d.mean():.4f} mm, max {d.max():.4f} mm")
    print(f"wrote {args.out}")
    return 0


def cmd_evaluate(args) -> int:
    import json
    from vecpin.measurement.campaign import read_campaign
    from vecpin.identification.fit import distance_stats
    from vecpin.models import ErrorModel
    from vecpin.measurement.registration import registered_errors
    model = ErrorModel.load(args.model)
    m = model.machine
    full = read_campaign(args.csv, m)
    c = full.subset(full.tracker_rows[full.station[full.tracker_rows] == 0]) if full.mixed else full
    nominal = m.tool_tip(c.q, c.tool)
    if args.reregister:
        d_nom = np.linalg.norm(registered_errors(nominal, c.xyz), axis=1) * 1e3
    else:
        d_nom = np.linalg.norm(c.xyz - model.predict_nominal(c.q, c.tool), axis=1) * 1e3
    d_mod = np.linalg.norm(model.residuals(c, reregister=args.reregister), axis=1) * 1e3
    print(f"{model.kind} model, order {model.order} ({args.model}) on {args.csv}: {len(c)} rows"
          + (" (tracker re-registered)" if args.reregister else ""))
    print("\n".join(_per_tool_table([("uncompensated (nominal kinematics)", d_nom), ("model", d_mod)], c.tool)))
    red = 100 * (1 - d_mod.mean() / d_nom.mean())
    print(f"  reduction of the mean: {red:.1f}%")
    if full.mixed:
        print(f"  (station 0 tracker rows; the file has {len(full) - len(c)} more rows of other stations or the ball bar)")
    if args.json:
        out = {"model": str(args.model), "campaign": str(args.csv), "rows": len(c), "reregistered": args.reregister,
               "units": "mm", "uncompensated": distance_stats(d_nom, c.tool), "model_residual": distance_stats(d_mod, c.tool),
               "reduction_of_mean_pct": red}
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)
        print(f"wrote {args.json}")
    return 0


def _orders(text: str) -> list[int]:
    out = []
    for part in text.split(","):
        if "-" in part:
            a, b = part.split("-")
            out += list(range(int(a), int(b) + 1))
        else:
            out.append(int(part))
    return out


def cmd_orders(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.selection.orders import order_sweep
    m = _machine(args.machine)
    c = read_campaign(args.csv, m)
    v = read_campaign(args.validation, m) if args.validation else None
    say = _progress(not args.quiet)
    for kind in args.model:
        sweep = order_sweep(m, c, kind, _orders(args.orders), validation=v, folds=args.folds,
                            noise=_noise(args, m), basis=args.basis, progress=say)
        print(sweep.table())
        print(f"best {kind} order on held-out data ({sweep.method}): {sweep.best.order}\n")
    return 0


def cmd_demo(args) -> int:
    from vecpin.models import make_model
    from vecpin.measurement.noise import NoiseModel
    from vecpin.simulation.simulate import simulate
    from vecpin.kinematics.machine import Machine
    m = Machine.load("flow_xyzcb")
    say = _progress(not args.quiet)
    say("simulating Paper I's campaign on flow_xyzcb (295 commands x 2 tools, 35 validation points)")
    sim = simulate(m, seed=args.seed, mean_error_mm=0.65)
    paths = sim.write(args.out)
    c, v, exact = sim.campaign, sim.validation, sim.validation_truth
    table = []
    for kind in ("6dof", "ap"):
        model = make_model(kind, m, args.order)
        say(f"fitting the {kind} model, order {args.order}")
        model.fit(c, NoiseModel.default(m, "spherical"))
        model.save(Path(args.out) / f"model_{kind}.json")
        res = lambda camp: np.linalg.norm(model.residuals(camp), axis=1)  # noqa: E731
        table.append((f"{'6-DoF' if kind == '6dof' else 'AP'} order {args.order}", res(c), res(v), res(exact), model.report_))
    # the nominal tracker pose is the registration of the nominal kinematics: the same for both models
    nom = lambda camp: np.linalg.norm(camp.xyz - model.predict_nominal(camp.q, camp.tool), axis=1)  # noqa: E731
    table.insert(0, ("Uncompensated", nom(c), nom(v), nom(exact), None))
    print(f"vecpin demo: Paper I design on the simulated laboratory XYZCB machine (seed {args.seed}), mm")
    print(f"  {'model':<16s} | {'identification (590)':^21s} | {'validation (35)':^21s} | {'noise-free validation':^21s} | fit time")
    print(f"  {'':<16s} | {'mean':>10s} {'max':>10s} | {'mean':>10s} {'max':>10s} | {'mean':>10s} {'max':>10s} |")
    for label, a, b, e, rep in table:
        t = f"{rep.seconds:6.2f} s" if rep else ""
        print(f"  {label:<16s} | {a.mean() * 1e3:10.4f} {a.max() * 1e3:10.4f} | {b.mean() * 1e3:10.4f} {b.max() * 1e3:10.4f} | "
              f"{e.mean() * 1e3:10.4f} {e.max() * 1e3:10.4f} | {t}")
    print("  seed, Paper I Table 2 (real machine): uncompensated 0.602/1.417 (ident), 0.568/1.110 (valid); "
          "6-DoF order 6 0.027/0.071, 0.062/0.092; AP order 6 0.029/0.091, 0.049/0.132")
    print(f"files in {args.out}: " + ", ".join(p.name for p in paths.values()) + ", model_6dof.json, model_ap.json")
    print(f"the same by hand: vecpin fit flow_xyzcb {paths['campaign']} --model ap --order {args.order} --spherical "
          f"--out {Path(args.out) / 'model_ap.json'}; vecpin evaluate {Path(args.out) / 'model_ap.json'} {paths['validation']}")
    return 0


def _axis_map(items: list[str]) -> dict[str, str]:
    out = {}
    for it in items:
        if "=" not in it:
            raise VecpinError(f"--axis-map takes JOINT=NCNAME, not '{it}'")
        a, b = it.split("=", 1)
        out[a.strip()] = b.strip()
    return out


def cmd_tables(args) -> int:
    from vecpin.export.controllers import write_fanuc, write_generic, write_siemens
    from vecpin.models import ErrorModel
    from vecpin.compensation.plan import plan_tables
    model = ErrorModel.load(args.model)
    m = model.machine
    for a in args.forbid_output:
        m.axis(a)
    say = _progress(not args.quiet)
    commands = None
    if args.commands:
        from vecpin.measurement.campaign import read_campaign
        camp = read_campaign(args.commands, m)
        commands = camp.q
        if args.tools is None:
            args.tools = [float(t * 1e3) for t in camp.tool_lengths()]
    plan = plan_tables(model, args.controller, max_tables=args.max_tables, no_circular=args.no_circular or None,
                       forbid_output=args.forbid_output, points=args.points, method=args.method,
                       tools_mm=args.tools, modulo_axes=args.modulo, commands=commands, progress=say)
    print(f"compensation tables for {m.name} ({args.controller}), model {args.model}")
    grid = (f"resampled to the controller's grid, at most {plan.controller.max_points} points"
            if args.controller == "fanuc-30i" else f"{args.points} points each")
    print(f"  tables: {' '.join(plan.tables.names())}  ({len(plan.tables.tables)} tables, {grid})")
    print(f"  gauge line (T_offset) change: {plan.tables.gauge_offset_change * 1e3:+.4f} mm")
    if plan.selection is not None:
        s = plan.selection
        print(f"  selection ({s.method}): {' '.join(s.tables)} in {s.seconds:.2f} s, {s.evaluations} combinations scored")
    where = f"the commands of {args.commands}" if args.commands else "1000 quasi-random commands"
    tools = ", ".join(f"{t * 1e3:g}" for t in plan.problem.tools)
    print(f"  predicted volumetric error (model, {where} x tools {tools} mm):")
    print(plan.report.table())
    if args.controller == "siemens-840d":
        files = write_siemens(plan.tables, m, args.out, _axis_map(args.axis_map), plan.controller)
    elif args.controller == "fanuc-30i":
        files = write_fanuc(plan.tables, m, args.out, plan.controller)
    else:
        files = []
    files += write_generic(plan.tables, m, args.out)
    for f in files:
        print(f"  wrote {f}")
    return 0


def cmd_diagnose(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.diagnosis.diagnose import diagnose
    m = _machine(args.machine)
    c = read_campaign(args.csv, m)
    effects = "all" if args.effects == "all" else [e.strip() for e in args.effects.split(",") if e.strip()]
    d = diagnose(m, c, model=args.model, order=args.order, effects=effects, noise=_noise(args, m), folds=args.folds,
                 alpha=args.alpha, basis=args.basis, progress=_progress(not args.quiet))
    print(d.summary())
    for k, p in d.write(args.out).items():
        print(f"wrote {p}")
    print(f"diagnosis took {d.seconds:.1f} s")
    return 0


def cmd_view(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.models import ErrorModel
    from vecpin.viz.scene import build_scene, write_html
    model = ErrorModel.load(args.model)
    c = read_campaign(args.csv, model.machine)
    if not 0 <= args.row < len(c):
        raise VecpinError(f"--row {args.row}: the campaign has rows 0 .. {len(c) - 1}")
    tables = None
    if not args.no_tables:
        from vecpin.compensation.plan import plan_tables
        tables = plan_tables(model, "generic", n_commands=400).tables
    if args.html:
        facts = write_html(args.html, model, c, args.row, args.exaggerate, tables)
        print(f"wrote {args.html}: errors x{facts['exaggeration']:.0f}, largest {facts['max_error_mm']:.3f} mm, "
              f"{facts['commands']} scene commands; open it in a browser (no server needed)")
        return 0
    import time
    import meshcat
    vis = meshcat.Visualizer()
    try:
        facts = build_scene(vis, model, c, args.row, args.exaggerate, tables)
        print(f"meshcat scene at {vis.url()}  (errors x{facts['exaggeration']:.0f}; groups under /vecpin can be "
              "switched on and off in Open Controls > Scene); Ctrl-C to stop")
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        return 0
    finally:
        if vis.window.server_proc is not None:
            vis.window.server_proc.kill()


def cmd_report(args) -> int:
    from vecpin.measurement.campaign import read_campaign
    from vecpin.models import ErrorModel
    from vecpin.viz.report import write_report
    model = ErrorModel.load(args.model)
    c = read_campaign(args.csv, model.machine)
    v = read_campaign(args.validation, model.machine) if args.validation else None
    page = write_report(model, c, args.out, validation=v, orders=_orders(args.orders) if args.orders else None,
                        controller=args.controller, max_tables=args.max_tables, progress=_progress(not args.quiet))
    print(f"wrote {page} (with figures/ and scene.html)")
    return 0


def _noise_args(s) -> None:
    s.add_argument("--spherical", action="store_true", help="tracker noise in its native spherical coordinates (range dependent)")
    s.add_argument("--multilateration", action="store_true", help="use the tracker ranges only (several stations)")
    s.add_argument("--ballbar-sigma-mm", type=float, help="ball bar radius noise, mm (default 0.0025)")
    s.add_argument("--repeatability-mm", type=float, help="1-sigma positioning noise of linear axes, mm (default 0.006)")
    s.add_argument("--repeatability-deg", type=float, help="1-sigma positioning noise of rotary axes, deg (default 0.0015)")
    s.add_argument("--tracker-sigma-mm", type=float, help="Cartesian tracker noise, mm (default 0.02)")
    s.add_argument("--tracker-noise", type=float, nargs=4, metavar=("R_MM", "R_PPM", "T_MM", "T_PPM"),
                   help="spherical tracker noise: range sigma = R_MM + R_PPM*R, transverse = T_MM + T_PPM*R")
    s.add_argument("--basis", default="auto", choices=["auto", "chebyshev"],
                   help="auto: Fourier on rotary axes travelling more than a turn, Chebyshev elsewhere (default)")
    s.add_argument("--quiet", action="store_true", help="no progress lines")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="vecpin", description="Volumetric error compensation of machine tools.")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("info", help="axes, limits and frames of a machine (bundled name or URDF path)")
    s.add_argument("machine")
    s.set_defaults(func=cmd_info)

    s = sub.add_parser("simulate", help="simulate a laser-tracker campaign on a machine with known errors")
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
    s.set_defaults(func=cmd_simulate)

    s = sub.add_parser("fit", help="identify an error model from a campaign CSV (maximum likelihood)")
    s.add_argument("machine")
    s.add_argument("csv")
    s.add_argument("--model", choices=["6dof", "ap"], default="ap")
    s.add_argument("--order", type=int, default=6)
    s.add_argument("--out", required=True, help="model file to write (JSON)")
    s.add_argument("--tool-corrections", action="store_true", help="also fit a length correction per tool")
    s.add_argument("--prior-scale", type=float, default=1.0, help="multiply every parameter prior sigma")
    s.add_argument("--underdetermined", action="store_true",
                   help="accept fewer equations than parameters (the priors decide the rest)")
    _noise_args(s)
    s.set_defaults(func=cmd_fit)

    s = sub.add_parser("evaluate", help="residuals of a fitted model on a campaign CSV")
    s.add_argument("model")
    s.add_argument("csv")
    s.add_argument("--json", help="also write the figures to this JSON file")
    s.add_argument("--reregister", action="store_true", help="the tracker was moved: register its pose to this file first")
    s.set_defaults(func=cmd_evaluate)

    s = sub.add_parser("orders", help="choose the series order on held-out data (Paper I Table 2)")
    s.add_argument("machine")
    s.add_argument("csv")
    s.add_argument("--model", choices=["6dof", "ap"], nargs="+", default=["6dof", "ap"])
    s.add_argument("--orders", default="0-7", help="e.g. 0-7 or 2,4,6")
    s.add_argument("--validation", help="validation CSV (default: k-fold cross-validation)")
    s.add_argument("--folds", type=int, default=5)
    _noise_args(s)
    s.set_defaults(func=cmd_orders)

    s = sub.add_parser("tables", help="compensation tables of a fitted model for a controller (Paper I §3.3, Paper II)")
    s.add_argument("model")
    s.add_argument("--controller", default="generic", choices=["siemens-840d", "fanuc-30i", "generic"])
    s.add_argument("--max-tables", type=int, help="cross tables to choose (pitch tables are always in)")
    s.add_argument("--no-circular", action="store_true", help="never use table ij together with ji")
    s.add_argument("--forbid-output", action="append", default=[], metavar="AXIS", help="axis that cannot be corrected")
    s.add_argument("--method", default="exact", choices=["exact", "ga", "heuristic"], help="subset selection method")
    s.add_argument("--points", type=int, default=1024, help="points per table (default 1024)")
    s.add_argument("--tools", type=float, nargs="+", help="tool lengths in mm (default: those of the fit)")
    s.add_argument("--axis-map", action="append", default=[], metavar="JOINT=NCNAME", help="NC axis names (Siemens)")
    s.add_argument("--modulo", action="append", default=[], metavar="AXIS", help="rotary input axis with modulo tables (one turn)")
    s.add_argument("--commands", help="campaign CSV whose commands (and tools) the tables are fitted and judged on")
    s.add_argument("--out", required=True)
    s.add_argument("--quiet", action="store_true")
    s.set_defaults(func=cmd_tables)

    s = sub.add_parser("diagnose", help="where the residual lies, which unmodelled effect causes it, how far it shrinks")
    s.add_argument("machine")
    s.add_argument("csv")
    s.add_argument("--out", required=True)
    s.add_argument("--model", choices=["6dof", "ap"], default="6dof")
    s.add_argument("--order", type=int, default=6)
    s.add_argument("--effects", default="all", help="all, or a comma list of: gantry_skew, coupled_axes, thermal, "
                   "backlash, rotary_periodic, instrument_shift, outliers")
    s.add_argument("--folds", type=int, default=5)
    s.add_argument("--alpha", type=float, default=0.01, help="family-wise false-alarm rate per round")
    _noise_args(s)
    s.set_defaults(func=cmd_diagnose)

    s = sub.add_parser("view", help="meshcat scene of measured vs modelled tool tips (interactive, or --html)")
    s.add_argument("model")
    s.add_argument("csv")
    s.add_argument("--row", type=int, default=0, help="measurement row to pose the machine at (0-based)")
    s.add_argument("--exaggerate", type=float, help="error vector scale (default: largest error = 8%% of the workspace)")
    s.add_argument("--html", help="write a self-contained page instead of starting a server")
    s.add_argument("--no-tables", action="store_true", help="skip the compensated view")
    s.set_defaults(func=cmd_view)

    s = sub.add_parser("report", help="one HTML page: tables, the seed's figures, the 3D scene")
    s.add_argument("model")
    s.add_argument("csv")
    s.add_argument("--out", required=True)
    s.add_argument("--validation", help="validation CSV for the before/after table and the order sweep")
    s.add_argument("--orders", help="also run the order sweep, e.g. 0-7")
    s.add_argument("--controller", default="generic", choices=["siemens-840d", "fanuc-30i", "generic"])
    s.add_argument("--max-tables", type=int)
    s.add_argument("--quiet", action="store_true")
    s.set_defaults(func=cmd_report)

    s = sub.add_parser("demo", help="simulate Paper I's campaign, fit both models, print the before/after table")
    s.add_argument("--out", default="demo")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--order", type=int, default=6)
    s.add_argument("--quiet", action="store_true")
    s.set_defaults(func=cmd_demo)
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except VecpinError as exc:
        print(f"vecpin: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("vecpin: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. piped into `head`
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
