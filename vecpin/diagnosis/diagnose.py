"""Diagnosing the sim-to-real gap: where the residual lies, which unmodelled effect
causes it, how far it shrinks once the effect is added, and what to do.

0. **Gross errors first.** A robust first pass (a quick AP order-4 fit, held-out
   whitened residuals scaled by each prediction's own spread, against their median
   level, each row with its own number of equations, at a 1 % family-wise false-alarm
   rate for the whole campaign: :mod:`.grosserrors`) flags rows no noise explains, so
   they do not steer the choice of the base model; the chosen base model flags again (rows
   the choice saw: it is made again without them), and every flagged row is judged once
   more under the final model (rows it explains are kept). Rows whose repeated readings
   agree, rows crowded into one stretch of an axis, and
   rows an effect fitted to the other rows predicts (:func:`.flagging.explained_by_effects`)
   are misfit, not gross errors: kept (the first two reported as regions the model does not fit).
1. **The base model.** The model the data choose (kind, per-axis bases, orders:
   :mod:`vecpin.selection.choice`), on the rows left; a base model richer than the seed's
   6-DoF order 6 is itself a finding, with its shrink. Effects are scored against it.
2. **Where.** Held-out residuals (k-fold cross-validation grouped by command) broken
   down along every coordinate a cause could follow (:mod:`.localise`).
3. **Which.** Every candidate effect (:mod:`vecpin.models.effects`, every choice of
   axes) is scored against the current model (:mod:`.scoring`): it must pass an F-test
   within the fit *and* a paired test on held-out rows, both Bonferroni-corrected over
   the round, and shrink the held-out mean by a worthwhile amount. The most economical
   such candidate (BIC) is accepted, the model refitted with it, and the rest scored
   again against the improved model; the search stops at the first round with no
   significant gain.
4. **How far, and why.** Held-out mean/max before and after each accepted effect; the
   breakdowns the effect explains (structured before, not after); breakdowns left
   structured at the end are reported as unexplained.
5. **What to do.** Each accepted effect turns its fitted numbers into advice.
6. **Given the accepted.** Every other candidate is judged with the accepted effects in the
   model (significant: given them); each family's detection size is stated (:mod:`.detection`).

Every row is judged with its own likelihood (tracker points from any station, nests,
tool targets, ranges, ball bar radii: :mod:`vecpin.identification.likelihood`).
Scoring uses the likelihood linearised at the current model: the models are linear in
their parameters to about 1e-4, so cross-validation is a few small solves per
candidate. Accepted effects are then fitted for real (nonlinear ML).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from vecpin.diagnosis.armadvice import arm_advice
from vecpin.diagnosis import flagging as fl
from vecpin.diagnosis import grosserrors as gross_
from vecpin.diagnosis.harmonics import base_harmonics
from vecpin.diagnosis.detection import Sight, sight_of
from vecpin.diagnosis.localise import describe_structure, explained, localise
from vecpin.diagnosis.nextplan import next_measurements
from vecpin.diagnosis.result import BASE_ALIKE, Diagnosis, EffectScore, base_finding
from vecpin.diagnosis.structure import (ProgramChanges, held_back, in_both_regions, program_changes, repeats_verdict,
                                        step_not_shown)
from vecpin.diagnosis.scoring import (Figures, adopt_given, beyond_span, candidate_effects, distances_mm, fitted,
                                      heldout_gap, needed_given, on_ends, size_mm, weakest)
from vecpin.errors import ConvergenceError, InputError
from vecpin.identification.crossval import FoldedProblem
from vecpin.identification.folds import command_folds
from vecpin.identification.linearised import Linearised
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.features import Features
from vecpin.measurement.noise import NoiseModel
from vecpin.models.base import ErrorModel
from vecpin.models.effects import REGISTRY, Effect
from vecpin.models.modelfile import check_same_machine
from vecpin.planning.zones import clip_to_zone
from vecpin.selection.choice import choose_or_fix
from vecpin.selection.design import partly_measured
from vecpin.selection.orders import check_folds
from vecpin.threads import one_blas_thread

def _evidence(sc: EffectScore, loc_before: dict, loc_after: dict) -> tuple[str, list[str]]:
    """The effect's own evidence sentence and the breakdowns it explains."""
    gone = explained(loc_before, loc_after)
    what = (f"the residual was structured along {describe_structure(loc_before, gone)} and is not after it"
            if gone else "it explains no single breakdown on its own (its signature spreads over several)")
    text = (f"{what}; held-out mean {sc.heldout_mean_mm_before:.4f} -> "
            f"{sc.heldout_mean_mm_after:.4f} mm ({sc.shrink_pct:.1f}%, p = {sc.p_heldout:.1e} on held-out rows); "
            f"chi2 down by {sc.delta_chi2:.0f} (F = {sc.f_statistic:.1f}, p = {sc.p_value:.1e}; threshold "
            f"{sc.threshold:.1e})")
    return text, gone


