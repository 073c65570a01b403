"""Diagnosis matrix (issue 12): effects x machines x strengths x seeds, on bundled
machines (vecpin's own truth family) and on machines vecpin never saw (the independent
truth family, including rotary axes travelling several turns and long gantries).

For every campaign with one withheld effect (and clean campaigns) it records which
effects the diagnosis accepted. Printed: per effect the recall (the true effect
accepted) and precision (accepted effects of that kind that were really there), the
number of *spurious* effects (named but not there) per campaign, clean campaigns that
named anything, the gap recovered on noise-free validation, and the worst diagnosis
time of a ~600-row campaign (target <= 15 s).

Run: python benchmarks/bench_diagnosis.py [--quick]
"""
import argparse
import time
from collections import defaultdict

import numpy as np

import vecpin
from vecpin.diagnosis.diagnose import diagnose
from vecpin.measurement.noise import NoiseModel
from vecpin.simulation.effects import EffectSpec
from vecpin.simulation.independent import IndependentMachine, layout
from vecpin.simulation.simulate import Design, simulate

EFFECTS = ["gantry_skew", "coupled_axes", "thermal", "backlash", "rotary_periodic", "instrument_shift", "outliers"]


def spec(name, machine, strength, seed):
    """(specification, label prefix of the right answer) of an effect on a machine."""
    rot = [a.name for a in machine.axes if a.kind == "rotary" and a.travel > 2 * np.pi]
    lin = [a.name for a in machine.axes if a.kind == "linear"]
    return {
        "gantry_skew": (EffectSpec("gantry_skew", (lin[1],), strength, {"about": "x", "depends": lin[0]}, seed),
                        "gantry_skew["),
        "coupled_axes": (EffectSpec("coupled_axes", (lin[0], lin[1]), strength, seed=seed),
                         f"coupled_axes[{lin[0]},{lin[1]}]"),
        "thermal": (EffectSpec("thermal", (), strength, seed=seed), "thermal"),
        "backlash": (EffectSpec("backlash", (lin[0],), strength, seed=seed), f"backlash[{lin[0]}]"),
        "rotary_periodic": (EffectSpec("rotary_periodic", tuple(rot[:1]), strength, seed=seed),
                            f"rotary_periodic[{rot[0]}]") if rot else (None, None),
        "instrument_shift": (EffectSpec("instrument_shift", (), strength, {"at": 0.6}, seed=seed), "instrument_shift"),
        "outliers": (EffectSpec("outliers", (), 10 * strength, {"fraction": 0.01}, seed=seed), "outliers"),
    }[name]


