"""Thermal terms on fresh truths outside vecpin's thermal model (issue 44), through the
controllers' files read back by the tests' independent readers.

Each run draws fresh seeds (or takes ``--seed``); per seed a truth of
tests/thermal_truth.py: the structure lags the air by 0.6..3.5 h (vecpin scans 0, 0.5,
1, 2, 4 h and refines between), per axis an offset of ±10 um/K, an expansion of 6..16
ppm/K about its own centre and a curvature (a common -1.5..1.5 %/K plus ±0.5 %/K per
axis), a tool growing 0..10 um/K; a 10 h campaign of 160 rows on the trunnion machine
(3 um tracker noise per coordinate) while the hall cycles 2..4 K over 5..9 h and drifts
±0.2 K/h. vecpin fits its terms (:func:`vecpin.compensation.thermal.fit_thermal`) and
writes one controller's files (the seeds cycle through Siemens 840D, Beckhoff, Heidenhain,
Fanuc); the reader turns them into the correction; 40 fresh commands run on the truth at
a steady temperature 10 K above or below the campaign's mean. Judged: the tip's mean
displacement from where the machine put it at the campaign's temperature (what the
geometric tables leave), without and with the terms, against vecpin's prediction
(:func:`vecpin.compensation.thermal.remaining_mm`: expected figure and 5..95 % band).

Run: python benchmarks/bench_thermal_truth.py [--seeds 24] [--seed S] [--out PAGE]
"""
from __future__ import annotations

import argparse
import secrets
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from thermal_truth import READERS, Truth, commands, corrected, judged  # noqa: E402  (the independent judges)

import vecpin  # noqa: E402
from vecpin.compensation.thermal import fit_thermal, remaining_mm  # noqa: E402
from vecpin.export import thermal  # noqa: E402
from vecpin.export.profile import ControllerProfile  # noqa: E402
from vecpin.fileio import OutputSet  # noqa: E402
from vecpin.measurement.campaign import Campaign  # noqa: E402
from vecpin.measurement.noise import NoiseModel  # noqa: E402
from vecpin.models import make_model  # noqa: E402

PAGE = Path(__file__).resolve().parents[1] / "docs" / "results" / "thermal_truth.md"
STEP_K = 10.0


def draw_truth(m, rng) -> Truth:
    """A truth of the family the module text describes."""
    common = rng.uniform(-0.015, 0.015)
    axes = ("X", "Y", "Z")
    centre = {a: rng.uniform(m.axis(a).lower, m.axis(a).upper) for a in axes}
    return Truth(lag_s=rng.uniform(0.6, 3.5) * 3600.0,
                 nonlinear={a: common + rng.uniform(-0.005, 0.005) for a in axes},
                 offset={a: rng.uniform(-10e-6, 10e-6) for a in axes},
                 expand={a: rng.uniform(6e-6, 16e-6) for a in axes}, centre=centre,
                 growth=rng.uniform(0.0, 10e-6), growth_nonlinear=common)


def one(m, seed: int, controller: str) -> dict:
    """Draw, measure, fit, write, read back and judge one seed."""
    rng = np.random.default_rng(seed)
    truth = draw_truth(m, rng)
    n = 160
    q = commands(m, n, rng)
    t = np.linspace(0, 10 * 3600, n)
    period, amp, drift = rng.uniform(5, 9) * 3600, rng.uniform(2, 4), rng.uniform(-0.2, 0.2)
    air = 21 + amp * np.sin(2 * np.pi * t / period + rng.uniform(0, 2 * np.pi)) + drift * t / 3600
    tool = np.full(n, 0.12)
    xyz = truth.tip(m, q, tool, truth.structure(t, air)) + rng.normal(0, 3e-6, (n, 3))
    camp = Campaign(m.axis_names, q, tool, xyz, extra={"time": t, "temperature": air})
    start = time.perf_counter()
    geo = make_model("6dof", m, 2).fit(camp, NoiseModel.default(m, "spherical"))
    terms, _ = fit_thermal(geo, camp)
    seconds = time.perf_counter() - start
    tv = terms.t0_c + STEP_K * rng.choice([-1.0, 1.0])
    qv = commands(m, 40, rng)
    toolv = np.full(len(qv), 0.12)
    with tempfile.TemporaryDirectory() as tmp:
        with OutputSet(Path(tmp)) as out:
            thermal.write(controller, terms, ControllerProfile(), out)
        without, left = judged(m, truth, qv, toolv, corrected(m, qv, Path(tmp), controller, tv), tv, terms.t0_c)
    pred = remaining_mm(terms, m, qv, toolv, tv)
    straight = remaining_mm(replace(terms, curvature={}), m, qv, toolv, tv)
    return {"seed": seed, "controller": controller, "lag_true": truth.lag_s / 3600, "lag": terms.lag_h,
            "lag_std": terms.held_out.get("lag_std_h", 0.0),
            "kappa_true": float(np.mean(list(truth.nonlinear.values()))),
            "kappa": terms.curvature.get("per_k", np.nan), "kappa_std": terms.curvature.get("std_per_k", np.nan),
            "step": tv - terms.t0_c, "without": without * 1e6, "with": left * 1e6, "expected": pred.expected * 1e3,
            "low": pred.low * 1e3, "high": pred.high * 1e3, "straight": straight.expected * 1e3, "seconds": seconds}