DECISIVE_NATS = math.log(20)   # the best must out-predict a rival's held-out rows by a likelihood ratio of 20
# (Kass & Raftery 1995: strong) and by a paired test, else the campaign cannot tell them apart: one finding


@dataclass
class _Problem:
    """What every stage shares: the campaign, the noise, the folds (over all rows), the
    features of the whole file, the base model's prototype and the settings."""
    machine: Machine
    campaign: Campaign
    noise: NoiseModel
    fold: np.ndarray
    all_feats: Features
    names: list[str]
    flaggers: list[str]
    folds: int
    alpha: float
    max_effects: int
    min_shrink_pct: float
    say: Callable[[str], None]
    proto: object = None
    choice: object = None
    ends: tuple = ()   # the axes measured over part of their travel (partly_measured): effects judged on their ends
    choose: Callable | None = None   # the base model chosen on a campaign's rows: (prototype, choice); None if given

    def fit(self, camp: Campaign, effects: list):
        """The base model with ``effects`` fitted to ``camp`` (nonlinear ML)."""
        return self.proto.with_effects(list(effects)).fit(camp, self.noise)


@dataclass
class _State:
    """The diagnosis as it goes: the rows fitted (``rows``, ``camp``, ``feats``,
    ``fold_r``), the outliers, the base model and its linearisation (``blin``, ``bev``),
    the current model with the accepted effects, its linearisation and breakdowns."""
    rows: np.ndarray
    outliers: np.ndarray
    camp: Campaign
    feats: Features
    fold_r: np.ndarray
    base_model: object
    blin: Linearised
    bev: dict
    base_info: dict
    loc: dict
    cur_model: object = None
    cur_lin: Linearised | None = None
    cur_eval: dict | None = None
    cur_loc: dict | None = None
    accepted: list = field(default_factory=list)
    scores: list = field(default_factory=list)
    put_back: list = field(default_factory=list)
    changes: ProgramChanges | None = None  # the program's changes on the rows fitted (:mod:`.structure`)
    candidates: list = field(default_factory=list)   # every candidate effect the search started from
    detection: list = field(default_factory=list)    # per family what the final model's campaign would detect
    last: tuple | None = None   # the forward search's last round (judged, folded problem, the model it scored against)
    figures: Figures | None = None   # the candidates' figures against the current model (:class:`.scoring.Figures`)

    def linearise(self, pb: _Problem, model) -> tuple[Linearised, dict]:
        """The model linearised on the fitted rows and its held-out evaluation."""
        lin = Linearised(model, self.camp, pb.noise, self.feats)
        return lin, lin.folded(self.fold_r).evaluate()

    def locate(self, pb: _Problem, model, lin: Linearised, ev: dict) -> dict:
        """The held-out residuals ``ev`` of ``model`` broken down (:func:`localise`)."""
        self.figures = Figures(model, self.camp, lin, self.feats)   # its kinematics, kept for the scoring rounds
        return localise(pb.machine, self.camp, ev["heldout"], ev["heldout_w"], self.figures.kin.point,
                        feats=self.feats, valid=lin.valid)

    def set_current(self, pb: _Problem, model) -> None:
        self.cur_model = model
        self.cur_lin, self.cur_eval = self.linearise(pb, model)
        self.cur_loc = self.locate(pb, model, self.cur_lin, self.cur_eval)

    def keep_rows(self, pb: _Problem, outliers: np.ndarray) -> None:
        """Fit every row but ``outliers`` from now on."""
        self.outliers = outliers
        self.rows = np.setdiff1d(np.arange(len(pb.campaign)), outliers)
        self.camp = pb.campaign.subset(self.rows) if outliers.size else pb.campaign
        self.feats, self.fold_r = pb.all_feats.subset(self.rows), pb.fold[self.rows]

    def refit_base(self, pb: _Problem) -> None:
        """The base model on the rows fitted, its linearisation, breakdowns and summary."""
        self.base_model = pb.fit(self.camp, [])
        self.blin, self.bev = self.linearise(pb, self.base_model)
        held = distances_mm(self.blin, self.bev["heldout"])
        rep = self.base_model.report_
        self.base_info.update(heldout_mean_mm=float(held.mean()), heldout_max_mm=float(held.max()),
                              rows=int(len(self.rows)), chi2_per_expected=rep.chi2 / rep.chi2_expected)
        self.loc = self.locate(pb, self.base_model, self.blin, self.bev)


