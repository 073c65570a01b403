"""Table generation and selection speed (issue 4 targets).

Choosing 6 of 20 cross tables exactly: the seed estimated 550 h for an exhaustive
search (38,760 combinations at 10 min each) and took 5.2 h with its GA; target here
<= 30 s for the exact search. Also prints the GA's time and result on the same problem.

Run: python benchmarks/bench_tables.py
"""
import time

import numpy as np

import vecpin
from vecpin.compensation.functions import TableProblem, all_table_names, from_ap_model, model_as_actual, pitch_names
from vecpin.models import make_model
from vecpin.measurement.noise import NoiseModel
from vecpin.simulation.simulate import simulate
from vecpin.compensation.selection import Constraints, exact_search, genetic_search, impact_heuristic


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


if __name__ == "__main__":
    main()
