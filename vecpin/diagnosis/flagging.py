"""Gross errors through the diagnosis: the first pass before the base model is chosen,
the flags of a fitted model's held-out residuals (:mod:`.grosserrors`: a family-wise rate
over the rows, repeated readings that agree and crowded regions are misfit), the flagged
rows judged again under the final model (:func:`recheck`), and the outliers' entry in the report."""
from __future__ import annotations

import copy
from dataclasses import replace
from typing import Callable

import numpy as np
from scipy import linalg, special

from vecpin.diagnosis import grosserrors as gross_
from vecpin.diagnosis.result import EffectScore
from vecpin.diagnosis.scoring import Kinematics, candidate_effects, distances_mm, effect_columns
from vecpin.errors import InputError, VecpinError
from vecpin.identification.linearised import Linearised
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.features import Features
from vecpin.measurement.noise import NoiseModel
from vecpin.selection.choice import fixed_model
from vecpin.units import MM_PER_M

OUTLIER_P = gross_.FAMILY_ALPHA  # chance that a clean campaign flags any row (Šidák over the rows)
FIRST_PASS_SHARE = 0.05  # a first pass flagging more rows than this is seeing misfit, not gross errors


def flag(machine: Machine, lin: Linearised, folds: np.ndarray, ev: dict, n_rows: int):
    """(gross errors, misfit rows, regions) of ``lin``'s held-out residuals from fold
    models fitted robustly (:func:`.grosserrors.robust_heldout`: gross rows do not pull
    them; ``ev``, the plain held-out residuals, kept for the callers), the false-alarm rate
    spread over ``n_rows`` rows (:mod:`.grosserrors`)."""
    rob = gross_.robust_heldout(lin, folds, n_rows, OUTLIER_P)
    return gross_.judge(machine, lin.campaign, rob["s"], rob["heldout_w"], lin.valid, n_rows, OUTLIER_P, rob["heldout"])


def still_gross(cur_model, cur_lin: Linearised, cur_eval: dict, fold_r: np.ndarray, campaign: Campaign,
                 outliers: np.ndarray, noise: NoiseModel, feats: Features, rows: np.ndarray) -> tuple[np.ndarray, list[dict]]:
    """(gross, regions they crowd): the flagged rows the final model does not explain either: their residuals through
    the one likelihood (each row in its own frame, with its own equations), as
    predictions of a model that did not see them (noise plus the model's uncertainty
    there), against the noise level of the rows it was fitted to (``rows``), and whose
    neighbours do not share their misfit (:func:`.grosserrors.crowded_regions`).
    The rows are evaluated within the whole campaign (``feats`` of every row): an effect
    that follows the rows' history (a lagged warm-up) sees the same history as in the fit."""
    level = gross_.robust_level(gross_.heldout_statistic(cur_lin, fold_r, cur_eval["heldout_w"]), cur_lin.valid)
    dof = gross_.level_dof(cur_lin.valid)
    try:
        lo = Linearised(cur_model, campaign, noise, feats)
        Jall = cur_lin.J.reshape(-1, cur_lin.J.shape[-1])
        if lo.J.shape[-1] != Jall.shape[-1]:
            raise InputError("the flagged rows' columns differ from the fit's")
        M = linalg.inv(Jall.T @ Jall + np.eye(Jall.shape[-1]))
        s = gross_.prediction_statistic(lo.w[outliers], lo.J[outliers], M, lo.valid[outliers])
        valid, r_out = lo.valid[outliers], lo.r[outliers]
    except VecpinError:
        ev = cur_model.row_residuals(campaign, feats)
        s = np.sum(np.where(ev.valid, ev.w, 0.0) ** 2, axis=1)[outliers]
        valid, r_out = ev.valid[outliers], ev.metric[outliers]
    resid = gross_.spread(len(campaign), rows, cur_eval["heldout"])   # every row's residual [m]
    resid[outliers] = r_out
    still = at_unknown_approach(cur_model, campaign, feats, outliers[gross_.beyond(s, valid, level, len(campaign),
                                                                                 OUTLIER_P, dof)], level, dof)
    # flagged rows whose neighbours share their misfit (over all the passes, with the
    # fitted rows beyond the noise now) are misfit
    gross_now, misfit_now, _ = flag(cur_model.machine, cur_lin, fold_r, cur_eval, len(campaign))
    beyond_all = np.union1d(still, rows[np.union1d(gross_now, misfit_now)])
    excess = np.full(len(campaign), np.nan)
    excess[outliers] = s / (level * gross_.limit(valid, len(campaign), OUTLIER_P, dof))
    regions = gross_.crowded_regions(cur_model.machine, campaign, beyond_all, resid, excess)
    crowded = {r for g in regions for r in g["rows"]}
    return np.array([r for r in still if r not in crowded], int), regions if crowded & set(still) else []