def _base_given(machine: Machine, base, model, basis, order):
    """The base model of a fitted model (``base``: its kind, bases and orders, refitted without its effects),
    checked against the machine and the other settings; None when no ``base`` is given (the data choose)."""
    if base is None:
        return None
    fixed = [f"`{k}` {v}" for k, v in (("model", model), ("basis", basis), ("order", order)) if str(v) != "auto"]
    if fixed:
        raise InputError(f"`base` with {', '.join(fixed)}: a base model fixes its kind, bases and orders; "
                         "leave them at auto")
    check_same_machine(machine, base.machine, "the diagnosis", "`base`")
    return base.with_effects([])


def _problem(machine: Machine, campaign: Campaign, model, order, effects, noise, folds: int, alpha: float,
             max_effects: int, basis, seed: int, min_shrink_pct: float, say, base=None,
             travel=None) -> tuple[_Problem, np.ndarray]:
    """The settings checked, the folds, the first pass' gross errors and the base model
    chosen (or fixed, or given as ``base``) on the rows left: (problem, first-pass outliers)."""
    if not (0 < alpha < 1) or not math.isfinite(alpha):
        raise InputError(f"`alpha` {alpha}: a false-alarm rate between 0 and 1 (e.g. 0.01)")
    given = _base_given(machine, base, model, basis, order)
    check_folds(campaign, folds)
    noise = noise or NoiseModel.default(machine, "spherical")
    names = list(REGISTRY) if effects in ("all", None) else list(effects)
    for n in names:
        if n not in REGISTRY:
            raise InputError(f"`effects`: unknown effect '{n}' (known: {', '.join(REGISTRY)})")
    fold = command_folds(campaign, folds, np.random.default_rng(seed))
    pb = _Problem(machine, campaign, noise, fold, Features.from_campaign(campaign),  # times, directions: the whole file
                  names, [n for n in names if REGISTRY[n].flags_rows], folds, alpha, max_effects, min_shrink_pct, say)
    zone = getattr(base, "zone_", None)   # a base model fitted in a zone is used there only
    travel = travel if travel is not None else (clip_to_zone(machine, zone) if zone else None)
    pb.ends = partly_measured(machine, campaign, travel)
    outliers = fl.first_pass(machine, campaign, noise, fold, pb.all_feats, say) if pb.flaggers else np.array([], int)
    camp = campaign.subset(np.setdiff1d(np.arange(len(campaign)), outliers)) if outliers.size else campaign
    if given is not None:
        pb.proto, pb.choice = given, None
        say(f"base model given: {given.label()} (refitted; no model choice)")
        return pb, outliers
    pb.choose = lambda c: choose_or_fix(machine, c, noise, model, basis, order, folds=folds, seed=seed, progress=say,
                                        travel=travel)
    pb.proto, pb.choice = pb.choose(camp)
    return pb, outliers


