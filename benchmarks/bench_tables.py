"""Table generation and selection speed (issue 4 targets), controller files (issue 13).

Choosing 6 of 20 cross tables exactly: the seed estimated 550 h for an exhaustive
search (38,760 combinations at 10 min each) and took 5.2 h with its GA; target here
<= 30 s for the exact search. Also prints the GA's time and result on the same problem,
the cost of the parameter-uncertainty spread of a report row, and the time to write and
read back each controller's files.

Run: python benchmarks/bench_tables.py
"""
import tempfile
import time
from pathlib import Path

import numpy as np

import vecpin
from vecpin.compensation.functions import all_table_names, from_ap_model, pitch_names
from vecpin.compensation.tableproblem import TableProblem
from vecpin.compensation.frame import model_as_actual
from vecpin.models import make_model
from vecpin.measurement.noise import NoiseModel
from vecpin.simulation.simulate import Design, simulate
from vecpin.compensation.plan import parameter_spread
from vecpin.compensation.functions import pseudo_commands
from vecpin.compensation.tables import cross_table_axes
from vecpin.compensation.selection import (BranchAndBound, Constraints, Scorer, admissible_combinations, exact_search,
                                           finalise, genetic_search, impact_heuristic)
from vecpin.export.common import ExportJob
from vecpin.export.profile import ControllerProfile
from vecpin.export.registry import get_format
from vecpin.fileio import OutputSet


def main():
    m = vecpin.Machine.load("flow_xyzcb")
    sim = simulate(m, seed=0, mean_error_mm=0.65)
    noise = NoiseModel.default(m, "spherical")
    model = make_model("6dof", m, 6).fit(sim.campaign, noise)
    ap = make_model("ap", m, 6).fit(sim.campaign, noise)
    t0 = time.perf_counter()
    problem = TableProblem(model_as_actual(model), m, sim.campaign.q[:295], [0.21488, 0.31286], order=6)
    t_setup = time.perf_counter() - t0
    t0 = time.perf_counter()
    full = problem.solve(all_table_names(m)).discretise(1024)
    t_full = time.perf_counter() - t0
    t0 = time.perf_counter()
    from_ap_model(ap).discretise(1024)
    t_ap = time.perf_counter() - t0
    print("Table generation, Paper I machine, 295 commands x 2 tools, order 6:")
    print(f"  linearised problem set-up           {t_setup:7.2f} s")
    print(f"  25 tables from the 6-DoF model      {t_full:7.2f} s  (projection, eq. 18-19, 1024 points)")
    print(f"  25 tables from the AP model         {t_ap:7.3f} s  (eq. 17)")
    print("\nChoosing 6 of 20 cross tables (seed: exhaustive estimate 550 h, GA 5.2 h):")
    print(f"  {'constraints':<16s} {'method':<10s} {'seconds':>8s} {'scored':>8s} {'mean mm':>8s} {'max mm':>8s}  tables")
    for label, cons in [("none", Constraints(6)), ("no circular", Constraints(6, no_circular=True)),
                        ("no X output", Constraints(6, forbid_output=("X",)))]:
        ex = exact_search(problem, cons)
        print(f"  {label:<16s} {'exact':<10s} {ex.seconds:8.2f} {ex.evaluations:8d} {ex.mean_mm:8.4f} {ex.max_mm:8.4f}  {' '.join(ex.tables)}")
        gas = [genetic_search(problem, cons, seed=s) for s in range(5)]
        for g in gas[:1]:
            print(f"  {'':<16s} {'GA (1 run)':<10s} {g.seconds:8.2f} {g.evaluations:8d} {g.mean_mm:8.4f} {g.max_mm:8.4f}  {' '.join(g.tables)}")
        means = [g.mean_mm for g in gas]
        print(f"  {'':<16s} {'GA x5':<10s} {sum(g.seconds for g in gas):8.2f} {'':>8s} {np.mean(means):8.4f} {'':>8s}  "
              f"mean of 5 runs, best {min(means):.4f}, exact optimum found in {sum(abs(x - ex.mean_mm) < 1e-9 for x in means)}/5")
        h = impact_heuristic(problem, cons)
        print(f"  {'':<16s} {'heuristic':<10s} {h.seconds:8.2f} {h.evaluations:8d} {h.mean_mm:8.4f} {h.max_mm:8.4f}  {' '.join(h.tables)}")
    print("  target: exact search <= 30 s")
    six_of_thirty()

    t0 = time.perf_counter()
    spread = parameter_spread(model, full, problem.q, problem.L)
    print(f"\nParameter-uncertainty spread of one report row (200 draws, {len(problem.q)} points, "
          f"{model.n_parameters} parameters): {time.perf_counter() - t0:.2f} s; full tables "
          f"{spread[0]:.4f} mm [{spread[1]:.4f}, {spread[2]:.4f}]")

    chosen = exact_search(problem, Constraints(6)).tables
    sets = {"full": full, "chosen": finalise(problem, chosen)[0], "pitch": problem.solve(pitch_names(m)).discretise(256),
            "full, 256 points": problem.solve(all_table_names(m)).discretise(256)}
    one_per_output = [n for k, n in enumerate(chosen) if n[0] not in {c[0] for c in chosen[:k]}]
    sets["one per output"] = finalise(problem, one_per_output, 1000)[0]
    axes = {a.name: {"nc_name": a.name + "1", "number": k + 1, "reference_position": 0.0, "detection_unit": 0.001}
            for k, a in enumerate(m.axes)}
    prof = ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1, "axes": axes,
                                        "options": {"rotary_any_range": True}})
    print("\nController files (write, then read back with the format's reader):")
    print(f"  {'controller':<14s} {'tables':>6s} {'points':>7s} {'write s':>8s} {'read s':>7s} {'files':>6s} {'kB':>8s}")
    for name, which in (("siemens-840d", "full"), ("fanuc-30i", "chosen"), ("linuxcnc", "pitch"),
                        ("beckhoff", "one per output"), ("heidenhain", "full, 256 points"), ("iso230", "full"),
                        ("generic", "full")):
        fmt = get_format(name)
        tables = sets[which]
        with tempfile.TemporaryDirectory() as d:
            t0 = time.perf_counter()
            with OutputSet(d) as out:
                names = fmt.write(ExportJob(tables, m, prof, fmt.limits_for(prof), out, model, 256))
            t_write = time.perf_counter() - t0
            t0 = time.perf_counter()
            if fmt.read is not None:
                fmt.read(Path(d), m, prof)
            t_read = time.perf_counter() - t0
            size = sum(p.stat().st_size for p in Path(d).iterdir()) / 1024
        points = max(len(t.values) for t in tables.tables)
        print(f"  {name:<14s} {len(tables.tables):6d} {points:7d} {t_write:8.3f} "
              f"{t_read if fmt.read else float('nan'):7.3f} {len(names):6d} {size:8.0f}")