def recheck(pb, st) -> None:
    """The flagged rows judged again under the final model: rows it explains, or that
    crowd one region (misfit), are put back and every model refitted on the rows kept (``pb``, ``st``: the
    diagnosis' problem and state, :mod:`.diagnose`)."""
    if not st.outliers.size:
        return
    still, st.put_back = still_gross(st.cur_model, st.cur_lin, st.cur_eval, st.fold_r, pb.campaign, st.outliers,
                                     pb.noise, pb.all_feats, st.rows)
    if still.size == st.outliers.size:
        return
    pb.say(f"{st.outliers.size - still.size} flagged rows are explained by the accepted effects or crowd one "
           "region (misfit): kept")
    st.keep_rows(pb, still)
    model = pb.fit(st.camp, st.accepted)
    st.refit_base(pb)
    st.set_current(pb, model)


def at_unknown_approach(model, campaign: Campaign, feats: Features, flagged: np.ndarray, level: float,
                        dof: float = np.inf) -> np.ndarray:
    """``flagged`` less the rows read before an axis first moved (approach direction 0: the file does not say how
    the axis came there, so a backlash's state at that reading is unknown) that ``model`` explains within the
    noise (``level``, estimated with ``dof`` degrees of freedom) at an approach they could have had (every unknown
    direction +1, or every one -1)."""
    unknown = flagged[np.any(feats.direction[flagged] == 0, axis=1)]
    if not unknown.size:
        return flagged
    fine = np.zeros(len(unknown), bool)
    for sign in (1.0, -1.0):
        ev = model.row_residuals(campaign, replace(feats, direction=np.where(feats.direction == 0, sign,
                                                                             feats.direction)))
        s = np.sum(np.where(ev.valid, ev.w, 0.0) ** 2, axis=1)[unknown]
        fine |= ~gross_.beyond(s, ev.valid[unknown], level, len(campaign), OUTLIER_P, dof)
    return np.setdiff1d(flagged, unknown[fine])


