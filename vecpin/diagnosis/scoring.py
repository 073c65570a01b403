"""Which effect: candidate effects scored against the current model by linearised
cross-validation and two tests that must both pass.

* **Within the fit**: the F-test of the chi-square reduction the effect's terms buy,
  over the scatter left (robust to a misjudged noise scale).
* **On held-out data**: a paired test of the per-row held-out distances before and
  after (one-sided t on their differences): the effect must predict rows it did not
  see better, by more than their scatter.

Both against ``alpha`` / (candidates in the round) (Bonferroni). Columns of a
candidate come from the current model's kinematics (d tip / d q, the tip and tool
direction, computed once per round): the candidate's terms are linear in its
parameters, so no trial model is built. The backward elimination scores every accepted
effect again given the others the same way (:func:`weakest`).
"""
from __future__ import annotations

import copy
import math

import numpy as np
from scipy import special

from vecpin.errors import InputError
from vecpin.identification.crossval import FoldedProblem
from vecpin.identification.linearised import Linearised
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.features import Features
from vecpin.models import ErrorModel
from vecpin.models.effects import REGISTRY, Effect, TipContext, Visited
from vecpin.units import MM_PER_M


def candidate_effects(machine: Machine, feats: Features, names, q: np.ndarray | None = None) -> list[Effect]:
    """Every candidate instance of the named effects (row-flagging effects excluded),
    each cut to what the commands ``q`` visited can support (:meth:`Effect.supported`:
    no more terms along an axis than its distinct positions less one, harmonics only
    where the travel tells them from a polynomial); those with nothing left are dropped."""
    out = []
    for name in names:
        if name not in REGISTRY:
            raise InputError(f"unknown effect '{name}' (known: {', '.join(REGISTRY)})")
        if not REGISTRY[name].flags_rows:
            out += REGISTRY[name].candidates(machine, feats)
    if q is None:
        return out
    visited = Visited.of(machine, q)
    return [s for s in (c.supported(visited) for c in out) if s is not None]


class Kinematics:
    """What the current model gives every candidate, computed once per round: per row the
    point the row measures (its instrument's request in the likelihood: a tool tip, a
    tool target of any tool point, or a point fixed on the table, a nest), in the base
    frame, with d point / d q and the tool direction.

    ``point`` (N,3) [m]; ``J_q`` (N,3,n); ``tool_dir`` (N,3) (zero on nest rows);
    ``on_tool`` (N,) False on nest rows: a command effect moves the axes of both branches,
    so it reaches a nest through the table axes (its own d point / d q), while a tip
    effect displaces the tool only; ``ctx``: the :class:`TipContext` of the tool rows."""

    def __init__(self, model: ErrorModel, lin: Linearised, feats: Features):
        lik = lin.likelihood
        q = lik.campaign.q
        N, n = q.shape
        theta = lik.theta_of(model)
        b = model.b_
        self.model, self.q = model, q
        self.point, self.J_q = np.zeros((N, 3)), np.zeros((N, 3, n))
        self.tool_dir, self.on_tool = np.zeros((N, 3)), np.ones(N, bool)
        for blk in lik.blocks:
            rows, req = blk.rows, blk.request
            f = feats.subset(rows) if feats is not None else None
            local, _ = req.with_unknowns(theta[blk.unknowns])
            if req.kind == "workpiece":
                wp = model.workpiece_points(q[rows], local, b, True, f)
                self.point[rows], self.J_q[rows] = wp.xyz, wp.J_q
                self.on_tool[rows] = False
                continue
            pt = req.point
            mt = model.tool_tip(q[rows], req.tool, b, True, f, frame="base",
                                point=int(pt[0]) if np.all(pt == pt[0]) else pt,
                                offset=local if np.any(local) else None)
            self.point[rows], self.J_q[rows], self.tool_dir[rows] = mt.tip, mt.J_q, mt.tool_dir
        self.ctx = TipContext(model.machine, q, self.point, self.tool_dir)

    @property
    def tip(self) -> np.ndarray:
        """The measured points (N,3) [m], base frame (tool tips, targets, nests)."""
        return self.point