def _base_stage(pb: _Problem, outliers: np.ndarray) -> _State:
    """The base model on the rows left, refitted without the gross errors it still sees
    (up to three times); its held-out summary and breakdowns."""
    pb.say(f"fitting the base model, {pb.proto.label()}")
    proto, choice = pb.proto, pb.choice
    info = {"model": proto.kind, "order": proto.order, "basis": proto.label(), "label": proto.label(),
            "choice": None if choice is None else choice.to_dict(), "folds": pb.folds}
    st = _State(np.array([], int), outliers, pb.campaign, pb.all_feats, pb.fold, None, None, {}, info, {})
    st.keep_rows(pb, outliers)
    st.base_model = pb.fit(st.camp, [])
    st.blin, st.bev = st.linearise(pb, st.base_model)
    for _ in range(3 if pb.flaggers else 0):
        new = fl.flag(pb.machine, st.blin, st.fold_r, st.bev, len(pb.campaign))[0]
        if new.size == 0:
            break
        st.keep_rows(pb, np.sort(np.r_[st.outliers, st.rows[new]]))
        pb.say(f"{st.outliers.size} rows flagged as outliers; refitting without them")
        st.base_model = pb.fit(st.camp, [])
        st.blin, st.bev = st.linearise(pb, st.base_model)
    back, by = fl.explained_by_effects(st.base_model, pb.campaign, pb.noise, pb.all_feats, st.rows, st.outliers,
                                       pb.names, pb.alpha)
    if len(back):   # a misfit on a few rows an effect fitted to the other rows predicts: not gross errors, kept
        pb.say(f"{len(back)} flagged rows are predicted by {', '.join(by)} fitted to the other rows: kept")
        st.keep_rows(pb, np.setdiff1d(st.outliers, back))
        st.base_model = pb.fit(st.camp, [])
        st.blin, st.bev = st.linearise(pb, st.base_model)
    held = distances_mm(st.blin, st.bev["heldout"])
    rep = st.base_model.report_
    st.base_info.update(heldout_mean_mm=float(held.mean()), heldout_max_mm=float(held.max()), rows=int(len(st.rows)),
                        chi2_per_expected=rep.chi2 / rep.chi2_expected)
    st.loc = st.locate(pb, st.base_model, st.blin, st.bev)
    st.cur_model, st.cur_lin, st.cur_eval, st.cur_loc = st.base_model, st.blin, st.bev, st.loc
    return st