def summary(rows: list[dict]) -> list[str]:
    n = len(rows)
    inband = sum(0.8 * r["low"] <= r["with"] <= 1.2 * r["high"] for r in rows)
    strict = sum(r["low"] <= r["with"] <= r["high"] for r in rows)
    point = sum(abs(r["with"] / r["expected"] - 1) <= 0.2 for r in rows)
    straight = sum(abs(r["with"] / r["straight"] - 1) <= 0.2 for r in rows)
    smaller = sum(r["with"] < r["without"] for r in rows)
    high = sum(r["high"] < r["without"] for r in rows)
    ratio = np.array([r["with"] / r["without"] for r in rows])
    low = sum(r["with"] < 0.8 * r["low"] for r in rows)
    return [f"- the error left within 20 % of the predicted band (0.8 x low .. 1.2 x high): **{inband}/{n}** "
            f"(inside the band itself: {strict}/{n}); below it {low}, above it {n - inband - low}",
            f"- the error left smaller than without the terms: **{smaller}/{n}** (median {np.median(ratio):.1%} of "
            f"it, worst {ratio.max():.1%}); the band's top below the error without: {high}/{n}",
            f"- within 20 % of the expected figure alone (a point prediction): {point}/{n}; of the expected figure "
            f"without the curvature's bound (straight terms trusted 10 K away): {straight}/{n}",
            f"- fit time (geometry, lag scan and refinement, held-out blocks, curvature): median "
            f"{np.median([r['seconds'] for r in rows]):.2f} s per campaign"]


def page(rows: list[dict], base: int) -> str:
    head = ("| seed | controller | lag true / fitted ± sd [h] | curvature true / fitted ± sd [%/K] | step [K] | "
            "without [um] | left [um] | predicted: expected (band) [um] | straight only [um] |\n"
            "|---|---|---|---|---|---|---|---|---|")
    body = [f"| {r['seed']} | {r['controller']} | {r['lag_true']:.2f} / {r['lag']:.2f} ± {r['lag_std']:.2f} | "
            f"{r['kappa_true'] * 100:+.2f} / {r['kappa'] * 100:+.2f} ± {r['kappa_std'] * 100:.2f} | "
            f"{r['step']:+.0f} | {r['without']:.1f} | {r['with']:.1f} | {r['expected']:.1f} ({r['low']:.1f} .. "
            f"{r['high']:.1f}) | {r['straight']:.1f} |" for r in rows]
    return "\n".join(["# Thermal terms on fresh truths outside vecpin's model", "",
                      "Written by `benchmarks/bench_thermal_truth.py` (its docstring gives the truth family and the "
                      f"judging); this run drew seeds {base}..{base + len(rows) - 1}: every run draws fresh ones.", "",
                      *summary(rows), "",
                      "Why a band and not a point: the error the terms leave 10 K away is one draw of the "
                      "coefficients' error, and a campaign over a hall cycle of a few kelvin bounds a curvature of the "
                      f"error only to ±{np.median([r['kappa_std'] for r in rows]) * 100:.1f} %/K (the median standard "
                      "deviation over these seeds), which 10 K away is that share per kelvin of the whole thermal "
                      "gain, times ten. The lag matters too: a lag off by a fraction of the scan's step changes the "
                      "gain fitted on a hall cycle (the lag damps the cycle), so vecpin refines the lag between the "
                      "scanned ones and carries its uncertainty. Where the campaign bounds the curvature only loosely "
                      "the band is wide (the vecpin printout then says to measure over a wider temperature span).",
                      "", head,
                      *body, ""])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=24)
    ap.add_argument("--seed", type=int, default=None, help="first seed (default: fresh)")
    ap.add_argument("--out", type=Path, default=PAGE)
    args = ap.parse_args(argv)
    base = args.seed if args.seed is not None else secrets.randbelow(10 ** 6)
    m = vecpin.Machine.load("trunnion_xyzac")
    names = list(READERS)
    rows = []
    for k in range(args.seeds):
        r = one(m, base + k, names[k % len(names)])
        rows.append(r)
        print(f"seed {r['seed']} {r['controller']:10s} lag {r['lag_true']:.2f}/{r['lag']:.2f} h  without "
              f"{r['without']:6.1f} um  left {r['with']:5.1f} um  predicted {r['expected']:5.1f} "
              f"({r['low']:.1f} .. {r['high']:.1f}) um", flush=True)
    print("\n".join(summary(rows)))
    args.out.write_text(page(rows, base), encoding="utf-8")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
