"""Diagnosing the sim-to-real gap: where the residual lies, which unmodelled effect
causes it, and how far it shrinks once that effect is added.

1. **Where.** Held-out residuals (k-fold cross-validation grouped by command, so no
   row judges a model it helped fit) broken down along each axis, against time and
   temperature, per tool and in space, with tests of whether each breakdown is more
   structured than the noise model explains.
2. **Which.** Every candidate effect (:mod:`vecpin.effects`, with every choice of
   axes) is added to the base model and scored on held-out data and by an F-test of
   its chi-square reduction (robust to a misjudged noise scale), with a Bonferroni
   correction over the candidates of the round. The best significant one is accepted
   and the rest re-scored against the improved model (forward selection). Gross
   errors (outliers) are flagged first and the base refitted without them.
3. **How far.** Held-out mean/max before and after each accepted effect.

Scoring uses the least-squares problem linearised at the fitted base model: the
models are linear in their parameters to about 1e-4, so cross-validation becomes a
few small solves per candidate (fold k: the normal equations less that fold's rows).
The accepted effects are then fitted for real (nonlinear ML) into the best model.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
from scipy import linalg, stats

from vecpin.errors import InputError, VecpinError
from vecpin.fileio import OutputSet
from vecpin.identification.crossval import Linearised, command_folds
from vecpin.identification.likelihood import predict_tracker
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.features import Features
from vecpin.measurement.noise import NoiseModel
from vecpin.models import ErrorModel
from vecpin.models.effects import REGISTRY, Effect
from vecpin.selection.choice import choose_or_fix


# ---------------------------------------------------------------------- results
@dataclass
class EffectScore:
    name: str
    label: str
    axes: list[str]
    n_parameters: int
    delta_chi2: float
    f_statistic: float
    p_value: float
    threshold: float
    heldout_mean_mm_before: float
    heldout_mean_mm_after: float
    heldout_max_mm_before: float
    heldout_max_mm_after: float
    significant: bool = False
    round: int = 1
    evidence: str = ""
    bic_gain: float = float("nan")
    effect: Effect | None = field(default=None, repr=False)

    @property
    def shrink_pct(self) -> float:
        return 100.0 * (1 - self.heldout_mean_mm_after / self.heldout_mean_mm_before)

    def to_dict(self) -> dict:
        return {"name": self.name, "label": self.label, "axes": self.axes, "significant": bool(self.significant),
                "heldout_mean_mm_before": self.heldout_mean_mm_before, "heldout_mean_mm_after": self.heldout_mean_mm_after,
                "heldout_max_mm_before": self.heldout_max_mm_before, "heldout_max_mm_after": self.heldout_max_mm_after,
                "shrink_pct": self.shrink_pct, "evidence": self.evidence, "n_parameters": self.n_parameters,
                "delta_chi2": self.delta_chi2, "f_statistic": self.f_statistic, "p_value": self.p_value,
                "p_threshold": self.threshold, "round": self.round, "bic_gain": self.bic_gain,
                "options": self.effect.options if self.effect is not None else {}}


@dataclass
class Diagnosis:
    machine: Machine
    base: dict
    effects: list[EffectScore]
    outlier_rows: list[int]
    localization: dict
    base_model: ErrorModel
    best_model: ErrorModel
    heldout_base: np.ndarray          # (N,3) m, held-out residuals of the base model
    campaign: Campaign
    seconds: float
    best: tuple[float, float] = (float("nan"), float("nan"))  # held-out mean/max [mm] of the best model

    @property
    def accepted(self) -> list[EffectScore]:
        return [e for e in self.effects if e.significant]

    def to_dict(self) -> dict:
        return {"base": self.base, "effects": [e.to_dict() for e in self.effects], "outlier_rows": self.outlier_rows,
                "localization": self.localization, "best": {"effects": [e.label for e in self.accepted],
                                                            "heldout_mean_mm": self.best_heldout()[0],
                                                            "heldout_max_mm": self.best_heldout()[1]},
                "seconds": self.seconds}

    def best_heldout(self) -> tuple[float, float]:
        return self.best

    def summary(self) -> str:
        b = self.base
        lines = [f"base model {b['label']}: held-out mean {b['heldout_mean_mm']:.4f} mm, max {b['heldout_max_mm']:.4f} mm "
                 f"({b['folds']}-fold CV over {b['rows']} rows)"]
        if self.outlier_rows:
            lines.append(f"outliers: rows {', '.join(map(str, self.outlier_rows))} (0-based) flagged and left out")
        lines.append(f"  {'rank':>4s} {'effect':<34s} {'sig':>3s} {'before':>8s} {'after':>8s} {'shrink':>7s} {'p':>9s}")
        for k, e in enumerate(self.effects[:12], 1):
            lines.append(f"  {k:4d} {e.label:<34s} {'yes' if e.significant else 'no':>3s} {e.heldout_mean_mm_before:8.4f} "
                         f"{e.heldout_mean_mm_after:8.4f} {e.shrink_pct:6.1f}% {e.p_value:9.2e}")
        for e in self.accepted:
            lines.append(f"accepted: {e.label}: {e.evidence}")
        m, x = self.best_heldout()
        lines.append(f"best model: held-out mean {m:.4f} mm, max {x:.4f} mm "
                     f"({100 * (1 - m / b['heldout_mean_mm']):.1f}% below the base)")
        return "\n".join(lines)

    def write(self, out_dir: str | Path) -> dict[str, Path]:
        """diagnosis.json, model_base.json, model_best.json, report.md and figures/,
        committed together (an interruption leaves the previous set)."""
        import json

        from vecpin.diagnosis.report import write_report
        with OutputSet(out_dir) as out:
            paths = {"diagnosis": out.write_text("diagnosis.json", json.dumps(self.to_dict(), indent=1, default=float))}
            self.base_model.save(out.path("model_base.json"))
            self.best_model.save(out.path("model_best.json"))
            paths["model_base"], paths["model_best"] = out.final("model_base.json"), out.final("model_best.json")
            paths["report"] = write_report(self, out)
        return paths


# ---------------------------------------------------------------------- localisation
def _breakdown(values: np.ndarray, held_mm: np.ndarray, held_w: np.ndarray, n_bins: int, label: str,
               unit: str, categorical: bool = False) -> dict:
    """Bins of a coordinate: residual size and mean vector per bin, and tests."""
    phi = float(np.mean(np.sum(held_w**2, axis=1)) / 3.0)  # overall dispersion (1 if the noise model holds)
    if categorical:
        keys = np.unique(values)
        idx = np.searchsorted(keys, values)
        edges = None
    else:
        lo, hi = float(values.min()), float(values.max())
        edges = np.linspace(lo, hi, n_bins + 1)
        idx = np.clip(np.searchsorted(edges, values, side="right") - 1, 0, n_bins - 1)
        keys = np.arange(n_bins)
    bins, systematic, dof = [], 0.0, 0
    for k in range(len(keys)):
        sel = idx == k
        n = int(sel.sum())
        if n == 0:
            continue
        wbar = held_w[sel].mean(axis=0)
        stat = n * float(wbar @ wbar)                       # ~ chi2(3) * phi under no structure
        chi2 = float(np.sum(held_w[sel] ** 2))              # ~ chi2(3n) under the noise model
        systematic += stat
        dof += 3
        entry = {"n": n, "mean_mm": float(np.linalg.norm(held_mm[sel], axis=1).mean()),
                 "mean_vector_mm": [float(v) for v in held_mm[sel].mean(axis=0)],
                 "chi2": chi2, "chi2_expected": 3 * n, "p_noise": float(stats.chi2.sf(chi2, 3 * n))}
        if categorical:
            entry["value"] = float(keys[k])
        else:
            entry["from"], entry["to"] = float(edges[k]), float(edges[k + 1])
        bins.append(entry)
    # trend: regress each whitened component on the standardised coordinate
    x = (values - values.mean()) / (values.std() + 1e-300)
    slope = (x @ held_w) / (x @ x) if x @ x > 0 else np.zeros(3)
    trend = float(slope @ slope * (x @ x)) / phi
    p_trend = float(stats.chi2.sf(trend, 3))
    p_sys = float(stats.chi2.sf(systematic / phi, max(dof - 3, 1)))
    return {"coordinate": label, "unit": unit, "bins": bins, "systematic_chi2": systematic / phi,
            "systematic_dof": max(dof - 3, 1), "p_systematic": p_sys, "trend_chi2": trend, "p_trend": p_trend,
            "dispersion": phi}


def localise(machine: Machine, campaign: Campaign, held_mm: np.ndarray, held_w: np.ndarray, tips: np.ndarray,
             n_bins: int = 8, alpha: float = 0.01, feats: Features | None = None) -> dict:
    """Breakdowns of held-out residuals; each says whether it is structured."""
    out = {}
    feats = feats or Features.from_campaign(campaign)
    for a in machine.axes:
        out[f"axis:{a.name}"] = _breakdown(a.to_user(campaign.q[:, a.index]), held_mm, held_w, n_bins, a.name, a.unit)
    for a in machine.axes:
        d = feats.direction[:, a.index]
        if len(np.unique(d)) > 1:
            out[f"direction:{a.name}"] = _breakdown(d, held_mm, held_w, 0, f"approach direction of {a.name}", "",
                                                    categorical=True)
    if campaign.time is not None:
        out["time"] = _breakdown(campaign.time, held_mm, held_w, n_bins, "time", "s")
    if campaign.temperature is not None:
        out["temperature"] = _breakdown(campaign.temperature, held_mm, held_w, n_bins, "temperature", "degC")
    out["tool"] = _breakdown(campaign.tool * 1e3, held_mm, held_w, 0, "tool", "mm", categorical=True)
    out["row order"] = _breakdown(np.arange(len(campaign), dtype=float), held_mm, held_w, n_bins, "row", "")
    for k, c in enumerate("xyz"):
        out[f"space:{c}"] = _breakdown(tips[:, k] * 1e3, held_mm, held_w, n_bins, f"tool tip {c} (machine frame)", "mm")
    m = len(out)
    for v in out.values():
        v["structured"] = bool(min(v["p_systematic"], v["p_trend"]) < alpha / m)
    ranked = sorted(out, key=lambda k: -out[k]["systematic_chi2"] / out[k]["systematic_dof"])
    return {"breakdowns": out, "most_structured": ranked[:5],
            "note": "held-out (k-fold CV) residuals; chi2 of bin means over the overall dispersion; "
                    "'structured' when the bin-mean or trend test is below alpha/number of breakdowns"}


# ---------------------------------------------------------------------- the diagnosis
def _evidence(effect: Effect, score: EffectScore, loc: dict) -> str:
    top = loc["most_structured"][0]
    b = loc["breakdowns"][top]
    where = f"; the base residual is most structured along {top} (bin-mean chi2/dof " \
            f"{b['systematic_chi2'] / b['systematic_dof']:.1f})"
    return (f"adding {effect.label} ({score.n_parameters} terms) cuts chi2 by {score.delta_chi2:.0f} "
            f"(F = {score.f_statistic:.1f}, p = {score.p_value:.1e} < {score.threshold:.1e}) and the held-out mean by "
            f"{score.shrink_pct:.1f}%{where}")


def candidate_effects(machine: Machine, feats: Features, names) -> list[Effect]:
    """Every candidate instance of the named effects (row-flagging effects excluded)."""
    out = []
    for name in names:
        if name not in REGISTRY:
            raise InputError(f"unknown effect '{name}' (known: {', '.join(REGISTRY)})")
        if not REGISTRY[name].flags_rows:
            out += REGISTRY[name].candidates(machine, feats)
    return out


def _effect_columns(model: ErrorModel, lin: Linearised, effect: Effect, camp: Campaign, feats: Features,
                    prior: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ψ-scaled columns (A, J) of a candidate effect's parameters at the current fit."""
    k = effect.n_parameters
    A = np.zeros(lin.r.shape + (k,))
    J = np.zeros_like(A)
    if "tracker" in effect.kinds:  # acts on the measured point only: no kinematics needed
        a, j = lin.tracker_columns(effect.tracker(np.nan_to_num(lin.y), feats), prior)
        A, J = A + a, J + j
    if "command" in effect.kinds or "tip" in effect.kinds:
        trial = model.with_effects(model.effects + [effect])
        b = np.r_[model.b_, np.zeros(k)]
        D = trial.tool_tip(camp.q, camp.tool, b, jacobian=True, features=feats).J_b[:, :, -k:]
        a, j = lin.point_columns(D, prior)
        A, J = A + a, J + j
    return A, J