def _score_round(pb: _Problem, st: _State, remaining: list[Effect], rnd: int,
                 sight: Sight | None = None) -> tuple[list, tuple | None, float]:
    """Every remaining candidate scored against the current model (:func:`score`; a
    scanned family by full-data chi2 first, its best cross-validated): ([(score, its
    evaluation, its columns)], the most economical significant one or None, threshold).
    ``sight``: every candidate's detection size at the round's threshold (:mod:`.detection`)."""
    lin, fold_r = st.cur_lin, st.fold_r
    if st.figures is None or not st.figures.of(st.cur_model, st.camp, lin):
        st.figures = Figures(st.cur_model, st.camp, lin, st.feats)
    fig, base = st.figures, lin.folded(fold_r)   # the same model scored again (given the accepted): not formed again
    if sight is not None:
        sight.base = base
    round_scores, scan_best, held = [], {}, {}
    scanned = [c for c in remaining if c.scanned]
    fig.score_all([c for c in remaining if not c.scanned], base, st.cur_eval)   # one product per fold for them all
    for c, gain in zip(scanned, fig.gains(base, scanned)):   # full-data chi2 first, cross-validate the best
        c.prepare(st.camp, st.feats)
        # a step at a change of the program, nothing separating them
        why = held_back(st.changes, st.camp, st.feats, c, st.cur_lin, pb.alpha)
        slot = held if why else scan_best
        if type(c) not in slot or gain > slot[type(c)][0]:
            slot[type(c)] = (gain, c, why)
    for c in remaining:
        c.prepare(st.camp, st.feats)
        ev = None if c.scanned else fig.score(c, base, st.cur_eval)
        if sight is not None:
            sight.add(c, fig.columns(c), ev)   # a scored candidate's cross blocks are not formed again
        if not c.scanned:
            round_scores.append((c, ev, 1, fig.columns(c), None))
    for kind, (gain, c, why) in list(scan_best.items()) + list(held.items()):
        if why and kind in scan_best and scan_best[kind][0] >= gain:
            continue  # a step held back is shown when it would have been the family's best
        round_scores.append((c, fig.score(c, base, st.cur_eval), sum(type(x) is kind for x in remaining),
                             fig.columns(c), why))
    thr = pb.alpha / max(sum(k for _, _, k, _, why in round_scores if not why), 1)
    if sight is not None:
        sight.settle(thr)
    best, judged, ends = None, [], None
    for c, ev, _, cols, why in round_scores:
        b_, a_ = ev["before"], ev["after"]
        sc = EffectScore(c.name, c.label, list(c.axes), c.n_parameters, ev["d_chi2"], ev["F"], ev["p"], thr,
                         float(b_.mean()), float(a_.mean()), float(b_.max()), float(a_.max()), False, rnd,
                         bic_gain=ev["bic_gain"], p_heldout=ev["p_heldout"], effect=c, size_mm=size_mm(lin, ev, cols))
        passes = ev["p"] < thr and ev["p_heldout"] < thr and not why
        sc.significant = passes and a_.mean() < b_.mean() * (1 - pb.min_shrink_pct / 100)
        sc.small = passes and not sc.significant
        sc.evidence = why or (f"both tests pass but it takes {sc.shrink_pct:.1f}% off the held-out mean, under the "
                              f"{pb.min_shrink_pct:g}% an effect must earn to be named" if sc.small else "")
        sc.base_share = ev["base_share"]
        sc.alike_base = not passes and not why and c.in_time and sc.base_share >= BASE_ALIKE
        if sc.alike_base:
            sc.evidence = "; ".join(x for x in (sc.evidence, f"the model's functions of the axes take {sc.base_share:.0%} "
                                                "of its shape on these rows: the data cannot tell the two apart") if x)
        if sc.significant and getattr(c, "t0", None) is not None:   # a step: shown where both sides measured?
            both = in_both_regions(st.camp, st.feats, c.t0, c.station)
            not_shown = step_not_shown(b_, a_, both[lin.point_rows] if lin.point_rows.any() else both, thr)
            sc.significant, sc.evidence = not_shown is None, not_shown or ""
            verdict, seen = repeats_verdict(st.camp, st.feats, c, lin, fitted(lin, ev, cols), pb.alpha)
            sc.significant = sc.significant and verdict != "contradicted"
            sc.evidence = "; ".join(x for x in (sc.evidence, seen) if x)
        if sc.significant and pb.ends:   # where the model will be used beyond what was measured
            ends = ends or on_ends(base, st.camp, pb.ends)
            sc.significant, why = beyond_span(", ".join(pb.machine.axes[a].name for a in pb.ends), ends, cols)
            sc.evidence = "; ".join(x for x in (why, sc.evidence) if x)
            sc.worse_beyond = not sc.significant
        # the most economical explanation wins; on a tie (columns the data cannot tell
        # apart) the first candidate, the one nearer the base of the chain
        if sc.significant and (best is None or sc.bic_gain > best[0].bic_gain + 1e-6 * (1 + abs(best[0].bic_gain))):
            best = (sc, ev, cols)
        judged.append((sc, ev, cols))
    return judged, best, base


