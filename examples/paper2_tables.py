"""Reproduce the shapes of Paper II Tables 2-5 and 7 (choosing 6 of 20 compensation
tables) on a simulated laboratory XYZCB machine, beside the seed's numbers.

The seed's figures are a real machine's; ours are a simulated machine with known
errors, so the *shapes* compare (full < best subset < heuristic << pitch only; the
no-X-output constraint costs more than no-circular), not the digits. Errors are
model-predicted over the identification commands x 2 tools, as in Paper II; the
last column applies the same tables to the simulated true machine.

At the end the exact choice is written as Fanuc 30i files (5 pitch tables as a
parameter tape, the 6 straightness tables as values for entry by hand), and every pitch
value is checked against the controller's range. The controller profile used for that
is illustrative (axis numbers 1-5, reference positions at 0, 0.001 mm/deg detection
units): a real machine's come from its parameters.

Run: python examples/paper2_tables.py [--seed N] [--out DIR]
"""
import argparse

import numpy as np

import vecpin
from vecpin.compensation.functions import all_table_names, pseudo_commands, truth_as_actual
from vecpin.compensation.tableproblem import TableProblem
from vecpin.compensation.frame import model_as_actual
from vecpin.compensation.report import compensated_errors
from vecpin.models import make_model
from vecpin.measurement.noise import NoiseModel
from vecpin.simulation.simulate import simulate
from vecpin.compensation.selection import Constraints, exact_search, finalise, genetic_search, impact_heuristic
from vecpin.export import fanuc, fanuc_read
from vecpin.export.common import ExportJob
from vecpin.export.profile import ControllerProfile
from vecpin.fileio import OutputSet