def _score(lin: Linearised, base: tuple, cand_cols: tuple, folds: np.ndarray, base_eval: dict,
           base_grams: dict | None = None) -> dict:
    A0, J0, psi0 = base
    A1, J1 = cand_cols
    A = np.concatenate([A0, A1], axis=-1)
    J = np.concatenate([J0, J1], axis=-1)
    psi = np.r_[psi0, np.zeros(A1.shape[-1])]
    grams = lin.extend_grams(base_grams, J0, J1, folds) if base_grams is not None else None
    ev = lin.evaluate(A, J, psi, folds, grams)
    d_chi2 = base_eval["chi2"] - ev["chi2"]
    k = max(ev["p_eff"] - base_eval["p_eff"], 0.5)
    dof = max(lin.n_equations - ev["p_eff"], 1.0)
    F = (d_chi2 / k) / (ev["chi2"] / dof)
    ev.update(d_chi2=d_chi2, k=k, F=F, p=float(stats.f.sf(F, k, dof)) if F > 0 else 1.0)
    return ev


def flag_outliers(lin: Linearised, folds: np.ndarray, base_eval: dict, p: float = 1e-3) -> np.ndarray:
    """Rows whose held-out whitened residual is too large to be noise, judged against
    the robust (median) dispersion of all rows, Bonferroni over the rows."""
    s = np.sum(base_eval["heldout_w"] ** 2, axis=1)
    scale = np.median(s) / stats.chi2.median(3)
    limit = stats.chi2.isf(p / len(s), 3)
    return np.flatnonzero(s / scale > limit)


