"""Identification speed and memory (issue 3 targets).

Paper I, 295 commands x 2 tools on the laboratory XYZCB machine, order 6: the seed
reports 27 min (AP) and 144 min (6-DoF); target <= 0.5 s each here. 10,000
measurements: target <= 10 s, memory growing linearly.

Run: python benchmarks/bench_fit.py
"""
import time
import tracemalloc

import numpy as np

import vecpin
from vecpin.models import make_model
from vecpin.measurement.noise import NoiseModel
from vecpin.simulation.simulate import Design, simulate


def timed_fit(kind, machine, campaign, instrument, repeat=3):
    times, rep = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        model = make_model(kind, machine, 6).fit(campaign, NoiseModel.default(machine, instrument))
        times.append(time.perf_counter() - t0)
        rep = model.report_
    return min(times), float(np.median(times)), rep


def main():
    m = vecpin.Machine.load("flow_xyzcb")
    sim = simulate(m, seed=0, mean_error_mm=0.65)
    print("Paper I campaign: 295 commands x 2 tools = 590 rows, order 6 (seed: AP 27 min, 6-DoF 144 min)")
    print(f"  {'model':<6s} {'noise':<10s} {'params':>6s} {'iters':>5s} {'best s':>7s} {'median s':>8s} {'ident mean mm':>13s}")
    for kind in ("ap", "6dof"):
        for inst in ("cartesian", "spherical"):
            best, med, rep = timed_fit(kind, m, sim.campaign, inst)
            print(f"  {kind:<6s} {inst:<10s} {rep.n_parameters:6d} {rep.iterations:5d} {best:7.3f} {med:8.3f} "
                  f"{rep.residuals_mm['all']['mean']:13.4f}")
    print("  target: <= 0.5 s each")
    print("\nScaling with the number of measurements (order 6, spherical noise), peak traced memory:")
    print(f"  {'model':<6s} {'rows':>6s} {'seconds':>8s} {'peak MB':>8s} {'MB per 1000 rows':>17s}")
    for kind in ("ap", "6dof"):
        for n_cmd in (1250, 2500, 5000):
            c = simulate(m, seed=1, design=Design(n_commands=n_cmd, n_validation=2)).campaign
            tracemalloc.start()
            t0 = time.perf_counter()
            make_model(kind, m, 6).fit(c, NoiseModel.default(m, "spherical"))
            secs = time.perf_counter() - t0
            peak = tracemalloc.get_traced_memory()[1] / 1e6
            tracemalloc.stop()
            print(f"  {kind:<6s} {len(c):6d} {secs:8.2f} {peak:8.1f} {peak / len(c) * 1000:17.1f}")
    print("  target: 10,000 rows <= 10 s; memory linear in rows")


if __name__ == "__main__":
    main()
