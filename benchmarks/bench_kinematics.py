"""Nominal FK + tool-tip Jacobian throughput (issue 2 target: 10,000 poses < 50 ms).

Run: python benchmarks/bench_kinematics.py
"""
import time

import numpy as np

import vecpin
from vecpin.kinematics.errorframes import ErrorFrames
from vecpin.simulation.truth import uniform_commands


def best_of(fn, repeat=7):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times), float(np.median(times))


def main():
    n = 10_000
    rng = np.random.default_rng(0)
    print(f"{'machine':<18s} {'what':<34s} {'best ms':>8s} {'median ms':>10s} {'µs/pose':>8s}")
    for name in vecpin.bundled_machines():
        m = vecpin.Machine.load(name)
        q = uniform_commands(m, n, rng)
        tool = rng.uniform(0.1, 0.4, n)
        for label, fn in [("FK only (tip + orientation)", lambda: m.kinematics(q, tool, jacobian=False)),
                          ("FK + tool-tip Jacobian", lambda: m.kinematics(q, tool))]:
            b, med = best_of(fn)
            print(f"{name:<18s} {label:<34s} {b * 1e3:8.1f} {med * 1e3:10.1f} {b / n * 1e6:8.2f}")
    m = vecpin.Machine.load("flow_xyzcb")
    ef = ErrorFrames(m)
    q = uniform_commands(m, n, rng)
    d = rng.normal(size=(n, 5, 3)) * 1e-5
    b, med = best_of(lambda: ef.tool_tip(q, d, d, 0.2), repeat=3)
    print(f"{'flow_xyzcb':<18s} {'6-DoF error chain + all Jacobians':<34s} {b * 1e3:8.1f} {med * 1e3:10.1f} {b / n * 1e6:8.2f}")
    print(f"target: nominal FK + Jacobian for {n} poses under 50 ms")


if __name__ == "__main__":
    main()