def diagnose(machine: Machine, campaign: Campaign, model: str = "auto", order: int | str = "auto", effects="all",
             noise: NoiseModel | None = None, folds: int = 5, alpha: float = 0.01, max_effects: int = 4,
             basis: str = "auto", seed: int = 0, min_shrink_pct: float = 2.0,
             progress: Callable[[str], None] | None = None) -> Diagnosis:
    """Run the diagnosis; see the module docstring. The base model is the one the data
    choose (:func:`vecpin.selection.choice.choose_or_fix`; ``model``, ``basis`` and
    ``order`` fix any of it). An effect is accepted when its F-test passes ``alpha`` /
    (candidates in the round) and it shrinks the held-out mean by at least
    ``min_shrink_pct`` (statistically real and practically worth a term)."""
    t0 = time.perf_counter()
    say = progress or (lambda s: None)
    if not (0 < alpha < 1):
        raise InputError(f"--alpha {alpha}: a false-alarm rate between 0 and 1 (e.g. 0.01)")
    noise = noise or NoiseModel.default(machine, "spherical")
    names = list(REGISTRY) if effects in ("all", None) else list(effects)
    flaggers = [n for n in names if n in REGISTRY and REGISTRY[n].flags_rows]
    fold = command_folds(campaign, folds, np.random.default_rng(seed))
    proto, choice = choose_or_fix(machine, campaign, noise, model, basis, order, folds=folds, progress=say)

    def base_fit(camp, effs):
        return proto.with_effects(effs).fit(camp, noise)

    # ---- base model and outliers
    say(f"fitting the base model, {proto.label()}")
    camp = campaign
    rows = np.arange(len(campaign))
    base_model = base_fit(camp, [])
    feats = Features.from_campaign(campaign)
    lin = Linearised(base_model, camp, noise, feats)
    base_eval = lin.evaluate(lin.A, lin.J, lin.psi0, fold)
    first_eval = base_eval
    scores: list[EffectScore] = []
    outliers = np.array([], int)
    if flaggers:
        for _ in range(3):
            new = flag_outliers(lin, fold[rows], base_eval)
            if new.size == 0:
                break
            outliers = np.sort(np.r_[outliers, rows[new]])
            keep = np.setdiff1d(np.arange(len(campaign)), outliers)
            rows, camp = keep, campaign.subset(keep)
            say(f"{outliers.size} rows flagged as outliers; refitting without them")
            base_model = base_fit(camp, [])
            lin = Linearised(base_model, camp, noise, Features.from_campaign(campaign).subset(keep))
            base_eval = lin.evaluate(lin.A, lin.J, lin.psi0, fold[rows])
        if outliers.size:
            clean = np.setdiff1d(np.arange(len(campaign)), outliers)
            before = np.linalg.norm(first_eval["heldout"][clean], axis=1) * 1e3
            after = np.linalg.norm(base_eval["heldout"], axis=1) * 1e3
            sc = EffectScore("outliers", "outliers", [], int(outliers.size * 3), 0.0, float("inf"), 0.0, alpha,
                             float(before.mean()), float(after.mean()), float(before.max()), float(after.max()), True, 0)
            sc.evidence = (f"{outliers.size} rows have held-out residuals beyond the p = 1e-3 (Bonferroni) limit of "
                           f"chi2(3) at the robust noise level; without them the held-out mean of the other rows "
                           f"falls from {sc.heldout_mean_mm_before:.4f} to {sc.heldout_mean_mm_after:.4f} mm")
            scores.append(sc)
    feats = Features.from_campaign(campaign).subset(rows)
    fold_r = fold[rows]
    held_mm = np.linalg.norm(base_eval["heldout"], axis=1) * 1e3
    base_info = {"model": proto.kind, "order": proto.order, "basis": proto.label(), "label": proto.label(),
                 "choice": None if choice is None else choice.to_dict(), "heldout_mean_mm": float(held_mm.mean()),
                 "heldout_max_mm": float(held_mm.max()), "folds": folds, "rows": int(len(rows)),
                 "chi2_per_expected": base_model.report_.chi2 / base_model.report_.chi2_expected}
    tips = base_model.predict(camp.q, camp.tool, "machine")
    loc = localise(machine, camp, base_eval["heldout"], base_eval["heldout_w"], tips, feats=feats)
    held_base_all = base_eval["heldout"]

    # ---- forward selection over candidate effects
    accepted: list[Effect] = []
    cur_model, cur_lin, cur_eval = base_model, lin, base_eval
    candidates = candidate_effects(machine, feats, names)
    for rnd in range(1, max_effects + 1):
        remaining = [c for c in candidates if c.label not in {a.label for a in accepted}
                     and not (c.scanned and any(type(a) is type(c) for a in accepted))]
        if not remaining:
            break
        say(f"round {rnd}: scoring {len(remaining)} candidates against "
            + ("the base model" if not accepted else "base + " + ", ".join(a.label for a in accepted)))
        base_cols = (cur_lin.A, cur_lin.J, cur_lin.psi0)
        base_grams = cur_lin.grams(cur_lin.J, fold_r)
        round_scores = []
        scan_best: dict[type, tuple] = {}
        for c in remaining:
            c.prepare(camp, feats)
            prior = np.array([p.prior for p in c.parameters()])
            cols = _effect_columns(cur_model, cur_lin, c, camp, feats, prior)
            if c.scanned:
                # one family scanned over a parameter: cheap full-data chi2 first, cross-validate the best only
                G, g = cur_lin.extend_grams(base_grams, cur_lin.J, cols[1], fold_r)["all"]
                g = g - np.r_[cur_lin.psi0, np.zeros(cols[1].shape[-1])]
                chi2 = -float(g @ linalg.solve(G + np.eye(len(g)), g, assume_a="pos"))  # chi2 up to a constant
                if type(c) not in scan_best or chi2 < scan_best[type(c)][0]:
                    scan_best[type(c)] = (chi2, c, cols)
                continue
            round_scores.append((c, _score(cur_lin, base_cols, cols, fold_r, cur_eval, base_grams), 1))
        for kind, (_, c, cols) in scan_best.items():
            n_scan = sum(type(x) is kind for x in remaining)
            round_scores.append((c, _score(cur_lin, base_cols, cols, fold_r, cur_eval, base_grams), n_scan))
        m_tests = sum(k for _, _, k in round_scores)
        best = None
        before = np.linalg.norm(cur_eval["heldout"], axis=1) * 1e3
        for c, ev, _ in round_scores:
            after = np.linalg.norm(ev["heldout"], axis=1) * 1e3
            thr = alpha / m_tests
            sc = EffectScore(c.name, c.label, list(c.axes), c.n_parameters, ev["d_chi2"], ev["F"], ev["p"], thr,
                             float(before.mean()), float(after.mean()), float(before.max()), float(after.max()),
                             False, rnd, effect=c)
            sc.bic_gain = float(ev["d_chi2"] - ev["k"] * math.log(cur_lin.n_equations))
            sig = ev["p"] < thr and after.mean() < before.mean() * (1 - min_shrink_pct / 100)
            # among significant candidates the most economical explanation wins (BIC gain)
            if sig and (best is None or sc.bic_gain > best[0].bic_gain):
                best = (sc, ev)
            if rnd == 1:
                scores.append(sc)
        if best is None:
            break
        sc = best[0]
        sc.significant = True
        sc.evidence = _evidence(sc.effect, sc, loc)
        if rnd > 1:
            scores.append(sc)
        accepted.append(sc.effect)
        say(f"accepted {sc.label}: held-out mean {sc.heldout_mean_mm_before:.4f} -> {sc.heldout_mean_mm_after:.4f} mm")
        cur_model = base_fit(camp, list(accepted))
        cur_lin = Linearised(cur_model, camp, noise, feats)
        cur_eval = cur_lin.evaluate(cur_lin.A, cur_lin.J, cur_lin.psi0, fold_r)
    # outliers judged again under the final model: rows it explains are not outliers
    if outliers.size:
        # features from the whole campaign: approach directions and times depend on the row order
        sub = campaign.subset(outliers)
        y = predict_tracker(cur_model, sub.q, sub.tool, np.r_[cur_model.e0_, cur_model.b_], cur_model.setup_,
                            Features.from_campaign(campaign).subset(outliers), False)[0]
        r = np.linalg.norm(sub.xyz - y, axis=1)
        typical = np.linalg.norm(cur_eval["heldout"], axis=1)
        limit = np.sqrt(stats.chi2.isf(1e-3 / len(campaign), 3) / 3) * np.sqrt(np.mean(typical**2))
        still = outliers[r > limit]
        if still.size < outliers.size:
            say(f"{outliers.size - still.size} flagged rows are explained by the accepted effects: kept")
            outliers = still
            keep = np.setdiff1d(np.arange(len(campaign)), outliers)
            camp = campaign.subset(keep)
            cur_model = base_fit(camp, list(accepted))
            scores = [s for s in scores if s.name != "outliers" or outliers.size]
            for s in scores:
                if s.name == "outliers":
                    s.n_parameters = int(3 * outliers.size)
                    s.evidence = (f"{outliers.size} rows stay beyond the p = 1e-3 (Bonferroni) limit under the final "
                                  f"model and are left out")
    # the final row set: base and best model judged on the same rows
    if len(camp) != base_info["rows"]:
        rows = np.setdiff1d(np.arange(len(campaign)), outliers)
        feats = Features.from_campaign(campaign).subset(rows)
        fold_r = fold[rows]
        base_model = base_fit(camp, [])
        blin = Linearised(base_model, camp, noise, feats)
        bev = blin.evaluate(blin.A, blin.J, blin.psi0, fold_r)
        held_mm = np.linalg.norm(bev["heldout"], axis=1) * 1e3
        base_info.update(heldout_mean_mm=float(held_mm.mean()), heldout_max_mm=float(held_mm.max()), rows=int(len(camp)),
                         chi2_per_expected=base_model.report_.chi2 / base_model.report_.chi2_expected)
        loc = localise(machine, camp, bev["heldout"], bev["heldout_w"], base_model.predict(camp.q, camp.tool, "machine"),
                       feats=feats)
        held_base_all = bev["heldout"]
        if not accepted:
            cur_model = base_model
    if accepted:
        flin = Linearised(cur_model, camp, noise, feats)
        fev = flin.evaluate(flin.A, flin.J, flin.psi0, fold_r)
        best_mm = np.linalg.norm(fev["heldout"], axis=1) * 1e3
        best = (float(best_mm.mean()), float(best_mm.max()))
    else:
        best = (base_info["heldout_mean_mm"], base_info["heldout_max_mm"])
    # ranking: accepted effects in the order forward selection took them (the strongest
    # first), outliers after them, then the rest by their evidence (BIC gain)
    acc = sorted([s for s in scores if s.significant and s.name != "outliers"], key=lambda s: s.round)
    acc += [s for s in scores if s.significant and s.name == "outliers"]
    rest = sorted([s for s in scores if not s.significant], key=lambda s: -s.bic_gain)
    ranked = acc + [s for s in rest if s.label not in {a.label for a in acc}]
    return Diagnosis(machine, base_info, ranked, [int(r) for r in outliers], loc, base_model, cur_model,
                     held_base_all, camp, time.perf_counter() - t0, best)