def explained_by_effects(base_model, campaign: Campaign, noise: NoiseModel, feats: Features, rows: np.ndarray,
                         flagged: np.ndarray, names: list[str], alpha: float) -> tuple[np.ndarray, list[str]]:
    """(the flagged rows an effect candidate predicts, those candidates' labels). A systematic misfit that sits on
    a few rows (the reversal rows of a backlash, the far corner of a skew) looks like gross errors until its
    effect is in the model; a gross error is a row no other row shares. Per candidate (every instance of
    ``names``): the base model and the candidate fitted, linearised at the base model's solution, to the rows
    kept (``rows``: the flagged rows do not steer it); the candidate must be significant there (F-test of its
    chi2 gain at ``alpha`` over the candidates); a flagged row is explained when its residual under that fit is
    within the limit the flags use, against the noise alone (the fit's uncertainty there does not excuse it)."""
    if not flagged.size:
        return flagged, []
    try:
        lo = Linearised(base_model, campaign, noise, feats)
        kin = Kinematics(base_model, lo, feats)
        cands = candidate_effects(base_model.machine, feats, names, campaign.q)
    except VecpinError:
        return np.array([], int), []
    v = lo.valid.astype(float)
    Jk = (lo.J[rows] * v[rows][..., None]).reshape(-1, lo.J.shape[-1])
    wk = (lo.w[rows] * v[rows]).ravel()
    n_eq = max(float(v[rows].sum()), 1.0)
    M0 = linalg.inv(Jk.T @ Jk + np.eye(Jk.shape[1]))
    g0 = Jk.T @ wk - lo.psi0
    d0 = M0 @ g0
    scatter = max(float(np.sum((wk - Jk @ d0) ** 2)) / n_eq, 1e-300)
    level = gross_.robust_level(np.sum((lo.w * v)[rows] ** 2, axis=1), lo.valid[rows])
    dof = gross_.level_dof(lo.valid[rows])
    out, why = set(), []
    for c, Jc, Jck, B in _with_cross(cands, kin, lo, feats, campaign, v, rows, Jk):
        k = Jc.shape[-1]
        S = Jck.T @ Jck + np.eye(k) - B.T @ M0 @ B
        gc = Jck.T @ wk - B.T @ d0
        dc = linalg.solve(S, gc, assume_a="sym")
        gain = float(gc @ dc)
        if not float(special.fdtrc(k, max(n_eq - Jk.shape[1] - k, 1.0), gain / k / scatter)) < alpha / len(cands):
            continue
        dz = d0 - M0 @ B @ dc
        wf = lo.w[flagged] - lo.J[flagged] @ dz - Jc[flagged] @ dc
        s = np.sum(np.where(lo.valid[flagged], wf, 0.0) ** 2, axis=1)
        hit = flagged[~gross_.beyond(s, lo.valid[flagged], level, len(campaign), OUTLIER_P, dof)]
        if hit.size:
            out.update(hit.tolist())
            why.append(c.label)
    return np.array(sorted(out), int), why


def _with_cross(cands: list, kin: Kinematics, lin: Linearised, feats: Features, campaign: Campaign, v: np.ndarray,
                rows: np.ndarray, Jk: np.ndarray, chunk: int = 32):
    """(candidate, its whitened columns (N,3,k) zero on invalid equations, those of ``rows`` (3 n, k), Jk^T of
    them (P, k)) per candidate whose columns can be formed (prepared on ``campaign``); the cross products of
    ``chunk`` candidates in one product (``Jk``, the model's columns on ``rows``, read once for all of them)."""
    for i in range(0, len(cands), chunk):
        part = []
        for c in cands[i:i + chunk]:
            c.prepare(campaign, feats)
            try:
                Jc = effect_columns(kin, lin, c, feats)[1] * v[..., None]
            except VecpinError:
                continue
            part.append((c, Jc, Jc[rows].reshape(-1, Jc.shape[-1])))
        if not part:
            continue
        B = Jk.T @ np.concatenate([x[2] for x in part], axis=1)
        at = np.cumsum([0] + [x[2].shape[1] for x in part])
        for (c, Jc, Jck), a, b in zip(part, at[:-1], at[1:]):
            yield c, Jc, Jck, B[:, a:b]


def _rows(lin: Linearised, rows: np.ndarray) -> Linearised:
    """``lin`` on ``rows`` only (the same solution and columns): its folded problem
    re-solves the linearised fit without the other rows."""
    out = copy.copy(lin)
    out.campaign = lin.campaign.subset(rows)
    out.J, out.A, out.w, out.r, out.y = lin.J[rows], lin.A[rows], lin.w[rows], lin.r[rows], lin.y[rows]
    out.valid, out.point_rows = lin.valid[rows], lin.point_rows[rows]
    return out


