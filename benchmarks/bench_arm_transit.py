"""Every move of an arm's program free of the arm (issue 41): UR5 plans routed and judged.

Per plan (the docs' 30-point plan of docs/whole-day-machines.md and 20- and 60-point
plans at several seeds, 6-DoF order 2, the plan's two holders, 10 mm holder radius):
the joint moves between points of the plan program and its validation run, how many of
them meet the arm when made directly (vecpin's check), how many the router sends through
one via pose or through a roadmap route (2 or more vias), how many it leaves to be
jogged by hand, its CPU time; then the program's every joint move (approach, measure,
retract, via) posed every 5 deg by tests/collision_judge.py (Pinocchio and Coal on the
URDF, no vecpin code; the holder a capsule of 10 mm radius), with and without the vias.

Run: python benchmarks/bench_arm_transit.py [--out docs/results/arm_transit.md]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from collision_judge import judge  # noqa: E402

from vecpin.kinematics.machine import Machine  # noqa: E402
from vecpin.planning.armpose import arm_clearance  # noqa: E402
from vecpin.planning.armprogram import arm_poses  # noqa: E402
from vecpin.planning.armtransit import blocked_moves, free_transits  # noqa: E402
from vecpin.planning.plan import PlanSettings, make_plan  # noqa: E402
from vecpin.planning.sightline import SightLine  # noqa: E402

RADIUS_MM = 10.0
CASES = [("docs (30 points, repeat 4 x 3)", dict(n_commands=30, candidates=300, repeat_points=4, repeat_times=3,
                                                  n_validation=12, seed=0))]
CASES += [(f"{n} points, seed {s}", dict(n_commands=n, seed=s)) for n in (20, 60) for s in (1, 2, 3)]


def judged(j, names: list[str], poses: list, template) -> int:
    """Joint moves of ``poses`` (every move of the program) whose path, posed every 5 deg,
    puts the holder into the arm by the independent judge."""
    hits = 0
    for p, r in zip(poses[:-1], poses[1:]):
        a, b = np.degrees(p.q), np.degrees(r.q)
        n = int(np.ceil(max(np.abs(b - a).max() / 5.0, 1)))
        path = a + np.linspace(0, 1, n + 1)[:, None] * (b - a)
        hits += bool(j.colliding([dict(zip(names, x)) for x in path], float(template.tool[r.row])))
    return hits


def one_run(m, template, clearance: float, sight, j, names) -> dict:
    poses = arm_poses(m, template, clearance, (4.0, 15.0, 2.0))
    moves = [i for i, p in enumerate(poses) if i > 0 and p.kind == "approach"]
    hit = blocked_moves(sight, np.array([poses[i - 1].q for i in moves]), np.array([poses[i].q for i in moves]),
                        np.array([template.tool[poses[i].row] for i in moves]))
    t0 = time.process_time()
    routed, left = free_transits(m, template, poses, sight)
    cpu = time.process_time() - t0
    vias, run = [], 0
    for p in routed:
        if p.kind == "via":
            run += 1
        elif p.kind == "approach":
            if run:
                vias.append(run)
            run = 0
    return dict(moves=len(moves), blocked=int(np.sum(hit != "")), one=sum(v == 1 for v in vias),
                roadmap=sum(v > 1 for v in vias), left=len(left), cpu=cpu,
                judged_direct=judged(j, names, poses, template), judged=judged(j, names, routed, template),
                all_moves=len(routed) - 1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    m = Machine.load("ur5")
    j = judge("ur5", RADIUS_MM / 1000)
    names = [j.model.names[k] for k in range(1, j.model.njoints)]
    rows = []
    for name, kw in CASES:
        s = PlanSettings(model="6dof", order=2, tool_radius_mm=RADIUS_MM, **kw)
        plan = make_plan(m, s)
        sight = SightLine(m, plan.tracker, tool_radius=RADIUS_MM / 1000)
        for run, t in (("plan", plan.template), ("validation", plan.validation_template)):
            r = one_run(m, t, arm_clearance(s), sight, j, names)
            rows.append((name, run, r))
            print(f"{name:32s} {run:10s} moves {r['moves']:3d} blocked {r['blocked']:3d} one via {r['one']:3d} "
                  f"roadmap {r['roadmap']:2d} left {r['left']} route {r['cpu']:.2f} s CPU; judge: "
                  f"{r['judged_direct']} of the direct program's moves meet the arm, {r['judged']} of the "
                  f"{r['all_moves']} routed", flush=True)
    if args.out:
        write_page(args.out, rows)


def write_page(path: Path, rows: list) -> None:
    lines = ["# Every move of an arm's program free of the arm", "",
             "Written by `python benchmarks/bench_arm_transit.py --out docs/results/arm_transit.md`. The bundled UR5, "
             "6-DoF model of order 2, the plan's two holders (214.88 and 312.86 mm), approach 5 mm back along the tool "
             f"axis, holder radius {RADIUS_MM:g} mm. *Moves*: the joint moves between points (retract to the next "
             "approach); *blocked*: those that meet the arm made directly (vecpin's check, every 2 deg and the area "
             "between); *one via* / *roadmap*: routed through one via pose / a roadmap route of 2 or more; *left*: no "
             "route found (jog by hand); *route CPU*: the router's time. *Judge*: every joint move of the program "
             "(approach, measure, retract, via) posed every 5 deg by `tests/collision_judge.py` (Pinocchio and Coal on "
             "the URDF, no vecpin code, the holder a capsule of the same radius): moves that meet the arm without the "
             "vias, and with them.", "",
             "| plan | run | moves | blocked | one via | roadmap | left | route CPU [s] | judge: direct "
             "| judge: routed |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for name, run, r in rows:
        lines.append(f"| {name} | {run} | {r['moves']} | {r['blocked']} | {r['one']} | {r['roadmap']} | {r['left']} | "
                     f"{r['cpu']:.2f} | {r['judged_direct']} | {r['judged']} of {r['all_moves']} |")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
