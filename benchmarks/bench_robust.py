"""Gross errors found before the noise level is taken from the data (issues 40 and 42).

A simulated Flow XYZCB campaign (480 rows, two tools; seeds ``--seeds``) fitted with the
noise from the data (no noise stated), a 6-DoF model with Fourier series of order 6 (about
9 µm on this machine), clean and spoilt four ways:

* ``9 gross``: nine rows 0.3-1.2 mm off in random directions, four of them (the smallest)
  in one twentieth of X's travel (issue 40);
* ``bump 20`` / ``bump 96``: 0.37 mm on 20 or 96 rows read one after another (issue 42);
* ``flipped target``: a 240-row campaign of three known targets, one offset's x sign
  flipped (issue 42).

Per case: what the fit did (left rows out, or refused), how many of the spoilt rows it
named, the noise scale it used, the plain and robust scales of the screen, and the
validation error (mean distance on 60 noise-free validation points, µm) beside the clean
fit's and beside the fit without the screen (the behaviour before). Then the diagnosis of
``9 gross`` (fixed model, outliers only): the gross errors it flags and its model's
validation error. The judge is the simulation's truth.

Run: python benchmarks/bench_robust.py [--seeds 5 6 7] [--out docs/results/robust_screen.md]
"""
from __future__ import annotations

import argparse
import copy
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_robust_screen import FIXED, nine_gross, validation_um  # noqa: E402  (the test's spoiling and judge)


def spoil(case: str, sim, machine, rng) -> np.ndarray:
    """The rows spoilt in ``sim.campaign`` (in place)."""
    c = sim.campaign
    if case == "9 gross":
        return nine_gross(c, machine, rng)
    if case.startswith("bump"):
        n = int(case.split()[1])
        rows = np.argsort(c.time)[100:100 + n]
        c.xyz[rows] += np.array([0.37e-3, 0.0, 0.0])
        return rows
    c.targets["T2"] = c.targets["T2"] * np.array([-1.0, 1.0, 1.0])
    return np.flatnonzero(c.target.astype(str) == "T2")


def one(machine, sim, case: str, seed: int) -> dict:
    """The fit of one spoilt campaign, with and without the screen."""
    import vecpin.selection.choice as choice
    from vecpin.errors import InputError
    from vecpin.measurement.noise import NoiseModel
    from vecpin.workflows.fitting import fit_campaign
    spoilt = copy.deepcopy(sim)
    rows = spoil(case, spoilt, machine, np.random.default_rng(seed))
    noise = NoiseModel.default(machine)
    out = {"case": case, "seed": seed, "spoilt": len(rows)}
    t0 = time.perf_counter()
    try:
        run = fit_campaign(machine, spoilt.campaign, noise, noise_from_data=True, **FIXED)
        g = run.gross
        named = np.array([], int) if g is None else g.rows
        out |= {"did": "left out" if g is not None else "kept all", "named": len(np.intersect1d(named, rows)),
                "others": len(np.setdiff1d(named, rows)), "noise": run.noise_used,
                "plain": None if g is None else g.plain, "robust": None if g is None else g.robust,
                "val": validation_um(run.model, sim)}
    except InputError as e:
        out |= {"did": "refused", "named": len(rows) if "file lines" in str(e) else 0, "others": 0,
                "noise": None, "plain": None, "robust": None, "val": None}
    out["seconds"] = time.perf_counter() - t0
    plain = choice.choose_model
    choice.choose_model = lambda *a, **k: plain(*a, **(k | {"screen": False}))
    try:
        before = fit_campaign(machine, spoilt.campaign, noise, noise_from_data=True, **FIXED)
        out |= {"before_noise": before.noise_used, "before_val": validation_um(before.model, sim)}
    finally:
        choice.choose_model = plain
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[5, 6, 7])
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "results" / "robust_screen.md"))
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    import vecpin
    from vecpin.diagnosis.diagnose import diagnose
    from vecpin.measurement.noise import NoiseModel
    from vecpin.simulation.simulate import Design, simulate
    from vecpin.workflows.fitting import fit_campaign
    m = vecpin.Machine.load("flow_xyzcb")
    rows, diag = [], []
    for seed in args.seeds:
        sim = simulate(m, seed=seed, design=Design(n_commands=240, n_validation=60))
        clean = validation_um(fit_campaign(m, sim.campaign, NoiseModel.default(m), noise_from_data=True,
                                           **FIXED).model, sim)
        for case in ("9 gross", "bump 20", "bump 96"):
            r = one(m, sim, case, seed) | {"clean": clean}
            rows.append(r)
            print(r)
        tsim = simulate(m, seed=seed, design=Design(n_commands=80, n_validation=60, tools_mm=(250.0,), known_targets=True,
                                                    targets_mm=((60, 0, 40), (-60, 0, 40), (0, 60, 40))))
        r = one(m, tsim, "flipped target", seed) | {"clean": float("nan")}
        rows.append(r)
        print(r)
        spoilt = copy.deepcopy(sim)
        bad = spoil("9 gross", spoilt, m, np.random.default_rng(seed))
        d = diagnose(m, spoilt.campaign, model="6dof", basis="fourier", order=6, effects=["outliers"])
        diag.append({"seed": seed, "flagged": len(np.intersect1d(d.outlier_rows, bad)),
                     "others": len(np.setdiff1d(d.outlier_rows, bad)), "regions": len(d.misfit_regions),
                     "val": validation_um(d.best_model, sim), "clean": clean})
        print(diag[-1])
    write(args.out, rows, diag)
    print(f"wrote {args.out}")


def _f(v, fmt: str) -> str:
    return "-" if v is None or (isinstance(v, float) and not np.isfinite(v)) else format(v, fmt)


def write(path: str, rows: list[dict], diag: list[dict]) -> None:
    lines = ["# Gross errors before the noise level (issues 40 and 42)", "",
             "Written by `python benchmarks/bench_robust.py`: Flow XYZCB, 480 rows (the flipped target: 240 rows "
             "of three known targets), noise from the data, 6-DoF Fourier order 6; validation: mean distance on 60 "
             "noise-free points, µm. 'before': the same fit without the screen.", "",
             "| case | seed | rows spoilt | the fit | spoilt rows named | others named | noise used | plain / robust "
             "scale | validation | clean fit | before: noise | before: validation | s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        pr = f"{_f(r['plain'], '.2f')} / {_f(r['robust'], '.2f')}" if r["plain"] is not None else "-"
        lines.append(f"| {r['case']} | {r['seed']} | {r['spoilt']} | {r['did']} | {r['named']} | {r['others']} | "
                     f"{_f(r['noise'], '.2f')} | {pr} | {_f(r['val'], '.2f')} | {_f(r['clean'], '.2f')} | "
                     f"{_f(r['before_noise'], '.1f')} | {_f(r['before_val'], '.1f')} | {r['seconds']:.1f} |")
    lines += ["", "The diagnosis of '9 gross' (fixed model, outliers only):", "",
              "| seed | gross errors flagged (of 9) | other rows flagged | misfit regions | validation | clean fit |",
              "|---|---|---|---|---|---|"]
    lines += [f"| {d['seed']} | {d['flagged']} | {d['others']} | {d['regions']} | {d['val']:.2f} | {d['clean']:.2f} |"
              for d in diag]
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