def effect_columns(kin: Kinematics, lin: Linearised, effect: Effect, feats: Features) -> tuple[np.ndarray, np.ndarray]:
    """ψ-scaled columns (A metric, J whitened) of a candidate effect's parameters: the
    columns the model with the effect has at the current solution (command effects
    through each row's own d point / d q, tip effects on tool rows only, tracker-frame
    effects on the rows the effect says it moves, each in its station's frame)."""
    prior = np.array([p.prior for p in effect.parameters()])
    k = len(prior)
    A = np.zeros(lin.r.shape + (k,))
    J = np.zeros_like(A)
    if "tracker" in effect.kinds:  # acts on the measured point only
        a, j = lin.tracker_columns(effect.tracker(np.nan_to_num(lin.y), feats), prior)
        A, J = A + a, J + j
    D = np.zeros((len(kin.q), 3, k))
    if "command" in effect.kinds:
        D += np.einsum("pin,pnk->pik", kin.J_q, effect.command(kin.q, feats))
    if "tip" in effect.kinds:
        D += effect.tip(kin.ctx, feats) * kin.on_tool[:, None, None]
    if "command" in effect.kinds or "tip" in effect.kinds:
        a, j = lin.point_columns(D, prior)
        A, J = A + a, J + j
    return A, J


class Figures:
    """Candidates' figures against one model (``lin``: it linearised on the rows ``camp``), each formed once, so
    a later round against the same model (every candidate judged given the accepted effects) reuses them: the
    model's :class:`Kinematics` (``kin``), a candidate's columns (:func:`effect_columns`; a scanned family's
    are formed again when wanted, not kept: a hundred of them), its :func:`score` and a scanned candidate's
    full-data chi2 gain (:meth:`gains`). Candidates are told apart by identity (they live through the diagnosis)."""

    CHUNK = 32   # a scanned family's candidates whose columns are formed at once for their gains

    def __init__(self, model: ErrorModel, camp: Campaign, lin: Linearised, feats: Features):
        self.model, self.camp, self.lin, self.feats = model, camp, lin, feats
        self.kin = Kinematics(model, lin, feats)
        self._cols, self._scores, self._gains = {}, {}, {}

    def of(self, model: ErrorModel, camp: Campaign, lin: Linearised) -> bool:
        """Whether these are the figures of ``model`` linearised as ``lin`` on ``camp``'s rows."""
        return self.model is model and self.camp is camp and self.lin is lin

    def columns(self, c: Effect) -> tuple[np.ndarray, np.ndarray]:
        """The candidate's columns (:func:`effect_columns`; the candidate prepared on these rows)."""
        cols = self._cols.get(id(c))
        if cols is None:
            cols = effect_columns(self.kin, self.lin, c, self.feats)
            if not c.scanned:
                self._cols[id(c)] = cols
        return cols

    def score(self, c: Effect, base: FoldedProblem, base_eval: dict) -> dict:
        """The candidate's :func:`score` against ``base`` (the model's folded problem; ``base_eval`` its evaluation)."""
        if id(c) not in self._scores:
            self._scores[id(c)] = score(self.lin, base, self.columns(c), base_eval)
        return self._scores[id(c)]

    def score_all(self, cands: list[Effect], base: FoldedProblem, base_eval: dict) -> None:
        """:meth:`score` of every candidate not scored yet, their columns' products formed together
        (:func:`scores`; the candidates prepared on these rows)."""
        todo = list({id(c): c for c in cands if id(c) not in self._scores}.values())
        for c in todo:
            c.prepare(self.camp, self.feats)
        self._scores.update(zip(map(id, todo), scores(self.lin, base, [self.columns(c) for c in todo], base_eval)))

    def gains(self, base: FoldedProblem, cands: list[Effect]) -> list[float]:
        """Each candidate's full-data chi2 gain (:meth:`FoldedProblem.chi2_gains`), the columns of
        :attr:`CHUNK` of them formed and multiplied at once."""
        todo = list({id(c): c for c in cands if id(c) not in self._gains}.values())
        for i in range(0, len(todo), self.CHUNK):
            part = todo[i:i + self.CHUNK]
            for c in part:
                c.prepare(self.camp, self.feats)
            self._gains.update(zip(map(id, part), base.chi2_gains([self.columns(c)[1] for c in part])))
        return [self._gains[id(c)] for c in cands]


