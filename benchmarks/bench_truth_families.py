"""Fits judged on the independent truth family (issue 11).

Per machine layout and error family: vecpin's default fit (AP, auto basis, order 6),
the grid of fixed choices (6-DoF / AP x Chebyshev / auto x orders 2..8) and the
oracle (a 6-DoF fit with the true family's bases), each by its noise-free validation
error on 1000 fresh rows (500 commands x the two Paper I tools), mean and max, mm.
The campaign is Paper I's design (295 commands x 2 tools), spherical tracker noise.

Run: python benchmarks/bench_truth_families.py [--layouts a,b] [--families a,b] [--grid]
"""
import argparse
import time

import numpy as np

from vecpin.simulation.independent import FAMILIES, LAYOUTS, IndependentMachine, layout
from vecpin.simulation.judge import judge

DEFAULT_LAYOUTS = ("portal_xyzcb", "portal_xyzcb_c720", "head_xyzab", "head_xyzab_b540", "gantry_xyzca")


def best_per_choice(j):
    """For each (kind, basis): the best order and its mean [mm]."""
    out = {}
    for r in j.grid:
        key = f"{r.kind} {r.basis}"
        if np.isfinite(r.mean_mm) and (key not in out or r.mean_mm < out[key].mean_mm):
            out[key] = r
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--layouts", default=",".join(DEFAULT_LAYOUTS), help=f"comma list of {', '.join(LAYOUTS)}")
    p.add_argument("--families", default=",".join(FAMILIES), help=f"comma list of {', '.join(FAMILIES)}")
    p.add_argument("--seed", type=int, default=1, help="truth seed (the campaign uses seed + 1)")
    p.add_argument("--mean-error-mm", type=float, default=0.5, help="mean volumetric error of the truth, mm")
    p.add_argument("--grid", action="store_true", help="print every row of the grid")
    args = p.parse_args()
    summary = []
    t_all = time.perf_counter()
    for name in args.layouts.split(","):
        m = layout(name)
        travel = ", ".join(f"{a.name} {a.lower_user:g}..{a.upper_user:g} deg" for a in m.axes if a.kind == "rotary")
        print(f"\n=== {name} ({m.name}: {travel})")
        for fam in args.families.split(","):
            t0 = time.perf_counter()
            truth = IndependentMachine.random(m, fam, seed=args.seed, mean_error_mm=args.mean_error_mm)
            j = judge(m, truth, seed=args.seed + 1)
            if args.grid:
                print(j.format())
            else:
                print(f"{name} / {fam}: uncompensated {j.uncompensated_mean_mm:.4f} mm")
                for key, r in best_per_choice(j).items():
                    print(f"    best {key:<15s} order {r.order}: {r.mean_mm:8.4f} mm mean {r.max_mm:8.4f} max")
                for tag, r in (("default", j.default), ("best fixed", j.best_fixed), ("oracle", j.oracle)):
                    print(f"  {tag:<10s} {r.label:<34s} {r.n_parameters:4d} params {r.mean_mm:8.4f} mm mean "
                          f"{r.max_mm:8.4f} max {r.note}")
            print(f"  ({time.perf_counter() - t0:.0f} s)")
            summary.append((name, fam, j))
    print("\nSummary: noise-free validation mean, mm (ratios of means)")
    print(f"  {'layout':<18s} {'family':<15s} {'default':>8s} {'6dof ch6':>8s} {'best fixed':>24s} {'oracle':>8s} "
          f"{'def/best':>8s} {'def/orc':>8s} {'best/orc':>8s}")
    for name, fam, j in summary:
        d, b, o = j.default.mean_mm, j.best_fixed, j.oracle.mean_mm
        c6 = j.find("6dof", "chebyshev", 6).mean_mm
        tag = "*" if "separable" in j.oracle.label else " "
        print(f"  {name:<18s} {fam:<15s} {d:8.4f} {c6:8.4f} {b.label:>15s} {b.mean_mm:8.4f} {o:8.4f}{tag}"
              f"{d / b.mean_mm:8.2f} {d / o:8.2f} {b.mean_mm / o:8.2f}")
    print("  * mixed: no per-axis oracle; the floor of the same machine without the terms that mix axes")
    print(f"total {time.perf_counter() - t_all:.0f} s")


if __name__ == "__main__":
    main()
