"""How to weigh real data whose residual is mostly what no model holds (issue 25): the
UR10 of ``bench_figaroh`` (the same data, ``--data`` the same way, the same splits),
fitted with vecpin's model of constant errors of every joint (a geometric calibration,
FIGAROH's model class) under two weightings:

* ``stated shape``: vecpin's default, the tracker's spherical noise and the joints'
  positioning noise (their shapes from the defaults) scaled to the level the residuals give;
* ``equal``: every coordinate of every pose weighted alike (an isotropic Cartesian noise,
  no positioning noise): FIGAROH's unweighted least squares.

Per split it prints the held-out mean of each (the split's test, which a user does not
have) beside what the training poses alone can say about the choice: the held-out mean of
each on the training poses' own folds (five interleaved folds by pose; each joint's low and
high ends, the outer 15 % of its measured positions, held out in turn), and the maximum
log-likelihood of the fit's residuals (whitened by the noise the fit used, at its solution)
with the stated shape scaled, with an isotropic part alone, and with both (the isotropic
part's share of the variance at the maximum).

Run: python benchmarks/bench_weighting.py [--data FILE] [--splits joint1 ...] [--out PAGE]
"""
from __future__ import annotations

import argparse
import copy
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import minimize, minimize_scalar

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_figaroh import _split, split_arguments, split_setting  # noqa: E402

END_SHARE = 0.15   # each end: the outer 15 % of a joint's measured positions in the training poses
FOLDS = 5


def weightings(machine) -> dict:
    from vecpin.measurement.noise import NoiseModel
    equal = NoiseModel.default(machine, "cartesian")
    equal.axis_sigma = np.zeros_like(equal.axis_sigma)
    return {"stated shape": NoiseModel.default(machine), "equal": equal}


def fit(machine, campaign, noise):
    from vecpin.workflows.fitting import fit_campaign
    return fit_campaign(machine, campaign, noise, kind="6dof", basis="chebyshev", order=0, noise_from_data=True).model


def heldout_mean(machine, train, test, noise) -> float:
    from vecpin.units import norm_mm
    return float(norm_mm(fit(machine, train, noise).residuals(test)).mean())


def folds_mean(machine, campaign, noise, labels: np.ndarray) -> float:
    """Mean held-out distance [mm] over the folds ``labels`` >= 0 (each fitted without it)."""
    from vecpin.units import norm_mm
    out = []
    for f in np.unique(labels[labels >= 0]):
        model = fit(machine, campaign.subset(labels != f), noise)
        out.append(norm_mm(model.residuals(campaign.subset(labels == f))))
    return float(np.concatenate(out).mean())


def end_labels(q: np.ndarray) -> np.ndarray:
    """0: a joint's low end, 1: its high end, -1: neither (``q`` one joint's positions)."""
    lo, hi = np.quantile(q, [END_SHARE, 1 - END_SHARE])
    return np.where(q < lo, 0, np.where(q > hi, 1, -1))