def distances_mm(lin: Linearised, held: np.ndarray) -> np.ndarray:
    """Per judged row the held-out distance [mm] (3-D points; ranges/radii otherwise)."""
    rows = lin.point_rows if lin.point_rows.any() else np.ones(len(held), bool)
    return np.linalg.norm(held[rows], axis=1) * MM_PER_M


def score(lin: Linearised, base: FoldedProblem, cand_cols: tuple, base_eval: dict) -> dict:
    """The candidate's linearised CV (``base`` extended by its columns) and both tests
    (see the module docstring)."""
    return scores(lin, base, [cand_cols], base_eval)[0]


def scores(lin: Linearised, base: FoldedProblem, cols: list[tuple], base_eval: dict) -> list[dict]:
    """:func:`score` of each candidate's columns in ``cols``, their products with the current model's columns
    formed together (:meth:`FoldedProblem.evaluate_extended_many`)."""
    # the current model's folds eliminated once per round, not per candidate
    evs = base.evaluate_extended_many([(J1, A1) for A1, J1 in cols])
    P = base.n_columns
    moved = base.J.reshape(-1, P) @ np.stack([ev["estimate"][:P] for ev in evs], axis=1) if evs else None
    for i, ((A1, J1), ev) in enumerate(zip(cols, evs)):   # what the candidate changes in the fit (whitened)
        ev["pattern"] = moved[:, i] + J1.reshape(-1, J1.shape[-1]) @ ev["estimate"][P:]
        _tests(lin, base, ev, base_eval)
    return evs


def _tests(lin: Linearised, base: FoldedProblem, ev: dict, base_eval: dict) -> None:
    """Both tests of :func:`score` added to a candidate's evaluation ``ev``."""
    d_chi2 = base_eval["chi2"] - ev["chi2"]
    k = max(ev["p_eff"] - base_eval["p_eff"], 0.5)
    dof = max(lin.n_equations - ev["p_eff"], 1.0)
    F = (d_chi2 / k) / (ev["chi2"] / dof)
    before, after = distances_mm(lin, base_eval["heldout"]), distances_mm(lin, ev["heldout"])
    ev.update(d_chi2=d_chi2, k=k, F=F, p=float(special.fdtrc(k, dof, F)) if F > 0 else 1.0, before=before, after=after,
              p_heldout=paired_gain_p(before, after), bic_gain=float(d_chi2 - k * math.log(lin.n_equations)))
    ev["base_share"] = base_share(base, ev, pose_columns(lin, base.n_columns))


def base_share(base: FoldedProblem, ev: dict, pose: np.ndarray) -> float:
    """The share of a candidate's columns J1 (whitened) that the current model's own
    functions take on these rows, beyond what the tracker's pose and the instruments'
    unknowns (``pose``, a mask over ``base``'s columns) take of it anyway (a step's
    constant part, the mean of a drift): (t - t_0) / (tr J1^T J1 - t_0), with
    t = tr(C^T M C), C = J^T J1, M = (G + I)^-1 over every column (the fit's projection,
    priors included; C, M C and J1^T J1 from ``ev``, :meth:`FoldedProblem.evaluate_extended`)
    and t_0 the same over the pose columns alone. Near 1, the model's functions of the
    axes mimic the effect on these rows (a drift in time where the program sweeps its axes
    in time order): the data cannot tell the one from the other."""
    C, MC = ev["cross"], ev["cross_m"]
    C0 = C[pose]
    t0 = float(np.einsum("ij,ij->", C0, np.linalg.solve(base.G[np.ix_(pose, pose)] + np.eye(len(C0)), C0)))
    rest = float(np.trace(ev["gram"])) - t0
    return (float(np.einsum("ij,ij->", C, MC)) - t0) / rest if rest > 0 else 0.0


