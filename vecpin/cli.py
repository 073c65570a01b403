"""Command line: a thin layer over the Python API.

Every user error (bad file, unknown machine, ...) prints one clear line and exits
with status 2; nothing prints a traceback for bad input.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from .errors import VecpinError


def _machine(name: str):
    from .machine import Machine
    return Machine.load(name)


def cmd_info(args) -> int:
    from .machine import bundled_machines
    m = _machine(args.machine)
    print(m.describe())
    if args.machine not in bundled_machines():
        print(f"  (bundled machines: {', '.join(bundled_machines())})")
    return 0


def _error_summary(label: str, err_mm: np.ndarray) -> str:
    d = np.linalg.norm(err_mm, axis=1)
    return f"  {label:<42s} mean {d.mean():8.4f} mm   max {d.max():8.4f} mm   RMS {np.sqrt((d**2).mean()):8.4f} mm"


def cmd_simulate(args) -> int:
    from .registration import registered_errors
    from .simulate import Design, parse_zone, simulate
    m = _machine(args.machine)
    design = Design(n_commands=args.points, n_validation=args.validation, method=args.method,
                    exclusion_zones=[parse_zone(z) for z in args.exclude],
                    tools_mm=tuple(args.tools) if args.tools else Design().tools_mm)
    sim = simulate(m, seed=args.seed, design=design, mean_error_mm=args.mean_error)
    paths = sim.write(args.out)
    c = sim.campaign
    nominal = m.tool_tip(c.q, c.tool)
    true_tip = sim.truth.tool_tip(c.q, c.tool)
    print(f"simulated {m.name}, seed {args.seed}: {len(c)} rows ({design.n_commands} commands x "
          f"{len(design.tools_mm)} tools {', '.join(f'{t:g}' for t in design.tools_mm)} mm), "
          f"{len(sim.validation)} validation rows")
    print(_error_summary("true vs nominal tip (machine frame)", (true_tip - nominal) * 1e3))
    print(_error_summary("uncompensated (measured, registered)", registered_errors(nominal, c.xyz) * 1e3))
    dist = np.linalg.norm(c.xyz, axis=1)
    print(f"  tracker range {dist.min():.2f} .. {dist.max():.2f} m; campaign takes {c.time[-1] / 3600:.2f} h")
    for k, p in paths.items():
        print(f"  wrote {p}  ({k})")
    return 0


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
    s.set_defaults(func=cmd_simulate)
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


if __name__ == "__main__":
    sys.exit(main())
