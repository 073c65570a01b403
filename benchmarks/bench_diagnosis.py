"""Diagnosis matrix (issue 5): effects x machines x strengths x seeds.

Prints a confusion matrix (true effect vs the effect ranked first), the false-alarm
rate on clean campaigns, the fraction of the gap recovered on noise-free validation
data, the smallest strength each effect is still detected at relative to the
measurement noise, and the time of a full diagnosis of a 590-row campaign.

Run: python benchmarks/bench_diagnosis.py [--quick]
"""
import argparse
import time
from collections import defaultdict

import numpy as np

import vecpin
from vecpin.diagnosis.diagnose import diagnose
from vecpin.models import make_model
from vecpin.measurement.noise import NoiseModel
from vecpin.simulation.simulate import Design, simulate
from vecpin.simulation.effects import TrueEffect


def spec(name, machine, strength, seed):
    rot = [a.name for a in machine.axes if a.kind == "rotary" and a.travel > 2 * np.pi]
    return {
        "gantry_skew": (TrueEffect("gantry_skew", ("Y",), strength, {"about": "x", "depends": "X"}, seed), "gantry_skew[Y/x]"),
        "coupled_axes": (TrueEffect("coupled_axes", ("X", "Y"), strength, seed=seed), "coupled_axes[X,Y]"),
        "thermal": (TrueEffect("thermal", (), strength, seed=seed), "thermal"),
        "backlash": (TrueEffect("backlash", ("X",), strength, seed=seed), "backlash[X]"),
        "rotary_periodic": (TrueEffect("rotary_periodic", tuple(rot[:1]), strength, seed=seed),
                            f"rotary_periodic[{rot[0]}]") if rot else (None, None),
        "instrument_shift": (TrueEffect("instrument_shift", (), strength, {"at": 0.6}, seed=seed), "instrument_shift"),
        "outliers": (TrueEffect("outliers", (), 10 * strength, {"fraction": 0.01}, seed=seed), "outliers"),
    }[name]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="one machine, two strengths, one seed")
    args = ap.parse_args()
    machines = ["flow_xyzcb"] if args.quick else ["flow_xyzcb", "ingersoll_xyzca"]
    strengths = [0.01, 0.03] if args.quick else [0.005, 0.01, 0.02, 0.05]
    seeds = [0] if args.quick else [0, 1]
    effects = ["gantry_skew", "coupled_axes", "thermal", "backlash", "rotary_periodic", "instrument_shift", "outliers"]
    design = Design(n_validation=200)
    confusion = defaultdict(lambda: defaultdict(int))
    detected = defaultdict(list)
    recovered = defaultdict(list)
    times, false_alarms, clean_runs, noise_rms = [], 0, 0, []
    for mname in machines:
        m = vecpin.Machine.load(mname)
        for seed in seeds:
            sim = simulate(m, seed=100 + seed, design=design)
            noise_rms.append(np.sqrt(np.mean(np.sum((sim.campaign.xyz - sim.truth.measure(sim.campaign.q, sim.campaign.tool,
                                                                                          None)) ** 2, axis=1))))
            base = make_model("6dof", m, 6).fit(sim.campaign, NoiseModel.default(m, "spherical"))
            floor = np.linalg.norm(base.residuals(sim.validation_truth), axis=1).mean()
            t0 = time.perf_counter()
            d = diagnose(m, sim.campaign)
            times.append((len(sim.campaign), time.perf_counter() - t0))
            clean_runs += 1
            false_alarms += bool(d.accepted or d.outlier_rows)
            confusion["clean"]["(none)" if not d.accepted else d.effects[0].name] += 1
            for name in effects:
                for strength in strengths:
                    eff, label = spec(name, m, strength, seed)
                    if eff is None:
                        continue
                    s = simulate(m, seed=100 + seed, design=design, effects=[eff])
                    t0 = time.perf_counter()
                    d = diagnose(m, s.campaign)
                    times.append((len(s.campaign), time.perf_counter() - t0))
                    top = d.effects[0] if d.effects and d.effects[0].significant else None
                    got = top.name if top else "(none)"
                    confusion[name][got] += 1
                    ok = top is not None and top.label.startswith(label)
                    detected[(name, strength)].append(ok)
                    if ok and name != "outliers":
                        before = np.linalg.norm(d.base_model.residuals(s.validation_truth), axis=1).mean()
                        after = np.linalg.norm(d.best_model.residuals(s.validation_truth), axis=1).mean()
                        if before - floor > 1e-6:
                            recovered[name].append((before - after) / (before - floor))
                    print(f"  {mname:<16s} seed {seed} {name:<17s} {strength:6.3f} mm -> {got:<17s} "
                          f"{'ok' if ok else 'MISS':4s} ({times[-1][1]:.1f} s)", flush=True)
    noise = float(np.mean(noise_rms)) * 1e3
    cols = effects + ["(none)"]
    print(f"\nConfusion matrix (rows: simulated effect; columns: effect ranked first and significant), "
          f"{len(machines)} machines x {len(seeds)} seeds x {len(strengths)} strengths:")
    print(f"  {'':<17s}" + "".join(f"{c[:10]:>11s}" for c in cols))
    for r in ["clean"] + effects:
        print(f"  {r:<17s}" + "".join(f"{confusion[r][c]:11d}" for c in cols))
    print(f"\nFalse alarms on clean campaigns: {false_alarms}/{clean_runs}")
    print(f"Measurement noise (RMS of |measured - exact|): {noise:.4f} mm")
    print(f"\n  {'effect':<17s} {'detected at strength (mm): fraction':<48s} {'smallest (x noise)':>18s} {'gap recovered':>14s}")
    for name in effects:
        row = "  ".join(f"{s:g}:{np.mean(detected[(name, s)]):.0%}" for s in strengths if detected[(name, s)])
        ok = [s for s in strengths if detected[(name, s)] and np.mean(detected[(name, s)]) == 1.0]
        smallest = f"{min(ok):g} ({min(ok) / noise:.2f})" if ok else "-"
        rec = f"{np.median(recovered[name]):.0%}" if recovered[name] else "-"
        print(f"  {name:<17s} {row:<48s} {smallest:>18s} {rec:>14s}")
    t = np.array([x[1] for x in times])
    print(f"\nFull diagnosis time: median {np.median(t):.1f} s, max {t.max():.1f} s for {times[0][0]}-row campaigns "
          f"(target <= 60 s for 600 rows)")


if __name__ == "__main__":
    main()