def _group(pb: _Problem, st: _State, judged: list, best: tuple, base: FoldedProblem) -> list:
    """The ambiguity group of the round's best: every rival that also explains the gap on held-out rows (takes
    ``min_shrink_pct`` off their mean, its held-out gain at ``alpha``, not worse beyond the measured span),
    that the best does not out-predict decisively on held-out rows (likelihood ratio :data:`DECISIVE_NATS`
    and a paired test per command, :func:`.scoring.heldout_gap`, at the round's threshold: the evidence that
    names an effect), and given which the best brings no significant gain at that threshold (the rival can
    stand in for it): one finding, named once with the best's shrink. No threshold on the families' own scores
    (BIC, number of terms) decides it."""
    sc, ev, cols_best = best
    rivals = [(o, e, cols) for o, e, cols in judged if o is not sc and o.shrink_pct >= pb.min_shrink_pct
              and o.p_heldout < pb.alpha and not o.worse_beyond]
    if not rivals:
        return []
    thr = sc.threshold
    cmd = np.unique(st.camp.q, axis=0, return_inverse=True)[1].ravel()
    out = []
    for o, e, cols in rivals:
        nats, p = heldout_gap(st.cur_lin, ev, e, cmd)
        if not (nats >= DECISIVE_NATS and p < thr) and not needed_given(st.cur_lin, base, cols_best, cols, e, thr):
            out.append(o)
    return out


def _forward(pb: _Problem, st: _State) -> None:
    """Forward selection (module docstring, step 3): each round's most economical
    significant candidate is accepted with its ambiguity group, the model refitted with
    it; the first round without a significant gain ends the search."""
    candidates = st.candidates = candidate_effects(pb.machine, st.feats, pb.names, st.camp.q)
    st.changes = program_changes(pb.machine, st.camp, st.feats)
    named: set[str] = set()  # accepted effects and the members of their ambiguity groups
    for rnd in range(1, pb.max_effects + 1):
        remaining = [c for c in candidates if c.label not in named
                     and not (c.scanned and any(type(a) is type(c) for a in st.accepted))]
        if not remaining:
            break
        pb.say(f"round {rnd}: scoring {len(remaining)} candidates against "
               + ("the base model" if not st.accepted else "base + " + ", ".join(a.label for a in st.accepted)))
        judged, best, base = _score_round(pb, st, remaining, rnd)
        st.scores += [sc for sc, _, _ in judged] if rnd == 1 else []
        if best is None:
            st.last = (judged, base, st.cur_model)   # scored given every accepted effect: reused if the model stays
            break  # the first round without a significant gain ends the search
        sc = best[0]
        sc.accepted = True
        if rnd > 1:
            st.scores.append(sc)
        st.accepted.append(sc.effect)
        group = _group(pb, st, judged, best, base)
        sc.alternatives, sc.alternative_effects = [o.label for o in group], [o.effect for o in group]
        named.update([sc.label] + sc.alternatives)
        pb.say(f"accepted {sc.label}: held-out mean {sc.heldout_mean_mm_before:.4f} -> {sc.heldout_mean_mm_after:.4f} mm")
        try:
            fitted = pb.fit(st.camp, st.accepted)
        except ConvergenceError as err:  # the linearised gain the fit cannot realise: not a finding, not an abort
            st.accepted.pop()
            sc.accepted = False
            sc.evidence = f"significant when linearised, but the model with it cannot be fitted: {err}"
            pb.say(f"{sc.label}: the fit with it does not converge; not accepted")
            break
        before = st.cur_loc
        st.set_current(pb, fitted)
        text, sc.explains = _evidence(sc, before, st.cur_loc)
        sc.evidence = "; ".join(x for x in (text, sc.evidence) if x)   # with what the poses read twice said of a step
        if sc.alternatives:
            sc.evidence += (f"; this campaign cannot tell it from {', '.join(sc.alternatives)}: each explains the "
                            "held-out rows within a likelihood ratio of "
                            f"{math.exp(DECISIVE_NATS):.0f} of it and can stand in for it (one finding)")