def machines(quick: bool):
    """(label, machine, truth factory(seed) or None for vecpin's own random truth)."""
    out = [("flow_xyzcb", vecpin.Machine.load("flow_xyzcb"), None)]
    if not quick:
        out.append(("ingersoll_xyzca", vecpin.Machine.load("ingersoll_xyzca"), None))
    for name, fam in ([("portal_xyzcb_c720", "windup")] if quick else
                      [("portal_xyzcb_c720", "windup"), ("head_xyzab_b540", "periodic_drift"),
                       ("gantry_xyzca_c720", "spline")]):
        m = layout(name)
        out.append((f"{name}/{fam}", m, lambda seed, m=m, fam=fam: IndependentMachine.random(m, fam, seed=seed)))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="fewer machines, strengths and seeds")
    args = ap.parse_args()
    strengths = [0.02, 0.05] if args.quick else [0.01, 0.02, 0.05]
    seeds = [0] if args.quick else [0, 1]
    design = Design(n_validation=200)
    recall = defaultdict(list)            # effect -> [accepted the true effect?]
    in_group = defaultdict(list)          # effect -> [named only as a member of another's ambiguity group?]
    named = defaultdict(lambda: [0, 0])   # effect kind -> [named right, named wrong]
    spurious, clean_named, recovered, times = [], [], defaultdict(list), []
    for label, m, factory in machines(args.quick):
        for seed in seeds:
            truth = factory(seed) if factory else None
            noise = NoiseModel.default(m, "spherical", **({"tracker": truth.tracker.noise} if truth else {}))
            kw = {"truth": truth} if truth else {}
            sim = simulate(m, seed=100 + seed, design=design, **kw)
            t0 = time.perf_counter()
            d = diagnose(m, sim.campaign, noise=noise)
            times.append(time.perf_counter() - t0)
            names = [e.label for e in d.accepted]
            clean_named.append(names)
            for e in d.accepted:
                named[e.name][1] += 1
            print(f"  {label:<30s} seed {seed} clean                    -> {', '.join(names) or '(none)'} "
                  f"({times[-1]:.1f} s)", flush=True)
            for name in EFFECTS:
                for strength in strengths:
                    eff, right = spec(name, m, strength, seed)
                    if eff is None:
                        continue
                    truth = factory(seed) if factory else None
                    kw = {"truth": truth} if truth else {}
                    s = simulate(m, seed=100 + seed, design=design, effects=[eff], **kw)
                    t0 = time.perf_counter()
                    d = diagnose(m, s.campaign, noise=noise)
                    times.append(time.perf_counter() - t0)
                    acc = d.accepted
                    # a finding is right when it or a member of its ambiguity group (the
                    # diagnosis names "X or Y: this campaign cannot tell them apart") is the truth
                    hit = [e for e in acc if any(x.startswith(right) for x in [e.label] + e.alternatives)]
                    ok = any(e.label.startswith(right) for e in acc)
                    wrong = [e for e in acc if e not in hit]
                    recall[name].append(ok)
                    in_group[name].append(bool(hit) and not ok)
                    spurious.append(len(wrong))
                    for e in acc:
                        named[e.name][0 if e.label.startswith(right) else 1] += 1
                    if ok and name != "outliers":
                        before = np.linalg.norm(d.base_model.residuals(s.validation_truth), axis=1).mean()
                        after = np.linalg.norm(d.best_model.residuals(s.validation_truth), axis=1).mean()
                        if before > 0:
                            recovered[name].append(1 - after / before)
                    print(f"  {label:<30s} seed {seed} {name:<17s} {strength:5.3f} mm -> "
                          f"{'; '.join(e.finding for e in acc) or '(none)'} "
                          f"{'ok' if ok else ('ok (in its group)' if hit else 'MISS')}"
                          f"{' +' + str(len(wrong)) + ' spurious' if wrong else ''} ({times[-1]:.1f} s)", flush=True)
    print("\nPer effect: recall (the withheld effect accepted) and precision (accepted effects of this kind that "
          "were there), all machines, strengths and seeds")
    print(f"  {'effect':<17s} {'recall':>8s} {'+group':>7s} {'precision':>10s} "
          f"{'validation error removed (median)':>34s}")
    for name in EFFECTS:
        r = recall[name]
        right, wrong = named[name]
        prec = f"{right / (right + wrong):.0%}" if right + wrong else "-"
        rec = f"{np.median(recovered[name]):.0%}" if recovered[name] else "-"
        grp = f"{np.mean(np.array(r) | np.array(in_group[name])):.0%}" if r else "-"
        print(f"  {name:<17s} {np.mean(r):8.0%} {grp:>7s} {prec:>10s} {rec:>34s}" if r else f"  {name:<17s} {'-':>8s}")
    print("(recall: the true effect named; +group: or named as a member of the accepted effect's ambiguity "
          "group; spurious: findings whose group does not hold the truth)")
    print(f"\nSpurious effects (named but not there) in single-effect campaigns: {sum(spurious)} in {len(spurious)} "
          f"campaigns ({np.mean(spurious):.2f} per campaign)")
    print(f"Clean campaigns naming an effect: {sum(bool(n) for n in clean_named)} of {len(clean_named)}")
    print(f"Diagnosis time: median {np.median(times):.1f} s, worst {max(times):.1f} s for ~590-row campaigns "
          "(target <= 15 s)")


if __name__ == "__main__":
    main()