def pose_columns(lin: Linearised, n: int) -> np.ndarray:
    """(n,) True on ``lin``'s columns of the tracker's pose (E_0) and the instruments'
    own unknowns, False on the model's terms and on columns appended after ``lin``'s
    (an effect's, :meth:`FoldedProblem.extend`)."""
    idx = np.flatnonzero(lin.keep)
    return np.r_[(idx < 6) | (idx >= 6 + lin.likelihood.n_model), np.zeros(n - len(idx), bool)]


def paired_gain_p(before: np.ndarray, after: np.ndarray) -> float:
    """One-sided p-value of the paired t test that the held-out distances ``after`` [mm]
    are no smaller than ``before``, row by row (no spread in the gain: 0 for a gain, 0.5
    otherwise)."""
    delta = before - after
    sd = float(np.std(delta, ddof=1)) if delta.size > 1 else 0.0
    t = float(delta.mean() / (sd / math.sqrt(delta.size))) if sd > 0 else (math.inf if delta.mean() > 0 else 0.0)
    return float(special.stdtr(max(delta.size - 1, 1), -t))


def on_ends(base: FoldedProblem, campaign: Campaign, axes) -> tuple[list[FoldedProblem], float]:
    """``base`` (the current model's folded problem on ``campaign``'s rows) judged on the
    ends of each axis in ``axes`` (:meth:`FoldedProblem.on_ends`: each end estimated
    without any of its own commands), and the current model's held-out mean [mm] over
    those end rows."""
    probs = [base.on_ends(campaign, a) for a in axes]
    held = np.concatenate([np.linalg.norm(p.residuals()[0][p.judged], axis=1) for p in probs])
    return probs, float(held.mean()) * MM_PER_M


def beyond(ends: tuple[list[FoldedProblem], float], cand_cols: tuple) -> tuple[float, float]:
    """(held-out mean [mm] over the end rows of :func:`on_ends`' problems without the
    candidate, the same with its columns): how the model, and the model with the
    candidate, predict each end of the axes measured over part of their travel from the
    rest."""
    A1, J1 = cand_cols
    probs, before = ends
    after = np.concatenate([np.linalg.norm(p.evaluate_extended(J1, A1)["heldout"][p.judged], axis=1) for p in probs])
    return before, float(after.mean()) * MM_PER_M


def beyond_span(names: str, ends: tuple[list[FoldedProblem], float], cand_cols: tuple) -> tuple[bool, str]:
    """(whether a significant candidate stays so, why not): it must not predict the ends
    of the axes measured over part of their travel (``names``) worse from the rest of
    their span (:func:`beyond`) than the model without it: an effect fitted inside the
    measured span that bends away beyond it would make the model worse where it is used."""
    before, after = beyond(ends, cand_cols)
    if after <= before:
        return True, ""
    return False, (f"predicts the ends of {names} (measured over part of their travel) from the rest of their span "
                   f"worse than the model without it: held-out mean {before:.4f} -> {after:.4f} mm; not accepted, "
                   "the model is used beyond what was measured")


def _change(lin: Linearised, ev: dict, cand_cols: tuple) -> np.ndarray:
    """(N,3) [m] how much a candidate, fitted beside the current model (``ev``: its
    :func:`score`), moves the model's metric prediction: its terms and what the model's
    own terms give back to them."""
    P = lin.J.shape[-1]
    est = ev["estimate"]
    return lin.A @ est[:P] + cand_cols[0] @ est[P:]