def _backward(pb: _Problem, st: _State) -> None:
    """Backward elimination: every accepted effect again, given all the others, on the
    rows the final model is fitted to (:func:`.scoring.weakest`); the weakest is dropped and the
    model refitted until every effect survives."""
    while len(st.accepted) >= 2:
        drop = weakest(st.accepted, st.cur_lin, st.cur_eval, st.fold_r)
        if drop is None:
            break
        e, text = drop
        st.accepted.remove(e)
        st.set_current(pb, pb.fit(st.camp, st.accepted))
        gone = next(x for x in st.scores if x.effect is e and x.accepted)
        gone.accepted, gone.dropped = False, True
        gone.evidence += f"; dropped given {', '.join(a.label for a in st.accepted)}: {text}"
        pb.say(f"dropped {e.label}: {text}")


def _given_accepted(pb: _Problem, st: _State) -> None:
    """Every candidate not accepted judged with the accepted effects in the final model (significant: given
    them, :func:`.scoring.adopt_given`); per family the size this campaign would detect (:mod:`.detection`)."""
    names = [a.label for a in st.accepted]
    remaining = [c for c in st.candidates if c.label not in names
                 and not (c.scanned and any(type(a) is type(c) for a in st.accepted))]
    if not remaining:
        return
    sight = sight_of(st.cur_lin, st.cur_eval, distances_mm(st.cur_lin, st.cur_eval["heldout"]), pb.min_shrink_pct,
                     pb.folds)
    scored = {sc.label for sc, _, _ in st.last[0]} if st.last else set()
    if st.last and st.last[2] is st.cur_model and st.last[0] and all(c.scanned or c.label in scored
                                                                      for c in remaining):
        # the last round scored this model and every candidate (group members are not scored again): its figures
        judged = sight.from_round(*st.last[:2])
    else:
        pb.say(f"what this campaign could have seen: {len(remaining)} candidates scored given {names or 'none'}")
        judged = _score_round(pb, st, remaining, 0, sight)[0]
    if names:
        adopt_given(st.scores, judged, names, {x for s in st.scores if s.accepted for x in s.alternatives})
    st.detection = sight.families()


def _regions(pb: _Problem, st: _State) -> list[dict]:
    """Rows beyond the noise of the final model that are not gross errors: the regions
    it does not fit, with their file lines and descriptions."""
    gf, mf, regions = fl.flag(pb.machine, st.cur_lin, st.fold_r, st.cur_eval, len(pb.campaign))
    for g in regions:
        g["rows"] = [int(st.rows[r]) for r in g["rows"]]
    if st.put_back:  # flagged rows put back as crowding one region: the region over all rows beyond the noise
        crowd = gross_.crowded_regions(pb.machine, pb.campaign, np.union1d(
            st.rows[np.union1d(gf, mf)], [r for g in st.put_back for r in g["rows"]]),
            gross_.spread(len(pb.campaign), st.rows, st.cur_eval["heldout"]))
        regions = (crowd or st.put_back) + [g for g in regions if not g["axis"]]
    for g in regions:
        g["lines"] = [int(pb.campaign.lines[r]) for r in g["rows"]]
        g["where"], g["text"] = gross_.describe_region(g, pb.campaign)
    return regions


