"""What the thermal terms leave 10 K away, split into its parts on the truth's side, each
set against vecpin's draws of that part alone: which part of the error left the
prediction understates or overstates (issue 44).

Per fresh seed, a truth and campaign of benchmarks/bench_thermal_truth.py (its docstring
gives the family; ``--amplitude`` the hall cycle). vecpin fits its terms
(:func:`vecpin.compensation.thermal.fit_thermal`); the error left at a steady temperature
10 K from the campaign's mean, judged with the arithmetic of that benchmark's judge
(tests/thermal_truth.py's ``judged``: the tip's displacement from where the geometric tables
leave it, the truth's tip averaged over the campaign's structure temperatures, over 40
commands; the terms' correction applied here from their published numbers, offset and slope
per kelvin about P0, as vectors so the parts can be told apart), is split three ways:

- the lag's part: the error left less the error left by the terms fitted at the truth's
  own lag (``lags=(true,)``);
- the curvature's part: the latter less the error left, at the truth's lag, on the same
  campaign (same commands, noise, hall) drawn from the truth without its curvature;
- the coefficients' part: that last one (noise and the geometry's trade alone).

Each part's mean length is placed among vecpin's draws of that part alone
(:func:`vecpin.compensation.thermal.remaining_mm` with the other parts zeroed: the
held-out spread less its lag share; the lag's standard deviation times the coefficients'
change per hour of lag, ``held_out['lag_gradient']``; the curvature's draws). An honest
part spreads these evenly over the quarters; the parts' norms do not add up to the whole's
(vectors), the whole is placed among the full draws.

``--per-term``: the curvature's part split per term as the truth bends it: X's, Y's, and
Z's with the tool's growth (on this machine the tool keeps its direction along Z: its
growth is Z's offset), each the error left at the truth's lag less the error left on the
same campaign drawn from the truth without that term's curvature, placed among vecpin's
draws of the curvature of the bent terms that carry it (X; Y; Z and ``tool_growth``).

Run: python benchmarks/bench_thermal_parts.py [--seeds 10] [--seed S] [--amplitude 6 8] [--per-term] [--out PAGE]
"""
from __future__ import annotations

import argparse
import secrets
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_thermal_truth import draw_truth  # noqa: E402
from thermal_truth import commands  # noqa: E402  (the independent truth)

import vecpin  # noqa: E402
from vecpin.compensation.thermal import fit_thermal, remaining_mm  # noqa: E402
from vecpin.measurement.campaign import Campaign  # noqa: E402
from vecpin.measurement.noise import NoiseModel  # noqa: E402
from vecpin.models import make_model  # noqa: E402

PAGE = Path(__file__).resolve().parents[1] / "docs" / "results" / "thermal_parts.md"
PARTS = ("whole", "lag", "curvature", "coefficients")


def campaign(m, seed: int, amplitude, flat=False):
    """(truth, campaign, rng after it) of bench_thermal_truth's family; ``flat``: the truth's curvature 0
    (True: every term's; a set of names, X, Y, Z or growth: those)."""
    rng = np.random.default_rng(seed)
    truth = draw_truth(m, rng)
    if flat:
        off = set(truth.nonlinear) | {"growth"} if flat is True else set(flat)
        truth = replace(truth, nonlinear={a: 0.0 if a in off else v for a, v in truth.nonlinear.items()},
                        growth_nonlinear=0.0 if "growth" in off else truth.growth_nonlinear)
    n = 160
    q, t = commands(m, n, rng), np.linspace(0, 10 * 3600, n)
    period, amp, drift = rng.uniform(5, 9) * 3600, rng.uniform(*amplitude), rng.uniform(-0.2, 0.2)
    air = 21 + amp * np.sin(2 * np.pi * t / period + rng.uniform(0, 2 * np.pi)) + drift * t / 3600
    tool = np.full(n, 0.12)
    xyz = truth.tip(m, q, tool, truth.structure(t, air)) + rng.normal(0, 3e-6, (n, 3))
    return truth, Campaign(m.axis_names, q, tool, xyz, extra={"time": t, "temperature": air}), rng