def fitted(lin: Linearised, ev: dict, cand_cols: tuple) -> tuple[np.ndarray, np.ndarray]:
    """(whitened, metric [m]) residuals (N,3) of every row with a candidate's columns
    fitted beside the current model's (``ev``: its :func:`score`)."""
    return lin.w - ev["pattern"].reshape(lin.w.shape), lin.r - _change(lin, ev, cand_cols)


def size_mm(lin: Linearised, ev: dict, cand_cols: tuple) -> float:
    """RMS over the point rows of how much [mm] a candidate, fitted beside the current
    model (``ev``: its :func:`score`), moves the model's prediction of the measured point
    (:func:`_change`)."""
    move = _change(lin, ev, cand_cols)[lin.point_rows]
    return float(np.sqrt(np.mean(np.sum(move ** 2, axis=1)))) * MM_PER_M if move.size else float("nan")


def heldout_gap(lin: Linearised, ev_a: dict, ev_b: dict, commands: np.ndarray) -> tuple[float, float]:
    """How much better candidate a predicts the held-out rows than candidate b (``ev_a``, ``ev_b``: their
    :func:`score`): (the held-out log-likelihood ratio [nats], the one-sided p of a paired t test that a is no
    better). Per command (``commands``: each row's command index; a command's rows share a fold) the
    difference of the held-out chi2, in units of the scatter a leaves per equation (a quasi-likelihood: a
    misjudged noise scale does not inflate it). The paired test runs over the commands where the two held-out
    predictions differ by more than the noise (|difference|² over the command's equations beyond the scatter):
    only they can tell the candidates apart, and the commands where both predict alike would only dilute a
    difference that sits in a few; fewer than two such commands tell nothing (p = 1)."""
    valid = lin.valid
    chi_a = np.sum(np.where(valid, ev_a["heldout_w"], 0.0) ** 2, axis=1)
    chi_b = np.sum(np.where(valid, ev_b["heldout_w"], 0.0) ** 2, axis=1)
    scatter = max(float(chi_a.sum()) / max(int(valid.sum()), 1), 1e-12)
    d = np.bincount(commands, weights=chi_b - chi_a) / scatter
    nats = 0.5 * float(d.sum())
    apart = np.bincount(commands, weights=np.sum(np.where(valid, ev_a["heldout_w"] - ev_b["heldout_w"], 0.0) ** 2,
                                                 axis=1)) > scatter
    if apart.sum() < 2:
        return nats, 1.0
    d = d[apart]
    sd = float(np.std(d, ddof=1)) if d.size > 1 else 0.0
    t = float(d.mean() / (sd / math.sqrt(d.size))) if sd > 0 else (math.inf if d.mean() > 0 else 0.0)
    return nats, float(special.stdtr(max(d.size - 1, 1), -t))


def needed_given(lin: Linearised, base: FoldedProblem, cols_a: tuple, cols_b: tuple, eval_b: dict,
                 threshold: float) -> bool:
    """True when candidate a still brings a gain, given candidate b in the model, that
    both tests of :func:`score` find at ``threshold``: the campaign shows that b cannot
    stand in for a. ``base``: the current model's folded problem; ``cols_a``, ``cols_b``:
    the candidates' columns; ``eval_b``: b's own score (the model with b, a's "before")."""
    Ab, Jb = cols_b
    ev = score(lin, base.extend(Jb, Ab), cols_a, eval_b)
    return bool(ev["p"] < threshold and ev["p_heldout"] < threshold)


