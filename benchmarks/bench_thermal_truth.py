"""Thermal terms on fresh truths outside vecpin's thermal model (issue 44), through the
controllers' files read back by the tests' independent readers.

Each run draws fresh seeds (or takes ``--seed``); per seed a truth of
tests/thermal_truth.py: the structure lags the air by 0.6..3.5 h (vecpin scans 0, 0.5,
1, 2, 4 h and refines between), per axis an offset of ±10 um/K, an expansion of 6..16
ppm/K about its own centre and a curvature (a common -1.5..1.5 %/K plus ±0.5 %/K per
axis), a tool growing 0..10 um/K; a 10 h campaign of 160 rows on the trunnion machine
(3 um tracker noise per coordinate) while the hall cycles 2..4 K over 5..9 h and drifts
±0.2 K/h (``--amplitude 6 8``: the wider hall cycle, its page ``--out
docs/results/thermal_truth_wide.md``). vecpin fits its terms
(:func:`vecpin.compensation.thermal.fit_thermal`: the lag refined with the curvature free) and
writes one controller's files (the seeds cycle through Siemens 840D, Beckhoff, Heidenhain,
Fanuc, LinuxCNC's HAL component); the reader turns them into the correction; 40 fresh commands run on the truth at
a steady temperature 10 K above or below the campaign's mean. Judged: the tip's mean
displacement from where the geometric tables leave it (the truth's tip averaged over the
campaign's structure temperatures: a least-squares geometry takes up the thermal error's
mean over its campaign, a curvature's included), without and with the terms, against vecpin's prediction
(:func:`vecpin.compensation.thermal.remaining_mm`: the point figure, the chance vecpin
gives it of holding to 20 %, the 5..95 % band). The share of seeds within 20 % of the
point is set beside the mean chance vecpin stated (an honest chance matches it), with
the tolerance vecpin says its point holds to 4 times in 5 (what is reachable) and the
share of seeds within it.

Run: python benchmarks/bench_thermal_truth.py [--seeds 24] [--seed S] [--amplitude 2 4] [--out PAGE]
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
from scipy.stats import binomtest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from thermal_truth import READERS, Truth, commands, corrected, judged  # noqa: E402  (the independent judges)

import vecpin  # noqa: E402
from vecpin.compensation.thermal import fit_thermal, point_within, remaining_mm  # noqa: E402
from vecpin.compensation.thermalheld import bend_terms  # noqa: E402
from vecpin.export import linuxcnc, thermal, thermal_linuxcnc  # noqa: E402
from vecpin.export.profile import ControllerProfile  # noqa: E402
from vecpin.fileio import OutputSet  # noqa: E402
from vecpin.measurement.campaign import Campaign  # noqa: E402
from vecpin.measurement.noise import NoiseModel  # noqa: E402
from vecpin.models import make_model  # noqa: E402

PAGE = Path(__file__).resolve().parents[1] / "docs" / "results" / "thermal_truth.md"
STEP_K = 10.0
HOLDS = 0.8     # the chance at which the reachable tolerance is stated


def reachable(draws) -> tuple[float, float]:
    """(the smallest relative tolerance w, on a 0.05 grid, at which a point holds with
    :data:`HOLDS` of the ``draws`` within w of it; that point)."""
    for w in np.arange(0.2, 5.0, 0.05):
        point, share = point_within(draws, w)
        if share >= HOLDS:
            return float(w), point
    return float("inf"), float(np.median(draws))


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


def one(m, seed: int, controller: str, amplitude=(2.0, 4.0)) -> dict:
    """Draw, measure, fit, write, read back and judge one seed."""
    rng = np.random.default_rng(seed)
    truth = draw_truth(m, rng)
    n = 160
    q = commands(m, n, rng)
    t = np.linspace(0, 10 * 3600, n)
    period, amp, drift = rng.uniform(5, 9) * 3600, rng.uniform(*amplitude), rng.uniform(-0.2, 0.2)
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
            if controller == "linuxcnc":
                joints = linuxcnc.joint_numbers(m, ControllerProfile())
                thermal_linuxcnc.write(terms, m, joints, max(joints.values()) + 1, out, chained=False)
            else:
                thermal.write(controller, terms, ControllerProfile(), out)
        without, left = judged(m, truth, qv, toolv, corrected(m, qv, Path(tmp), controller, tv), tv,
                               truth.structure(t, air))
    pred = remaining_mm(terms, m, qv, toolv, tv)
    straight = remaining_mm(replace(terms, curvature={}), m, qv, toolv, tv)
    reach, reach_point = reachable(pred.draws * 1e3)
    names, kappa, cov = bend_terms(terms.curvature)
    return {"seed": seed, "controller": controller, "lag_true": truth.lag_s / 3600, "lag": terms.lag_h,
            "lag_std": terms.held_out.get("lag_std_h", 0.0),
            "kappa_true": [truth.nonlinear.get(nm, truth.growth_nonlinear) for nm in names], "bent": names,
            "kappa": list(kappa), "kappa_std": list(np.sqrt(np.diag(cov))),
            "kappa_common": float(1 / np.sqrt(np.sum(np.linalg.inv(cov)))),
            "step": tv - terms.t0_c, "without": without * 1e6, "with": left * 1e6, "expected": pred.expected * 1e3,
            "low": pred.low * 1e3, "high": pred.high * 1e3, "straight": straight.expected * 1e3, "seconds": seconds,
            "point": pred.point * 1e3, "median": float(np.median(pred.draws)) * 1e3, "chance": pred.chance,
            "pit": float(np.mean(pred.draws < left * 1e3)),
            "reach": reach, "reach_point": reach_point, "span": float(np.ptp(air))}


def share(k: int, n: int) -> str:
    """``k/n`` with its 95 % (Wilson) interval."""
    ci = binomtest(k, n).proportion_ci(0.95, method="wilson")
    return f"{k}/{n} ({k / n:.0%}, 95 % interval {ci.low:.0%} .. {ci.high:.0%})"


def skew(quarters, n: int) -> str:
    """Words when an outer quarter of the draws holds the error left too often for an even
    spread (one-sided binomial test against a quarter, p < 0.01)."""
    for k, words in ((3, "the draws run low: vecpin understates the error left"),
                     (0, "the draws run high: vecpin overstates the error left")):
        if binomtest(int(quarters[k]), n, 0.25, alternative="greater").pvalue < 0.01:
            return f"; {words} ({quarters[k]}/{n} in the {'top' if k else 'bottom'} quarter)"
    return ""


def summary(rows: list[dict]) -> list[str]:
    n = len(rows)
    near = lambda r, key, w=0.2: abs(r["with"] / r[key] - 1) <= w   # noqa: E731
    inband = sum(0.8 * r["low"] <= r["with"] <= 1.2 * r["high"] for r in rows)
    strict = sum(r["low"] <= r["with"] <= r["high"] for r in rows)
    low = sum(r["with"] < 0.8 * r["low"] for r in rows)
    smaller = sum(r["with"] < r["without"] for r in rows)
    ratio = np.array([r["with"] / r["without"] for r in rows])
    pit = np.array([r["pit"] for r in rows])
    quarters = np.histogram(pit, bins=[0, 0.25, 0.5, 0.75, 1.0])[0]
    over = sum(r["with"] < r["point"] for r in rows)
    reach = np.array([r["reach"] for r in rows])
    hits = sum(near(r, "point") for r in rows)
    lag_z = np.array([(r["lag"] - r["lag_true"]) / r["lag_std"] for r in rows if r["lag_std"] > 0])
    chance = [r["chance"] for r in rows]
    return [f"- the error left within 20 % of vecpin's point figure: **{share(hits, n)}**; the chance vecpin stated "
            f"for it: mean {np.mean(chance):.0%} (range "
            f"{min(r['chance'] for r in rows):.0%} .. {max(r['chance'] for r in rows):.0%}); the point above the error "
            f"left on {over}/{n}",
            f"- what is reachable: the tolerance at which vecpin says its point holds 4 times in 5: median "
            f"±{np.median(reach):.0%} (range ±{reach.min():.0%} .. ±{reach.max():.0%}); the error left within it: "
            f"**{share(sum(near(r, 'reach_point', r['reach']) for r in rows), n)}**",
            f"- where the error left falls among vecpin's draws (an honest prediction spreads these evenly): quarters "
            f"{' / '.join(str(q) for q in quarters)} (0-25 % / 25-50 % / 50-75 % / 75-100 %){skew(quarters, n)}",
            f"- the error left within 20 % of the predicted band (0.8 x low .. 1.2 x high): {share(inband, n)} (inside "
            f"the band itself: {strict}/{n}); below it {low}, above it {n - inband - low}",
            f"- the error left smaller than without the terms: **{share(smaller, n)}** (median {np.median(ratio):.1%} "
            f"of it, worst {ratio.max():.1%})",
            f"- within 20 % of other point figures: the draws' mean {sum(near(r, 'expected') for r in rows)}/{n}, "
            f"their median {sum(near(r, 'median') for r in rows)}/{n}, the mean without the curvature's bound "
            f"(straight terms trusted 10 K away) {sum(near(r, 'straight') for r in rows)}/{n}",
            f"- the lag off the truth in its stated standard deviations (an honest one: RMS 1): RMS "
            f"{rms(lag_z) if len(lag_z) else float('nan'):.2f}, within two on "
            f"{int(np.sum(np.abs(lag_z) <= 2))}/{len(lag_z)} (refined ones)",
            f"- fit time (geometry, lag scan and refinement, held-out blocks, curvature): median "
            f"{np.median([r['seconds'] for r in rows]):.2f} s per campaign"]


WHY = ("Why 20 % is out of reach from such a campaign: the error the terms leave 10 K away is one draw of the "
       "coefficients' error plus the curvature the straight terms cannot follow, and a campaign over this hall "
       "cycle bounds a curvature common to all terms only to ±{k:.1f} %/K (the median standard deviation over these "
       "seeds; each term's own: ±{each:.1f} %/K), which 10 K away is that share per kelvin of the whole thermal "
       "gain, times ten: a median {c:.0f} um here, against a median error left of {left:.0f} um. vecpin fits a "
       "curvature per term (each linear axis, the tool's growth where it is a term of its own; where the tool "
       "keeps its direction along an axis, as here along Z, that axis' offset carries the growth and bends as the "
       "growth, its slope as the axis) and draws them from a normal hierarchy, a curvature common to the terms and "
       "each term's own deviation from it, both scales with "
       "the scale-free prior (uniform in log) on a grid about the campaign's own resolution, nothing taken from this"
       " truth family: what the campaign resolves is drawn around its estimate, what it does not is shrunk towards "
       "the common curvature and that towards none (drawn around their estimates alone, the draws overstate an "
       "unresolved curvature); the coefficients' error, a covariance from 5 time blocks held out (the curvature "
       "held at the campaign's estimate in those fits: the curvature's draws count its misfit, once), is drawn as "
       "Student's t, and the lag's error beside it (the lag refined with the curvature free: a curvature moves the "
       "lag a fit without it finds). "
       "The controllers' forms are straight in T: the curvature is not written, and the figures are those of the "
       "written straight terms. vecpin's point is the figure its draws put most often within 20 %, and that share "
       "is the chance it prints beside the point and the band. An honest chance matches the share of fresh truths "
       "within 20 % (first line), and the error left then falls evenly among the draws (third line, which says "
       "when it does not). A wider temperature span resolves more of the curvature and raises the chance "
       "(`--amplitude`).")


def curvatures(r: dict) -> str:
    """The bent terms' curvatures [%/K], true / fitted ± sd, one term after another."""
    return "; ".join(f"{nm} {t * 100:+.1f} / {k * 100:+.1f} ± {s * 100:.1f}"
                     for nm, t, k, s in zip(r["bent"], r["kappa_true"], r["kappa"], r["kappa_std"]))