def left(m, truth, terms, camp, q, tool, tv) -> np.ndarray:
    """(N,3) [m] the error the terms leave at ``tv`` [°C]: their correction from their numbers
    (a d + b d (p - P0), um and mm) on the commands, judged by thermal_truth's judge's arithmetic."""
    qc, d = q.copy(), tv - terms.t0_c
    for a in terms.axes:
        i = m.axis(a).index
        p = q[:, i] * 1e3
        qc[:, i] -= (terms.offset_um_per_k[a] + terms.slope_um_per_m_per_k[a] * (p - terms.p0_mm[a]) * 1e-3) * d * 1e-6
    held = truth.structure(camp.time, camp.temperature)
    at = truth.tip(m, np.tile(q, (len(held), 1)), np.tile(tool, len(held)), np.repeat(held, len(q)))
    ref = at.reshape(len(held), len(q), 3).mean(axis=0)
    return truth.tip(m, qc, tool, np.full(len(q), tv)) - ref


def fitted(m, camp, lags=None):
    geo = make_model("6dof", m, 2).fit(camp, NoiseModel.default(m, "spherical"))
    return fit_thermal(geo, camp, lags=lags)[0]


def part_draws(terms, m, q, tool, tv) -> dict:
    """Per part, vecpin's draws [mm] of that part alone."""
    h = terms.held_out
    g = np.asarray(h.get("lag_gradient", np.zeros(len(h["names"]))))
    lag = h.get("lag_std_h", 0.0) ** 2 * np.outer(g, g)
    zero = np.zeros_like(lag)
    one = lambda cov, curv: remaining_mm(replace(terms, held_out=dict(h, cov=cov.tolist()), curvature=curv),  # noqa
                                         m, q, tool, tv).draws
    return {"whole": remaining_mm(terms, m, q, tool, tv).draws, "lag": one(lag, {}),
            "curvature": one(zero, terms.curvature), "coefficients": one(np.asarray(h["cov"]) - lag, {})}


TERMS = {"X": ({"X"}, ["X"]), "Y": ({"Y"}, ["Y"]), "Z+growth": ({"Z", "growth"}, ["Z", "tool_growth"])}


def term_parts(m, seed, amplitude, terms, at_lag, true_lag, q, tool, tv) -> dict:
    """Per term of :data:`TERMS`: (the truth's curvature part of it [um], vecpin's draws' median [um], place)."""
    from vecpin.compensation.thermal import DRAWS, _only, tip_errors
    from vecpin.compensation.thermalheld import bend_terms, curvature_draws
    c = terms.curvature
    d = tv - terms.t0_c
    bend = d ** 2 - c["alpha"][0] - c["alpha"][1] * d
    names, per_k, cov = bend_terms(c)
    kappa = curvature_draws(per_k, cov, np.random.default_rng(0), DRAWS)
    out = {}
    for key, (truth_names, bent) in TERMS.items():
        t2, c2, _ = campaign(m, seed, amplitude, flat=truth_names)
        um = float(np.linalg.norm(at_lag - left(m, t2, fitted(m, c2, (true_lag,)), c2, q, tool, tv), axis=1).mean())
        e = sum(np.einsum("ni,d->dni", tip_errors(_only(terms, nm, c.get("growth_axis")), m, q, tool,
                                                  terms.t0_c + bend), kappa[:, names.index(nm)])
                for nm in bent if nm in names)
        dr = np.linalg.norm(e, axis=2).mean(axis=1) * 1e6
        out[key] = (um * 1e6, float(np.median(dr)), float(np.mean(dr < um * 1e6)))
    return out


def one_seed(m, seed: int, amplitude, per_term: bool = False) -> dict:
    truth, camp, rng = campaign(m, seed, amplitude)
    terms = fitted(m, camp)
    tv = terms.t0_c + 10.0 * rng.choice([-1.0, 1.0])
    q = commands(m, 40, rng)
    tool = np.full(len(q), 0.12)
    true_lag = round(truth.lag_s / 3600, 3)
    whole = left(m, truth, terms, camp, q, tool, tv)
    at_lag = left(m, truth, fitted(m, camp, (true_lag,)), camp, q, tool, tv)
    flat_truth, flat_camp, _ = campaign(m, seed, amplitude, flat=True)
    flat = left(m, flat_truth, fitted(m, flat_camp, (true_lag,)), flat_camp, q, tool, tv)
    size = {"whole": whole, "lag": whole - at_lag, "curvature": at_lag - flat, "coefficients": flat}
    draws = part_draws(terms, m, q, tool, tv)
    out = {"seed": seed, "lag_z": (terms.lag_h - truth.lag_s / 3600) / max(terms.held_out.get("lag_std_h", 0), 1e-9)}
    for k in PARTS:
        um = float(np.linalg.norm(size[k], axis=1).mean() * 1e6)
        out[k] = (um, float(np.median(draws[k])) * 1e3, float(np.mean(draws[k] * 1e3 < um)))
    if per_term:
        out["terms"] = term_parts(m, seed, amplitude, terms, at_lag, true_lag, q, tool, tv)
    return out