def first_pass(machine: Machine, campaign: Campaign, noise: NoiseModel, fold: np.ndarray, feats: Features,
                say: Callable[[str], None]) -> np.ndarray:
    """Rows with gross errors, flagged before the base model is chosen: a quick AP
    order-4 fit (Fourier per turn on rotary axes travelling more than a turn), its
    held-out whitened residuals judged against their median level (:func:`flag`), the
    linearised fit re-solved without the flagged rows up to three times (the models are
    linear in their parameters to about 1e-4: no refit). Flags nothing when that model
    cannot be fitted or when it flags more than :data:`FIRST_PASS_SHARE` of the rows (then
    it misfits, and the chosen base model judges)."""
    rows = np.arange(len(campaign))
    out = np.array([], int)
    quick = fixed_model(machine, "ap", "fourier" if any(a.multiturn for a in machine.axes) else "chebyshev", 4)
    try:
        lin_all = Linearised(quick.with_effects([]).fit(campaign, noise), campaign, noise, feats)
    except VecpinError:
        return out  # too few rows for the quick model: the chosen base model judges
    for _ in range(3):
        lin = _rows(lin_all, rows) if out.size else lin_all
        new = flag(machine, lin, fold[rows], lin.folded(fold[rows]).evaluate(), len(campaign))[0]
        if new.size == 0:
            break
        out = np.sort(np.r_[out, rows[new]])
        if out.size > max(3, FIRST_PASS_SHARE * len(campaign)):
            say(f"first pass: {out.size} rows beyond the noise of a quick model: misfit, not gross errors; "
                "the chosen base model judges them")
            return np.array([], int)
        rows = np.setdiff1d(np.arange(len(campaign)), out)
    if out.size:
        say(f"first pass: {out.size} rows flagged as gross errors before the base model is chosen")
    return out


def outlier_score(base_model, campaign: Campaign, noise: NoiseModel, feats: Features, fold: np.ndarray,
                   outliers: np.ndarray, lin: Linearised, ev: dict, alpha: float) -> EffectScore:
    """The outliers' entry: the held-out residuals of the other rows under the base model
    fitted with the flagged rows (before) and without them (after, ``lin``/``ev``). The fit
    with them is the base model's linearised problem over every row (the models are
    linear in their parameters to about 1e-4, so its solution is that of the refit)."""
    rows = np.setdiff1d(np.arange(len(campaign)), outliers)
    after = distances_mm(lin, ev["heldout"])
    try:
        lin_all = Linearised(base_model, campaign, noise, feats)
        held_all = lin_all.folded(fold).evaluate()["heldout"]
        keep = np.zeros(len(campaign), bool)
        keep[rows] = True
        judged = lin_all.point_rows if lin_all.point_rows.any() else np.ones(len(campaign), bool)
        before = np.linalg.norm(held_all[keep & judged], axis=1) * MM_PER_M
    except VecpinError:
        before = after
    lines = campaign.lines[outliers]
    shown = ", ".join(map(str, lines[:20])) + (" ..." if lines.size > 20 else "")
    sc = EffectScore("outliers", "outliers", [], int(3 * outliers.size), 0.0,
                     float("inf"), 0.0, alpha, float(before.mean()), float(after.mean()), float(before.max()),
                     float(after.max()), True, 0, accepted=True)
    sc.evidence = (f"{outliers.size} rows (file lines {shown}) have held-out residuals beyond the limit at which a "
                   f"clean campaign of {len(campaign)} rows flags any row with probability at most {OUTLIER_P:g} "
                   "(Šidák; "
                   "each row with its own number of equations, scaled by each prediction's own spread, against the "
                   "robust (median) noise level: F with that level's degrees of freedom), no repeated reading agrees "
                   "with them, they crowd no region, and "
                   "they stay beyond it under the final model; the base model fitted with them predicts the "
                   f"other rows to {sc.heldout_mean_mm_before:.4f} mm on average (held out), without them to "
                   f"{sc.heldout_mean_mm_after:.4f} mm")
    sc.advice = [f"outliers: re-measure the rows at file lines {shown} of {campaign.source} (the same commands, the "
                 "tracker where it stands; append them and diagnose again) or check the tracker log for a broken beam; "
                 "they are left out of the fit. If the new readings agree with them, or the same poses are flagged on "
                 "another day, the error is systematic at those poses (the machine there, not the reading): appended "
                 "readings that agree are kept and named a misfit"]
    return sc
