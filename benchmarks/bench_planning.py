"""Speed of the whole-day steps: line of sight, D-optimal choice, ordering, NC programs,
import. Prints figures; asserts nothing.

Paper I's campaign size: 295 commands x 2 holders from ~3000 candidates, 6-DoF order 6
(217 parameters with E_0).

Large plans (issue 27: 10,000 points within a minute and 1 GB): every bundled machine
with table axes and one head machine planned at 10,000 points by the command line, whole
process (wall and CPU seconds, peak RSS, the load average beside them: the development
machine is shared); and the D-optimal choice of the trunnion's 10,000 points by the
previous implementation (Woodbury-updated inverse in float64, kept here as the reference)
and by the current one: CPU seconds, the D-criterion (log det N of the whole plan) and the
predicted validation residual of each.

Run: python benchmarks/bench_planning.py [large]   (large: only the large plans)
"""
import heapq
import os
import subprocess
import sys
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
from vecpin.planning.problem import TABLE_MINUTE_POINTS
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


LARGE = ("trunnion_xyzac", "trunnion_xyzbc", "head_table_bc", "xyzac_trt", "flow_xyzcb")


CHILD = """import sys
from vecpin.cli.main import main
try:
    main(sys.argv[1:])
finally:  # this process' own peak (ru_maxrss of a child also counts the parent it was forked from)
    print(next(line for line in open("/proc/self/status") if line.startswith("VmHWM")), file=sys.stderr)
"""


def whole_plan(name, points=10_000):
    """(wall s, CPU s, peak RSS GB) of `vecpin plan NAME --points POINTS` as a process."""
    with tempfile.TemporaryDirectory() as d:
        cmd = [sys.executable, "-c", CHILD, "plan", name, "--points", str(points), "--out", str(Path(d) / "p"), "--quiet"]
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        err = proc.stderr.read()
        _, status, ru = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
        if os.waitstatus_to_exitcode(status):
            raise RuntimeError(f"{' '.join(cmd[3:])} failed: {err[-500:]}")
    peak_kb = float(err.split("VmHWM:")[1].split()[0])
    return wall, ru.ru_utime + ru.ru_stime, peak_kb / 1e6


def large_plans():
    print("Large plans, whole `vecpin plan MACHINE --points N` process (CPU: user + system, what the "
          "wall time is on an idle machine; load: 1-min load average of the 2-core machine before each run)")
    print(f"  {'machine':<18s} {'points':>7s} {'wall s':>8s} {'CPU s':>8s} {'peak GB':>8s} {'load':>5s}")
    runs = [(name, 10_000) for name in LARGE] + [("head_table_bc", TABLE_MINUTE_POINTS)]  # the slowest at its limit
    for name, points in runs:
        load = os.getloadavg()[0]
        wall, cpu, rss = whole_plan(name, points)
        print(f"  {name:<18s} {points:7d} {wall:8.1f} {cpu:8.1f} {rss:8.2f} {load:5.1f}", flush=True)


def reference_greedy(W, n, refresh=50, batch=16):
    """The D-optimal choice before this change (the reference): lazy greedy with gains
    log det(I + W_c N^-1 W_c^T) from a Woodbury-updated N^-1 in float64, every row dense."""
    C, r, p = W.shape
    N, Ninv, eye = np.eye(p), np.eye(p), np.eye(r)

    def gains(rows):
        B = np.asarray(W[rows], float)
        BN = (B.reshape(-1, p) @ Ninv).reshape(B.shape)
        return np.linalg.slogdet(eye + BN @ np.swapaxes(B, 1, 2))[1]
    heap = [(-g, c, 0) for a in range(0, C, 4096) for c, g in zip(range(a, min(a + 4096, C)), gains(np.arange(a, min(a + 4096, C))))]
    heapq.heapify(heap)
    chosen = []
    for step in range(n):
        if step and step % refresh == 0:
            Ninv = np.linalg.inv(N)
        while heap[0][2] != step:
            stale = [heapq.heappop(heap)[1] for _ in range(min(batch, len(heap))) if heap[0][2] != step]
            for g, c in zip(gains(np.array(stale)), stale):
                heapq.heappush(heap, (-g, c, step))
        s = heapq.heappop(heap)[1]
        chosen.append(s)
        Ws = np.asarray(W[s], float)
        V = Ninv @ Ws.T
        Ninv = Ninv - V @ np.linalg.inv(eye + Ws @ V) @ V.T
        N = N + Ws.T @ Ws
    return np.array(chosen)


def dense32(rows):
    """The candidates' rows as one dense float32 array (C, r, P), as the plan stored them before."""
    return np.concatenate([rows.dense(np.arange(a, min(a + 2000, rows.shape[0]))).astype(np.float32)
                           for a in range(0, rows.shape[0], 2000)])


def choice_before_after(name="trunnion_xyzac", points=10_000):
    """The same candidates chosen by the reference and the current D-optimal choice: CPU
    seconds, the whole plan's D-criterion and predicted validation residual."""
    from vecpin.planning.candidates import screen_candidates
    from vecpin.planning.information import validation_commands
    from vecpin.planning.plan import measurement_order, score_rows
    from vecpin.planning.problem import plan_problem, planned_model
    from vecpin.threads import blas_limited
    m = vecpin.Machine.load(name)
    with blas_limited():
        problem = plan_problem(m, PlanSettings(n_commands=points, model="auto", order=6))
        cands = screen_candidates(problem, lambda s: None)
        info = Information(planned_model(m, problem.settings), problem.noise, problem.tracker, problem.tools,
                           nests=problem.nests)
        ok = cands.kept
        rows = info.kept_rows(cands.q[ok], cands.seen[ok])
        vq = validation_commands(m, 500, problem.lo, problem.hi, seed=problem.settings.seed + 7)
        print(f"{name}: {points} of {len(ok)} candidates, {rows.shape[1]} rows x {rows.shape[2]} counted terms each; "
              f"candidate rows {rows.nbytes / 1e6:.0f} MB (dense float32: {np.prod(rows.shape) * 4 / 1e6:.0f} MB)")
        picks = {}
        for label, choose in (("before (reference)", lambda: reference_greedy(dense32(rows), points)),
                              ("after", lambda: greedy_d_optimal(rows, points)[0])):
            c0 = time.process_time()
            picks[label] = pick = choose()
            cpu = time.process_time() - c0
            _, template = measurement_order(problem, cands.q[ok[pick]], cands.seen[ok[pick]])
            sc, _ = score_rows(info, template, vq, float(problem.tools[0]), label)
            print(f"  {label:<20s} D-optimal choice {cpu:6.1f} CPU s; log det N {sc.log_det:.4f}; predicted validation "
                  f"residual mean {to_mm(sc.predicted.measured_mean):.5f} mm (model {to_mm(sc.predicted.model_mean):.5f} mm)")
        a, b = picks.values()
        first = np.flatnonzero(a != b)
        print(f"  picks: {'identical' if not len(first) else f'first different at pick {first[0] + 1}'}; "
              f"the same commands chosen: {set(a.tolist()) == set(b.tolist())}")


if __name__ == "__main__":
    if sys.argv[1:] != ["large"]:
        main()
    large_plans()
    choice_before_after()
