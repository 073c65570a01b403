"""Nominal FK + tool-tip Jacobian throughput on every bundled machine (issue 2 target:
10,000 poses < 50 ms for the 5-axis machines), both frames on two-branch machines, both
spindles of Spar Mill 23, table nests, and the 6-DoF error chain.

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
    print(f"{'machine':<18s} {'what':<44s} {'best ms':>8s} {'median ms':>10s} {'µs/pose':>8s}")

    def line(name, label, fn, repeat=7):
        b, med = best_of(fn, repeat)
        print(f"{name:<18s} {label:<44s} {b * 1e3:8.1f} {med * 1e3:10.1f} {b / n * 1e6:8.2f}")

    for name in vecpin.bundled_machines():
        m = vecpin.Machine.load(name)
        q = uniform_commands(m, n, rng)
        tool = rng.uniform(0.1, 0.4, n)
        line(name, f"FK only ({m.default_frame} frame)", lambda: m.kinematics(q, tool, jacobian=False))
        line(name, f"FK + tool-tip Jacobian ({m.default_frame} frame)", lambda: m.kinematics(q, tool))
        if m.has_workpiece:
            line(name, "FK + Jacobian (base frame)", lambda: m.kinematics(q, tool, frame="base"))
            p = rng.uniform(-0.2, 0.2, (n, 3))
            line(name, "table nests + Jacobians", lambda: m.workpiece_points(q, p))
        if len(m.tool_links) > 1:
            point = rng.integers(0, len(m.tool_links), n)
            line(name, "FK + Jacobian, spindle chosen per row", lambda: m.kinematics(q, tool, point=point))
    for name in ("flow_xyzcb", "trunnion_xyzac", "spar_mill_23"):
        m = vecpin.Machine.load(name)
        ef = ErrorFrames(m)
        q = uniform_commands(m, n, rng)
        d = rng.normal(size=(n, ef.n_slots, 3)) * 1e-5
        line(name, f"6-DoF error chain + all Jacobians ({ef.n_slots} slots)", lambda: ef.tool_tip(q, d, d, 0.2), 3)
    print(f"target: nominal FK + Jacobian for {n} poses under 50 ms on the 5-axis machines")


if __name__ == "__main__":
    main()