def page(rows, base: int, amplitude) -> str:
    quarters = {k: np.histogram([r[k][2] for r in rows], bins=[0, 0.25, 0.5, 0.75, 1.0])[0] for k in PARTS}
    lines = ["# The error the thermal terms leave, part by part, against vecpin's draws", "",
             f"Written by `benchmarks/bench_thermal_parts.py` (its docstring gives the split); this run drew seeds "
             f"{base}..{base + len(rows) - 1}, the hall cycling {amplitude[0]:g}..{amplitude[1]:g} K. Each part's "
             "mean length [um] beside the median of vecpin's draws of it, and where it falls among them (an honest "
             "part spreads evenly over the quarters).", "",
             "| part | quarters 0-25 / 25-50 / 50-75 / 75-100 % | median truth [um] | median of draws' medians [um] |",
             "|---|---|---|---|"]
    lines += [f"| {k} | {' / '.join(str(v) for v in quarters[k])} | {np.median([r[k][0] for r in rows]):.1f} | "
              f"{np.median([r[k][1] for r in rows]):.1f} |" for k in PARTS]
    z = np.array([r["lag_z"] for r in rows])
    lines += ["", f"The lag off the truth in its stated standard deviations: RMS {np.sqrt(np.mean(z ** 2)):.2f}.", "",
              "| seed | " + " | ".join(f"{k} [um] (draws' median, place)" for k in PARTS) + " |",
              "|---|" + "---|" * len(PARTS)]
    lines += [f"| {r['seed']} | " + " | ".join(f"{r[k][0]:.1f} ({r[k][1]:.1f}, {r[k][2]:.0%})" for k in PARTS) + " |"
              for r in rows]
    if all("terms" in r for r in rows):
        lines += ["", "The curvature's part per term (`--per-term`: the docstring gives the split): the truth's part "
                  "[um] placed among vecpin's draws of the bent terms that carry it.", "",
                  "| term | quarters 0-25 / 25-50 / 50-75 / 75-100 % | mean place | median truth [um] | "
                  "median of draws' medians [um] |", "|---|---|---|---|---|"]
        for t in TERMS:
            place = [r["terms"][t][2] for r in rows]
            q4 = np.histogram(place, bins=[0, 0.25, 0.5, 0.75, 1.0])[0]
            lines.append(f"| {t} | {' / '.join(str(v) for v in q4)} | {np.mean(place):.0%} | "
                         f"{np.median([r['terms'][t][0] for r in rows]):.1f} | "
                         f"{np.median([r['terms'][t][1] for r in rows]):.1f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--seed", type=int, default=None, help="first seed (default: fresh)")
    ap.add_argument("--amplitude", type=float, nargs=2, default=(6.0, 8.0), help="the hall cycle's amplitude [K]")
    ap.add_argument("--per-term", action="store_true", help="split the curvature's part per term (three more fits)")
    ap.add_argument("--out", type=Path, default=PAGE)
    args = ap.parse_args(argv)
    base = args.seed if args.seed is not None else secrets.randbelow(10 ** 6)
    m = vecpin.Machine.load("trunnion_xyzac")
    rows = []
    for k in range(args.seeds):
        rows.append(one_seed(m, base + k, tuple(args.amplitude), args.per_term))
        print(f"seed {base + k}: " + ", ".join(f"{p} {rows[-1][p][0]:.1f} um ({rows[-1][p][2]:.0%})" for p in PARTS),
              flush=True)
    text = page(rows, base, tuple(args.amplitude))
    print(text)
    args.out.write_text(text, encoding="utf-8")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
