"""Speed of the whole-day steps: line of sight, D-optimal choice, ordering, NC programs,
import. Prints figures; asserts nothing.

Paper I's campaign size: 295 commands x 2 holders from ~3000 candidates, 6-DoF order 6
(217 parameters with E_0).

Run: python benchmarks/bench_planning.py
"""
import tempfile
import time
from pathlib import Path

import numpy as np

import vecpin
from vecpin.measurement.importer import import_export
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.planning import route
from vecpin.planning.doptimal import greedy_d_optimal
from vecpin.planning.information import Information
from vecpin.planning.ncprogram import write_program
from vecpin.planning.plan import PlanSettings, make_plan
from vecpin.planning.sightline import SightLine, default_tracker_position
from vecpin.simulation.simulate import simulate
from vecpin.units import to_mm


def timed(label, fn, *a, **k):
    t0 = time.perf_counter()
    out = fn(*a, **k)
    dt = time.perf_counter() - t0
    print(f"  {label:<58s} {dt:8.3f} s")
    return out, dt


def main():
    m = vecpin.Machine.load("flow_xyzcb")
    rng = np.random.default_rng(0)
    q = m.lower + rng.random((3000, 5)) * (m.upper - m.lower)
    sl = SightLine(m, default_tracker_position(m))
    print(f"flow_xyzcb: {len(sl.solids)} solids of the visual geometry")
    res, dt = timed("line of sight, 3000 commands", sl.check, q, 0.21488)
    print(f"    {3000 / dt:,.0f} commands/s, {res.blocked.mean():.0%} blocked")
    model = make_model("6dof", m, 6)
    info, _ = timed("6-DoF order 6: structural redundancy (1000 x 2 rows)", Information, model,
                    NoiseModel.default(m, "spherical"), sl.tracker, [0.21488, 0.31286])
    W, _ = timed("whitened Jacobian of 2000 candidates x 2 holders", info.rows, q[:2000])
    (pick, _), dt = timed("greedy D-optimal, 295 of 2000 (217 parameters)", greedy_d_optimal, W, 295, info.keep)
    print(f"    {dt / 295 * 1e3:.1f} ms per pick")
    speed = route.axis_speeds(m)
    order, _ = timed("tour through 295 commands (nearest neighbour + 2-opt)", route.order_points, q[pick], speed)
    print(f"    moves {route.travel_time(q[pick][order], speed) / 60:.1f} min vs {route.travel_time(q[pick], speed) / 60:.1f} "
          "min in the picked order")
    plan, _ = timed("make_plan: 295 commands, AP order 6, sight, repeats 9 x 4", make_plan, m,
                    PlanSettings(n_commands=295, order=6, repeat_points=9, repeat_times=4))
    timed("Siemens program for 626 rows", write_program, "siemens-840d", m, plan.template, plan.steps)
    sim = simulate(m, 1, plan=(plan.template.q, plan.template.tool))
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        (d / "plan.csv").write_text(plan.template.to_csv(m))
        xyz = sim.campaign.xyz * 1000 / 25.4
        rows = ["Name;Meas X;Meas Y;Meas Z"] + [f"P{p:04d};" + ";".join(f"{v:.6f}".replace(".", ",") for v in r)
                                                 for p, r in zip(plan.template.point, xyz)]
        (d / "e.csv").write_text("\n".join(rows) + "\n")
        res, dt = timed(f"import {len(rows) - 1} rows (semicolon, decimal comma, inches)", import_export,
                        d / "e.csv", m, d / "plan.csv")
        print(f"    {len(rows) / dt:,.0f} rows/s, units {res.units}")
    table_machines()


def table_machines():
    """Machines with table axes: what the table nests add (table-axis terms identified,
    predicted error of the tool tip relative to the workpiece), and what reading the
    nests at only every 2nd or 4th command would give instead of at every command."""
    from vecpin.planning.plan import score_rows
    print("table machines: 100 commands x 2 holders, AP order 6, 3 table nests (predicted, tool tip relative to the "
          "workpiece)")
    for name in ("trunnion_xyzac", "trunnion_xyzbc", "head_table_bc"):
        m = vecpin.Machine.load(name)
        plan, dt = timed(f"{name}: plan with nests", make_plan, m, PlanSettings(n_commands=100, order=6))
        info, bare = plan.information, plan.bare
        before = int((~bare.keep[bare.model_columns]).sum())
        print(f"    table-axis terms identified {int(info.table_terms().sum())} (before: {before} left out); "
              f"{len(plan.template.nest_rows)} nest rows")
        t = plan.template
        tool_rows = t.tool_rows
        owner = np.maximum.accumulate(np.where(t.instrument != "nest", np.arange(len(t)), 0))
        cmd = np.unique(owner[t.nest_rows], return_inverse=True)[1]   # which command each nest row follows
        for every in (1, 2, 4):
            rows = np.sort(np.r_[tool_rows, t.nest_rows[cmd % every == 0]])
            sc, _ = score_rows(info, t.take(rows), plan.validation, float(plan.tools[0]), f"nests every {every}")
            print(f"    nests read at every {every} command(s): {int((cmd % every == 0).sum()):4d} nest rows, "
                  f"model error mean {to_mm(sc.predicted.model_mean):.4f} mm, max {to_mm(sc.predicted.model_max):.4f} mm")
        w = plan.without_nests.predicted
        print(f"    without nests: mean {to_mm(w.model_mean):.4f} mm, max {to_mm(w.model_max):.4f} mm")


if __name__ == "__main__":
    main()