def without(lin: Linearised, effect: Effect) -> Linearised:
    """The linearised model at the same solution with ``effect``'s parameters set to zero
    and its columns removed (residuals put back: w + J_e psi_e, r + A_e psi_e)."""
    names = np.asarray(lin.likelihood.names)[lin.keep]
    mine = np.char.startswith(names.astype(str), effect.label + ".")
    out = copy.copy(lin)
    pe = lin.psi0[mine]
    out.w = lin.w + lin.J[..., mine] @ pe
    out.r = lin.r + lin.A[..., mine] @ pe
    out.J, out.A, out.psi0 = lin.J[..., ~mine], lin.A[..., ~mine], lin.psi0[~mine]
    return out


def weakest(accepted: list, lin: Linearised, ev: dict, fold_r: np.ndarray):
    """The accepted effect whose removal, given all the others, worsens the held-out error
    least, when that worsening is not more than its own spread over the folds (the mean
    of the per-fold mean gains within one standard deviation of them), judged on the
    model linearised at the fit with all of them (``lin``, its held-out evaluation
    ``ev``): (effect, why) or None when every effect survives."""
    folds = fold_r[lin.point_rows] if lin.point_rows.any() else fold_r
    with_all = distances_mm(lin, ev["heldout"])
    worst = None
    for e in accepted:
        lo = without(lin, e)
        gain = distances_mm(lo, lo.folded(fold_r).evaluate()["heldout"]) - with_all
        per = np.array([gain[folds == f].mean() for f in np.unique(folds)])
        spread = float(np.std(per, ddof=1)) if per.size > 1 else 0.0
        margin = float(per.mean()) - spread
        if margin <= 0 and (worst is None or margin < worst[0]):
            text = (f"removing it changes the held-out mean by {per.mean():+.4f} mm, within its spread over the "
                    f"folds ({spread:.4f} mm)")
            worst = (margin, e, text)
    return None if worst is None else worst[1:]


ADOPTED = ("delta_chi2", "f_statistic", "p_value", "threshold", "heldout_mean_mm_before", "heldout_mean_mm_after",
           "heldout_max_mm_before", "heldout_max_mm_after", "significant", "bic_gain", "p_heldout", "size_mm", "small",
           "base_share", "alike_base", "worse_beyond")


def adopt_given(scores: list, judged: list, given: list[str], grouped: set[str] = frozenset()) -> None:
    """Every score not accepted takes its figures from ``judged`` (the candidates scored
    again with the accepted effects, labelled ``given``, in the model): one meaning of
    significant. The first round's figures stay as ``before_accepted``; a scanned family
    is matched by kind (its best instance may move), a candidate whose family is in the
    model, or that is named with an accepted one (``grouped``: its ambiguity group), is
    not significant given them."""
    new = {sc.label: sc for sc, _, _ in judged}
    by_kind = {type(sc.effect): sc for sc, _, _ in judged if sc.effect is not None and sc.effect.scanned}
    for s in scores:
        if s.accepted or s.effect is None or s.label in given:
            continue
        s.before_accepted = {"significant": bool(s.significant), "p_value": s.p_value, "p_heldout": s.p_heldout,
                             "p_threshold": s.threshold, "heldout_mean_mm_before": s.heldout_mean_mm_before,
                             "heldout_mean_mm_after": s.heldout_mean_mm_after, "shrink_pct": s.shrink_pct,
                             "size_rms_mm": s.size_mm}
        s.given = list(given)
        n = new.get(s.label) or (by_kind.get(type(s.effect)) if s.effect.scanned else None)
        if n is None:
            s.significant = s.small = s.alike_base = s.worse_beyond = False
            why = "named with the accepted effect it stands in for (one finding)" if s.label in grouped else \
                "its family is in the model"
            s.evidence = "; ".join(x for x in (s.evidence, why) if x)
            continue
        for name in ADOPTED:
            setattr(s, name, getattr(n, name))
        if s.effect.scanned and not s.dropped:
            s.label, s.effect = n.label, n.effect
        s.evidence = "; ".join(x for x in (n.evidence, s.evidence if s.dropped else "") if x)
