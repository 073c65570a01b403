"""A joint that never moved in training (issue 40): one sweep of a one-joint-at-a-time design held out.

A simulated UR10 (vecpin's simulator: a random true machine of 6-DoF errors per joint with location
offsets, tilts and index errors at 1 and 2 cycles per turn, tracker noise and repeatability) is read
along six sweeps from one middle pose, each joint swept +-90 deg in :data:`PER_SWEEP` steps, one
target on the flange. For every joint k the sweep of k is held out and the rest fitted: joint k
stood still in every training row, so the campaign knows its errors at that one position only.

Fits: vecpin's default (``vecpin.fit`` with no option: kind, bases and orders chosen by
cross-validation, folds grouped by sweep) and constant 6-DoF errors (``kind="6dof", order=0``), each
twice: *priors* (now: when an axis stood still, terms that only its stillness makes collinear are
held by their priors, the posterior mean, as the model choice's folds fit them; only terms no design
could identify are removed) and *term order* (before: the campaign's own redundancy removal, which
keeps the earlier of two collinear terms and drops the later one, so the split between a link's
constant error before the still joint and the joint's own error after it is decided by the order of
the terms). Held-out error: mean distance, mm, between each simulated reading of the held-out sweep
and the model's prediction; uncorrected: the nominal kinematics in the fitted tracker frame.

Run: python benchmarks/bench_still_joint.py [--seeds 0-8] [--out docs/results/still_joint.md]
"""
from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
MID = np.array([0.3, -1.2, 1.4, -1.5, -1.4, 0.2])   # rad: the middle pose the sweeps leave from
PER_SWEEP = 10
HALF_RAD = np.pi / 2
TOOL_M = 0.1
FITS = {"default": {}, "6-DoF constant": {"kind": "6dof", "order": 0}}


def design(machine) -> tuple[np.ndarray, np.ndarray]:
    """(commands (6 x PER_SWEEP, 6) rad, the joint each command sweeps)."""
    q, joint = [], []
    for a in machine.axes:
        for v in np.linspace(-HALF_RAD, HALF_RAD, PER_SWEEP):
            c = MID.copy()
            c[a.index] += v
            q.append(c)
            joint.append(a.index)
    return np.array(q), np.array(joint)


def one_seed(seed: int) -> list[dict]:
    """Per held-out joint: uncorrected and every fit's held-out mean [mm], both ways."""
    import vecpin
    import vecpin.identification.fit as fitmod
    from vecpin.simulation.simulate import Design, simulate
    from vecpin.units import norm_mm
    m = vecpin.Machine.load("ur10")
    q, joint = design(m)
    c = simulate(m, seed=seed, plan=(q, np.full(len(q), TOOL_M)), design=Design(n_validation=5)).campaign
    out = []
    for k in range(m.n_axes):
        held = joint == k
        train, test = c.subset(np.flatnonzero(~held)), c.subset(np.flatnonzero(held))
        row = {"seed": seed, "joint": m.axes[k].name}
        for way, flag in (("priors", True), ("term order", False)):
            fitmod.STILL_BY_PRIORS = flag
            for name, kw in FITS.items():
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    model = vecpin.fit(m, train, None, **kw).model
                row[(name, way)] = float(norm_mm(model.residuals(test)).mean())
                if name == "default" and flag:
                    row["uncorrected"] = float(norm_mm(test.xyz - model.predict_nominal(test.q, test.tool)).mean())
                    row["chosen"] = model.kind
        fitmod.STILL_BY_PRIORS = True
        out.append(row)
    return out


def summary(rows: list[dict]) -> list[str]:
    """Mean over the held-out sweeps and how many are worse than uncorrected, per fit and way."""
    unc = np.array([r["uncorrected"] for r in rows])
    lines = ["| fit | way | held-out mean, mm | worse than uncorrected (sweeps) | mean / uncorrected |",
             "|---|---|---|---|---|",
             f"| uncorrected | - | {unc.mean():.4f} | - | 1.00 |"]
    for name in FITS:
        for way in ("term order", "priors"):
            v = np.array([r[(name, way)] for r in rows])
            lines.append(f"| {name} | {way}{' (before)' if way == 'term order' else ' (now)'} | {v.mean():.4f} | "
                         f"{int((v > unc).sum())} of {len(v)} | {v.mean() / unc.mean():.2f} |")
    return lines


def per_joint(rows: list[dict]) -> list[str]:
    """The same means per held-out joint."""
    names = list(dict.fromkeys(r["joint"] for r in rows))
    head = [f"{n} / {w}" for n in FITS for w in ("term order", "priors")]
    lines = ["| held-out joint | uncorrected | " + " | ".join(head) + " |", "|---|---|" + "---|" * len(head)]
    for j in names:
        rs = [r for r in rows if r["joint"] == j]
        cells = " | ".join(f"{np.mean([r[(n, w)] for r in rs]):.4f}" for n in FITS for w in ("term order", "priors"))
        lines.append(f"| {j} | {np.mean([r['uncorrected'] for r in rs]):.4f} | {cells} |")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0-8", help="simulated machines, e.g. 0-8 (default) or 3,5")
    ap.add_argument("--out", default=str(ROOT / "docs" / "results" / "still_joint.md"))
    args = ap.parse_args()
    lo, _, hi = args.seeds.partition("-")
    seeds = list(range(int(lo), int(hi) + 1)) if hi else [int(s) for s in args.seeds.split(",")]
    t0 = time.perf_counter()
    rows = []
    for s in seeds:
        rows += one_seed(s)
        print(f"seed {s}: " + "; ".join(f"{r['joint']} unc {r['uncorrected']:.3f} default "
                                        f"{r[('default', 'priors')]:.3f} (before {r[('default', 'term order')]:.3f})"
                                        for r in rows[-6:]), flush=True)
    text = "\n".join([
        "# A joint that never moved in training: one sweep held out", "",
        "Written by `python benchmarks/bench_still_joint.py` (module docstring: the simulated UR10, the "
        f"one-joint-at-a-time design, the fits). Seeds {args.seeds}: {len(rows)} held-out sweeps "
        f"({time.perf_counter() - t0:.0f} s). *Term order* is how the fit treated a still joint before: the "
        "campaign's redundancy removal decides between terms that only the stillness makes collinear; *priors*: "
        "they are held by their priors (the posterior mean), only what no design could identify removed.", "",
        *summary(rows), "", "## Per held-out joint (mean over the seeds), mm", "", *per_joint(rows), ""])
    Path(args.out).write_text(text, encoding="utf-8")
    print(text)
    print(f"written {args.out}")


if __name__ == "__main__":
    main()