def rms(values) -> float:
    return float(np.sqrt(np.mean(np.square(values))))


def page(rows: list[dict], base: int, amplitude) -> str:
    head = ("| seed | controller | lag true / fitted ± sd [h] | curvature true / fitted ± sd [%/K] | step [K] | "
            "without [um] | left [um] | point [um] (chance) | band [um] | holds 4 in 5 to | left among draws |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|")
    body = [f"| {r['seed']} | {r['controller']} | {r['lag_true']:.2f} / {r['lag']:.2f} ± {r['lag_std']:.2f} | "
            f"{curvatures(r)} | "
            f"{r['step']:+.0f} | {r['without']:.1f} | {r['with']:.1f} | {r['point']:.1f} ({r['chance']:.0%}) | "
            f"{r['low']:.1f} .. {r['high']:.1f} | ±{r['reach']:.0%} | {r['pit']:.0%} |" for r in rows]
    return "\n".join(["# Thermal terms on fresh truths outside vecpin's model", "",
                      "Written by `benchmarks/bench_thermal_truth.py` (its docstring gives the truth family and the "
                      f"judging); this run drew seeds {base}..{base + len(rows) - 1}: every run draws fresh ones. The "
                      f"hall cycled {amplitude[0]:g}..{amplitude[1]:g} K (amplitude) during the campaigns: the "
                      f"campaigns spanned {np.median([r['span'] for r in rows]):.1f} K (median). Every figure in um "
                      "is the tool tip's displacement relative to the table (on this machine the same length as in "
                      "the base frame: the table carries no thermal error), its 3D length averaged over the 40 "
                      "commands, no translation removed, from where the geometric tables leave it: the frame "
                      "vecpin names beside its figures.", "",
                      *summary(rows), "", WHY.format(k=np.median([r["kappa_common"] for r in rows]) * 100,
                                                     each=np.median([rms(r["kappa_std"]) for r in rows]) * 100,
                                                     c=np.median([r["kappa_common"] * 10 * r["without"]
                                                                  for r in rows]),
                                                     left=np.median([r["with"] for r in rows])), "", head,
                      *body, ""])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=24)
    ap.add_argument("--seed", type=int, default=None, help="first seed (default: fresh)")
    ap.add_argument("--amplitude", type=float, nargs=2, default=(2.0, 4.0), help="the hall cycle's amplitude [K]")
    ap.add_argument("--out", type=Path, default=PAGE)
    args = ap.parse_args(argv)
    base = args.seed if args.seed is not None else secrets.randbelow(10 ** 6)
    m = vecpin.Machine.load("trunnion_xyzac")
    names = list(READERS)
    rows = []
    for k in range(args.seeds):
        r = one(m, base + k, names[k % len(names)], tuple(args.amplitude))
        rows.append(r)
        print(f"seed {r['seed']} {r['controller']:10s} lag {r['lag_true']:.2f}/{r['lag']:.2f} h  without "
              f"{r['without']:6.1f} um  left {r['with']:5.1f} um  point {r['point']:5.1f} um ({r['chance']:.0%}) "
              f"band {r['low']:.1f} .. {r['high']:.1f} um", flush=True)
    print("\n".join(summary(rows)))
    args.out.write_text(page(rows, base, args.amplitude), encoding="utf-8")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