SEED = {
    "table2": [("Model", "0.036", "-"), ("Full tables", "0.031", "-"), ("Pitch only", "0.142", "-")],
    "table5": [("Full tables", "--", "0.0310"), ("Heuristic", "1.0 h", "0.0625"), ("Average GA", "5.2 h", "0.0470")],
    "table7": [("Full tables", "0.0310"), ("Average GA", "0.0470"), ("Best GA", "0.0445 xz yc xc yx zx bc"),
               ("No circular, best of 5", "0.0526"), ("No X output", "0.0753 zx yx yc zb cb bc")],
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="paper2_fanuc", help="folder for the Fanuc 30i files (default paper2_fanuc)")
    args = ap.parse_args()
    m = vecpin.Machine.load("flow_xyzcb")
    sim = simulate(m, seed=args.seed, mean_error_mm=0.65)
    noise = NoiseModel.default(m, "spherical")
    model = make_model("6dof", m, 6).fit(sim.campaign, noise)
    problem = TableProblem(model_as_actual(model), m, sim.campaign.q[:295], [0.21488, 0.31286], order=6)
    truth = truth_as_actual(sim.truth)
    qv = pseudo_commands(m, 1000, seed=7)
    tv = np.tile([0.21488, 0.31286], 500)

    def on_truth(tables):
        return np.linalg.norm(compensated_errors(truth, m, tables, qv, tv), axis=1).mean()

    print("Paper II Table 2: volumetric errors, mm (mean)")
    print(f"  {'':<16s} {'seed':>8s} | {'vecpin model':>12s} {'max':>8s} | {'on the true machine':>20s}")
    rep = model.report_.residuals_mm["all"]
    full_t, full_mean, full_max = finalise(problem, [n for n in all_table_names(m) if n[0] != n[1]])
    pitch_t, pitch_mean, pitch_max = finalise(problem, [])
    print(f"  {'Model':<16s} {'0.036':>8s} | {rep['mean']:12.4f} {rep['max']:8.4f} |")
    print(f"  {'Full tables':<16s} {'0.031':>8s} | {full_mean:12.4f} {full_max:8.4f} | {on_truth(full_t) * 1e3:20.4f}")
    print(f"  {'Pitch only':<16s} {'0.142':>8s} | {pitch_mean:12.4f} {pitch_max:8.4f} | {on_truth(pitch_t) * 1e3:20.4f}")
    print(f"  {'Uncompensated':<16s} {'':>8s} | {'':>12s} {'':>8s} | {on_truth(None) * 1e3:20.4f}")

    print("\nPaper II Table 3: each GA run (6 of 20, 20% mutation, population 8, 50 generations / 20 unchanged)")
    gas = [genetic_search(problem, Constraints(6), seed=s) for s in range(5)]
    for k, g in enumerate(gas):
        print(f"  run {k + 1}: mean {g.mean_mm:.4f} mm, {len(g.history)} generations, {g.evaluations} combinations, "
              f"{g.seconds:.2f} s: {' '.join(g.tables)}")

    print("\nPaper II Table 4: mean error (mm) of the full set without each table (impact heuristic)")
    h = impact_heuristic(problem, Constraints(6))
    seed4 = {"zx": 0.1169, "yc": 0.1126, "xc": 0.1000, "zy": 0.0924, "yz": 0.0792, "bx": 0.0751}
    for rank, (name, err) in enumerate(h.ranking, 1):
        if rank <= 9 or rank > 16:
            s = f"{seed4[name]:.4f}" if name in seed4 else ""
            print(f"  {rank:2d} {name}  {err:.4f}   {s}")
        elif rank == 10:
            print("   ...")
    print("  (seed's top six: zx yc xc zy yz bx)")

    ex = exact_search(problem, Constraints(6))
    print("\nPaper II Table 5: heuristic, average GA and exact search (mean, mm)")
    print(f"  {'':<14s} {'seed time':>10s} {'seed mean':>10s} | {'time s':>8s} {'mean':>8s} {'on truth':>9s}  tables")
    print(f"  {'Full tables':<14s} {'--':>10s} {'0.0310':>10s} | {'':>8s} {full_mean:8.4f} {on_truth(full_t) * 1e3:9.4f}")
    print(f"  {'Heuristic':<14s} {'1.0 h':>10s} {'0.0625':>10s} | {h.seconds:8.2f} {h.mean_mm:8.4f} "
          f"{on_truth(finalise(problem, h.tables)[0]) * 1e3:9.4f}  {' '.join(h.tables)}")
    print(f"  {'Average GA':<14s} {'5.2 h':>10s} {'0.0470':>10s} | {np.mean([g.seconds for g in gas]):8.2f} "
          f"{np.mean([g.mean_mm for g in gas]):8.4f}")
    print(f"  {'Exact':<14s} {'550 h est.':>10s} {'':>10s} | {ex.seconds:8.2f} {ex.mean_mm:8.4f} "
          f"{on_truth(finalise(problem, ex.tables)[0]) * 1e3:9.4f}  {' '.join(ex.tables)}")

    print("\nPaper II Table 7: constraints (mean, mm)")
    print("  seed: full 0.0310, average GA 0.0470, best GA 0.0445; no circular 0.0526-0.0571; no X output 0.0753")
    for label, cons in [("none", Constraints(6)), ("no circular", Constraints(6, no_circular=True)),
                        ("no X output", Constraints(6, forbid_output=("X",)))]:
        runs = [genetic_search(problem, cons, seed=s) for s in range(5)]
        e = exact_search(problem, cons)
        print(f"  {label:<12s} GA runs: " + ", ".join(f"{r.mean_mm:.4f}" for r in runs)
              + f" | exact {e.mean_mm:.4f} {' '.join(e.tables)}")


    print(f"\nFanuc 30i files for the exact choice ({' '.join(ex.tables)}), written to {args.out}/:")
    tables, _, _ = finalise(problem, ex.tables)
    axes = {a.name: {"number": k + 1, "reference_position": 0.0, "detection_unit": 0.001} for k, a in enumerate(m.axes)}
    prof = ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1, "axes": axes},
                                       "illustrative profile of the example")
    with OutputSet(args.out) as out:
        job = ExportJob(tables, m, prof, fanuc.FORMAT.limits_for(prof), out, model)
        names = fanuc.write(job)
    limit = fanuc.FORMAT.extra_limit(prof, "max_pitch_value")
    grids = fanuc_read.read_grids(args.out, m, prof)
    print(f"  {'axis':<5s} {'points':>6s} {'interval':>10s} {'magnification':>13s} {'largest value':>13s}")
    for g in grids:
        print(f"  {g.axis:<5s} {g.last - g.first + 1:6d} {g.interval:10.3f} {g.magnification:13d} "
              f"{int(abs(g.values).max()):13d}")
    fits = all(abs(g.values).max() <= limit and g.magnification <= fanuc.FORMAT.extra_limit(prof, "max_magnification")
               for g in grids)
    print(f"  every pitch value within +-{limit} x magnification: {'yes' if fits else 'NO'}; "
          f"{len(ex.tables)} straightness tables in STRAIGHTNESS.CSV (entered by hand, see README_FANUC.md)")
    back = fanuc_read.read(args.out, m, prof)
    back.gauge_offset_change = tables.gauge_offset_change
    print(f"  as written (constants at the reference removed, rounded): model-predicted mean "
          f"{np.linalg.norm(compensated_errors(problem.actual, m, back, problem.q, problem.L), axis=1).mean() * 1e3:.4f} mm,"
          f" on the true machine {on_truth(back) * 1e3:.4f} mm")
    offsets = {g.axis: g.offset for g in fanuc.grids(tables, m, prof)}   # [mm or deg] at the reference
    for t in back.tables:
        if t.is_pitch:
            t.values = t.values + m.axis(t.input_axis).to_si(offsets[t.input_axis])
    print(f"  with those constants set as reference-position shifts: model-predicted mean "
          f"{np.linalg.norm(compensated_errors(problem.actual, m, back, problem.q, problem.L), axis=1).mean() * 1e3:.4f} mm,"
          f" on the true machine {on_truth(back) * 1e3:.4f} mm ("
          + ", ".join(f"{a} {v:+.4f} {m.axis(a).unit}" for a, v in offsets.items()) + ")")
    print("  files: " + ", ".join(names))


if __name__ == "__main__":
    main()