def six_of_thirty():
    """Fanuc's 6 of production_xyzbaw's 30 cross tables: the branch and bound against
    scoring every one of the 593,775 combinations (the exact search's ten best by the
    linearised score, before they are re-solved on the model)."""
    m = vecpin.Machine.load("production_xyzbaw")
    sim = simulate(m, seed=2, design=Design(n_commands=200, n_validation=5))
    model = make_model("6dof", m, 4).fit(sim.campaign, NoiseModel.default(m, "spherical"))
    problem = TableProblem(model_as_actual(model), m, pseudo_commands(m, 1000), sim.campaign.tool_lengths(),
                           order=8, basis="fourier")
    cons = Constraints(6)
    cand = cons.candidates(m.axis_names)
    t0 = time.perf_counter()
    search = BranchAndBound(Scorer(problem), cand, cons, 6, 10)
    bb, bb_scores = search.run()
    t_bb = time.perf_counter() - t0
    t0 = time.perf_counter()
    scorer = Scorer(problem)
    every = admissible_combinations(cand, cons, 6, cross_table_axes(m.axis_names))
    scores = scorer.score_many(every, cand)
    best = np.argsort(scores, kind="stable")[:10]
    t_all = time.perf_counter() - t0
    same = np.array_equal(every[best], bb) and np.array_equal(scores[best], bb_scores)
    print(f"\nChoosing 6 of 30 cross tables (production_xyzbaw, {len(problem.q)} points), the ten best by the score:")
    print(f"  branch and bound      {t_bb:8.2f} s  {search.scored:8d} combinations scored, {search.nodes} partial sets")
    print(f"  every combination     {t_all:8.2f} s  {len(every):8d} combinations scored")
    print(f"  the same ten, the same scores: {'yes' if same else 'NO'}; best {' '.join(cand[i] for i in bb[0])} "
          f"{bb_scores[0] * 1e3:.4f} mm")


if __name__ == "__main__":
    main()