def _result(pb: _Problem, st: _State, seconds: float) -> Diagnosis:
    """The diagnosis: advice from the final model's fitted numbers, the scores ranked
    (accepted in their order, then the rest by BIC gain), regions and outliers."""
    if st.outliers.size:
        st.scores.append(fl.outlier_score(st.base_model, pb.campaign, pb.noise, pb.all_feats, pb.fold, st.outliers,
                                          st.blin, st.bev, pb.alpha))
    regions = _regions(pb, st)
    best_mm = distances_mm(st.cur_lin, st.cur_eval["heldout"])
    std = st.cur_model.std_
    for s in st.scores:
        if s.accepted and s.effect is not None:
            sl = next(sl for e, sl in st.cur_model.effect_slices() if e.label == s.label)
            s.advice = s.advice or arm_advice(pb.machine, s.effect, s.effect.advice(st.cur_model.b_[sl], std[sl]))
    acc = sorted([s for s in st.scores if s.accepted and s.name != "outliers"], key=lambda s: s.round)
    acc += [s for s in st.scores if s.accepted and s.name == "outliers"]
    rest = sorted([s for s in st.scores if not s.accepted], key=lambda s: -s.bic_gain)
    ranked = acc + [s for s in rest if s.label not in {a.label for a in acc}]
    return Diagnosis(pb.machine, st.base_info, ranked, [int(r) for r in st.outliers], st.loc, st.base_model,
                     st.cur_model, st.bev["heldout"], st.camp, seconds, (float(best_mm.mean()), float(best_mm.max())),
                     st.cur_loc, list(st.cur_loc["most_structured"]), base_finding(pb.choice),
                     [int(v) for v in pb.campaign.lines[st.outliers]], misfit_regions=regions,
                     detection=st.detection)


@one_blas_thread
def diagnose(machine: Machine, campaign: Campaign, model: str = "auto", order: int | str = "auto", effects="all",
             noise: NoiseModel | None = None, folds: int = 5, alpha: float = 0.01, max_effects: int = 4,
             basis: str = "auto", seed: int = 0, min_shrink_pct: float = 2.0,
             progress: Callable[[str], None] | None = None, base: ErrorModel | None = None,
             travel: tuple[np.ndarray, np.ndarray] | None = None, base_known: Callable | None = None) -> Diagnosis:
    """Run the diagnosis (module docstring). ``model``, ``basis``, ``order`` fix any part of the base model
    (default: chosen by held-out data); ``base``: a fitted model (``fit``'s model file) whose kind, bases and orders
    are the base model, refitted here (no model choice); ``travel``: (low, high) [m, rad] per axis where the model
    will be used (default: a zone ``base`` was fitted in, else the axes' limits): the axes measured over part of it
    have their ends judged (the model choice, every effect); ``effects``: "all" or names; ``alpha``: the family-wise
    false-alarm rate per round; ``min_shrink_pct``: the held-out shrink an effect must bring to be worth its terms;
    ``base_known(localization, heldout [m], outlier rows)``: called once these are final. Stages: checks and model
    choice, base, forward, outliers again, backward, next measurements, periodic errors (:mod:`.harmonics`), result."""
    t0, say = time.perf_counter(), progress or (lambda s: None)
    pb, outliers = _problem(machine, campaign, model, order, effects, noise, folds, alpha, max_effects, basis, seed,
                            min_shrink_pct, say, base, travel)
    st = _base_stage(pb, outliers)
    if pb.choice is not None and np.setdiff1d(st.outliers, outliers).size:   # the choice saw rows since found gross
        say("the base model chosen again without the rows the first pass missed")
        pb.proto, pb.choice = pb.choose(st.camp)
        st = _base_stage(pb, st.outliers)
    _forward(pb, st)
    fl.recheck(pb, st)
    if base_known is not None:
        base_known(st.loc, st.bev["heldout"], st.outliers)
    _backward(pb, st)
    _given_accepted(pb, st)
    next_measurements(st.scores, st.accepted, st.cur_model, st.cur_lin, st.cur_eval, pb.fit, st.camp, say)
    st.scores += base_harmonics(st.cur_model, st.cur_lin, st.cur_eval, st.fold_r, st.scores, pb)
    return _result(pb, st, time.perf_counter() - t0)