def log_likelihoods(machine, campaign, noise) -> tuple[float, float, float, float]:
    """(max log-likelihood with the stated shape scaled, with an isotropic part alone, with
    both, the isotropic part's share of the mean variance at the last) of the residuals of
    the fit under the stated noise ``noise`` (whitened w, the reading's whitened Jacobian
    to the point G: covariance s² I + t² G Gᵀ per pose)."""
    from vecpin.identification.likelihood import Likelihood
    model = fit(machine, campaign, noise)
    lik = Likelihood(model, campaign, model.noise_, setup=copy.deepcopy(model.setup_))
    ev = lik.evaluate(lik.theta_of(model), jacobian=False, operators=True)
    w, GG = ev.w, np.einsum("nij,nkj->nik", ev.Gw, ev.Gw)

    def nll(log_s2: float, log_t2: float) -> float:
        L = np.linalg.cholesky(math.exp(log_s2) * np.eye(3) + math.exp(log_t2) * GG)
        z = np.linalg.solve(L, w[..., None])[..., 0]
        return float(np.log(np.diagonal(L, axis1=1, axis2=2)).sum() + 0.5 * (z**2).sum())
    tiny = -60.0
    stated = minimize_scalar(lambda a: nll(a, tiny), bounds=(-10, 15), method="bounded")
    t0 = math.log(float(np.mean(w**2)) / float(np.mean(np.trace(GG, axis1=1, axis2=2)) / 3))
    iso = minimize_scalar(lambda b: nll(tiny, b), bounds=(t0 - 12, t0 + 12), method="bounded")
    both = min((minimize(lambda p: nll(*p), x0, method="Nelder-Mead", options={"xatol": 1e-4, "fatol": 1e-4})
                for x0 in ([stated.x, iso.x - 3], [stated.x - 3, iso.x])), key=lambda r: r.fun)
    s2, t2 = np.exp(both.x)
    share = float(t2 * np.trace(GG, axis1=1, axis2=2).mean() / (3 * s2 + t2 * np.trace(GG, axis1=1, axis2=2).mean()))
    return -stated.fun, -iso.fun, -both.fun, share


def run_split(split: str) -> dict:
    machine, train, held = _split(split)
    rng = np.random.default_rng(0)
    interleaved = rng.permutation(np.arange(len(train)) % FOLDS)
    row = {"train": len(train), "held": len(held)}
    for name, noise in weightings(machine).items():
        t = time.perf_counter()
        row[name] = {"split": heldout_mean(machine, train, held, noise),
                     "interleaved": folds_mean(machine, train, noise, interleaved),
                     "ends": [folds_mean(machine, train, noise, end_labels(train.q[:, j]))
                              for j in range(machine.n_axes)]}
        print(f"  {split} {name}: {row[name]['split']:.4f} mm held out ({time.perf_counter() - t:.0f} s)", flush=True)
    row["loglik"] = log_likelihoods(machine, train, weightings(machine)["stated shape"])
    return row


def page(rows: dict, source: str, axes: list[str]) -> str:
    head = ("# Real data: how to weigh what no model holds (UR10, ipa-robot-accuracy)\n\n"
            f"Written by `python benchmarks/bench_weighting.py` on {source} (module docstring: the two weightings, "
            "the folds). vecpin's model of constant errors of every joint; held-out mean distance, mm. The split's "
            "column is the test a user does not have; the others are what the training poses alone say.\n\n")
    out = ["| split | weighting | the split's held-out poses | training: interleaved folds | "
           + " | ".join(f"training: {a}'s ends" for a in axes) + " |",
           "|---|---|---|---|" + "---|" * len(axes)]
    for split, r in rows.items():
        for name in ("stated shape", "equal"):
            v = r[name]
            out.append(f"| {split} ({r['train']} / {r['held']}) | {name} | {v['split']:.4f} | {v['interleaved']:.4f} | "
                       + " | ".join(f"{e:.4f}" for e in v["ends"]) + " |")
    out += ["", "Maximum log-likelihood (natural log, up to one constant) of the training fit's residuals, whitened "
            "by the noise that fit used (the stated shape at the data's level):",
            "", "| split | stated shape, scaled | isotropic alone | both | the isotropic part's share at the maximum |",
            "|---|---|---|---|---|"]
    for split, r in rows.items():
        a, b, c, share = r["loglik"]
        out.append(f"| {split} | {a:.1f} | {b:.1f} ({b - a:+.1f}) | {c:.1f} ({c - a:+.1f}) | {100 * share:.1f} % |")
    return head + "\n".join(out) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    split_arguments(ap, "real_data_weighting")
    args = ap.parse_args()
    warnings.filterwarnings("ignore")
    source, out = split_setting(args, "real_data_weighting")
    rows = {}
    for split in args.splits:
        rows[split] = run_split(split)
    out.write_text(page(rows, source, _split(args.splits[0])[0].axis_names))
    print(f"written {out}")


if __name__ == "__main__":
    main()
