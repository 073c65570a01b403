"""Machine kinds through the whole pipeline: every new bundled machine simulated (table
nests on table machines, both spindles on Spar Mill 23), fitted by the default model
choice and compensated; the figures are the noise-free validation (relative to the
workpiece on table machines) against a fit with the true error family's bases, the
true compensated error of vecpin's tables against the table floor, and times. Then
table nests and unknown tool targets recovered against their truth.

Run: python benchmarks/bench_kinds.py [--seeds N] [--more-rows N]
"""
import argparse
import time
from itertools import combinations

import numpy as np

import vecpin
from vecpin.compensation.plan import plan_tables
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.floor import table_floor, true_compensated_error
from vecpin.simulation.judge import uncompensated_error, validation_commands, validation_error
from vecpin.simulation.simulate import Design, simulate
from vecpin.simulation.truth import TrueMachine
from vecpin.workflows.fitting import fit_campaign

MACHINES = ["master_mill", "spar_mill_23", "production_xyzbaw", "trunnion_xyzac", "trunnion_xyzbc", "head_table_bc"]
# tracker stations of the campaign as the seed recommends it: on the long XYZBAW gantry the
# single tracker's range noise limited the model and its check, "future implementations on this
# machine should consider two laser tracker locations" (seed Section 2.6)
SEED_STATIONS = {"production_xyzbaw": 2}


def pipeline(name: str, seed: int, rows_factor: int = 1, stations: int = 1) -> tuple[str, float]:
    """(printed line, tables / floor) of one machine and seed; ``rows_factor`` times the
    default design's commands, each read from ``stations`` tracker stations."""
    m = vecpin.Machine.load(name)
    t0 = time.perf_counter()
    sim = simulate(m, seed=seed, design=Design(n_commands=Design().n_commands * rows_factor, n_validation=5,
                                               stations=stations))
    noise = NoiseModel.default(m, "spherical", tracker=sim.truth.tracker.noise)
    model = fit_campaign(m, sim.campaign, noise).model
    t_fit = time.perf_counter() - t0
    q, tool = validation_commands(m, 300, seed=7)
    val = validation_error(model, sim.truth, q, tool)[0]
    oracle = make_model("6dof", m, 4, bases=sim.truth.family_bases()).fit(sim.campaign, noise)
    val_o = validation_error(oracle, sim.truth, q, tool)[0]
    t1 = time.perf_counter()
    tables = plan_tables(model, uncertainty=False).tables
    t_tab = time.perf_counter() - t1
    vec = true_compensated_error(sim.truth, tables, q, tool, "reference")[0]
    # the oracle's tables: what identification with the true error family would give (the noise's share of the gap)
    vec_o = true_compensated_error(sim.truth, plan_tables(oracle, uncertainty=False).tables, q, tool, "reference")[0]
    floor = table_floor(sim.truth, q, tool, judged="reference").mean_mm
    unc = uncompensated_error(sim.truth, q, tool)
    tag = name if stations == 1 else f"{name} ({stations} st.)"
    return (f"  {tag:<26s} {seed:4d} {len(sim.campaign):5d} {model.label():<42s} {unc:7.4f} {val:7.4f} {val_o:7.4f} "
            f"{val / val_o:6.2f} {vec:7.4f} {floor:7.4f} {vec / floor:6.2f} {vec_o / floor:6.2f} {t_fit:6.1f} "
            f"{t_tab:6.1f}"), vec / floor


def nests(seed: int) -> str:
    m = vecpin.Machine.load("trunnion_xyzac")
    sim = simulate(m, seed=seed, design=Design(n_commands=150, nests=4, n_validation=5))
    model = make_model("6dof", m, 4, bases=sim.truth.family_bases()).fit(sim.campaign, NoiseModel.default(m, "spherical"))
    err = [abs(np.linalg.norm(model.setup_.nests[a] - model.setup_.nests[b]) - np.linalg.norm(sim.nests[a] - sim.nests[b]))
           for a, b in combinations(sim.nests, 2)]
    sd = np.mean([v for k, v in model.setup_.std.items() if k.startswith("nest")])
    return (f"  trunnion_xyzac, 4 nests, seed {seed}: distances between the fitted nests off the true ones by "
            f"{np.mean(err) * 1e3:.4f} mm mean, {np.max(err) * 1e3:.4f} mm max (coordinate sd {sd * 1e3:.4f} mm)")


def targets(seed: int) -> str:
    m = vecpin.Machine.load("ur5")
    truth = TrueMachine.random(m, np.random.default_rng(seed))
    for k in (4, 5):  # constant errors after the last wrist joints go to the targets: none in this truth
        for f in truth.errors[k]:
            if f.chebyshev:
                f.chebyshev[0] = 0.0
    design = Design(n_commands=150, targets_mm=((0, 0, 120.0), (180.0, 40.0, 60.0), (-90.0, 170.0, 30.0)),
                    n_validation=5)
    sim = simulate(m, seed=seed, design=design, truth=truth)
    t0 = time.perf_counter()
    model = make_model("6dof", m, 4, bases=truth.family_bases()).fit(sim.campaign, NoiseModel.default(m, "spherical"))
    z = []
    for tid, off in sim.targets.items():
        sd = np.array([model.setup_.std[f"target{tid}.{c}"] for c in "xyz"])
        z += list((model.setup_.targets[tid] - off - truth.gauge_error * m.tool_axis) / sd)
    z = np.abs(z)
    return (f"  ur5, 3 unknown targets, seed {seed}: |error| / sd mean {z.mean():.2f}, max {z.max():.2f} (9 coordinates); "
            f"fit {time.perf_counter() - t0:.1f} s")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--more-rows", type=int, default=4, metavar="N",
                    help="refit the machines whose tables miss 1.15x the floor with N times the commands (0: skip)")
    args = ap.parse_args()
    print("default fit and tables on every new bundled machine (mm; ratios: to the true family's fit, to the floor; "
          "'orcl' = the oracle fit's tables to the floor, the share of the gap that noise leaves with perfect bases)")
    print(f"  {'machine':<26s} {'seed':>4s} {'rows':>5s} {'chosen model':<42s} {'uncomp':>7s} {'valid':>7s} "
          f"{'oracle':>7s} {'ratio':>6s} {'tables':>7s} {'floor':>7s} {'ratio':>6s} {'orcl':>6s} {'fit s':>6s} {'tab s':>6s}")
    missed = []
    for name in MACHINES:
        for seed in range(1, args.seeds + 1):
            line, ratio = pipeline(name, seed)
            print(line, flush=True)
            if ratio > 1.15:
                missed.append((name, seed))
    print("measured as the seed recommends (Section 2.6: two tracker locations on the long gantry)")
    for name, stations in SEED_STATIONS.items():
        for seed in range(1, args.seeds + 1):
            print(pipeline(name, seed, stations=stations)[0], flush=True)
    if missed and args.more_rows:
        print(f"tables above 1.15x the floor, measured again with {args.more_rows}x the commands (the same machine and "
              "seed): a gap that closes is the identification noise's")
        for name, seed in missed:
            print(pipeline(name, seed, args.more_rows)[0], flush=True)
    print("table nests and tool targets")
    for seed in range(1, args.seeds + 1):
        print(nests(seed))
        print(targets(seed + 2))


if __name__ == "__main__":
    main()
