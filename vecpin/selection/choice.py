"""Let the data choose the model: kind, basis of every axis and order, by held-out data.

Every candidate model is a set of columns of one linearised problem. The models are linear in their parameters
to about 1e-4 around the nominal machine, the whitening of each row (instrument and positioning noise,
:mod:`vecpin.identification.likelihood`) does not depend on the model, and a model's columns are the kinematic
sensitivity of each axis' error components times functions of that axis' position. So one set of normal
equations per model kind, over the union of every candidate function of every axis, serves the k-fold
cross-validation of every candidate: a small solve per candidate and fold (folds grouped by pose, every tool and
target of a pose in one fold; whole sweeps where the design moves one joint at a time: measurement.poses).

Per axis the candidate bases are (:mod:`vecpin.selection.design`): Chebyshev series over the travel (orders 0-8)
and cubic B-splines with 3, 7 or 15 uniform knots (local errors; with ``basis="pspline"`` penalised splines on
31 knots, their smoothing λ from the held-out data); on a rotary axis that travels more than a turn, and that
the campaign measured over a turn or more, also Fourier series per turn, alone or with a Chebyshev trend over
the travel (errors that repeat every turn, and those that do not: cable wind-up, torsion, a gear behind the
encoder, drift over a long travel). The search scores the first model kind (6-DoF) with one family on all axes at
a common order, then refines it axis by axis (every basis and smoothing of one axis with the other axes eliminated
once); a later kind (AP) is scored at its bases first and searched so only where it could be chosen
(:func:`~vecpin.selection.stage.screen_kind`). The choice follows the one-standard-error rule: among the
candidates whose held-out mean distance is within one paired standard error of the lowest, the one with the
fewest terms (a penalised spline's effective terms).

The folds group the rows by command and deal the commands at random (interleaved folds: new poses among the
measured ones), except on an axis the campaign measured over less than 90 % of its travel: there the commands at
each end of its measured span (a tenth at each end) are held out whole
(:func:`vecpin.identification.folds.command_folds`), so that the held-out rows judge how a candidate
extrapolates beyond what it was fitted on, as it will be used beyond the measured span (a robot measured over
part of its joint ranges; a machine whose model is asked for over its whole travel). Along such axes every
candidate series and spline is built over the span measured, not the travel, and beyond it only its
straight-line part carries on (:func:`~vecpin.selection.design.measured_spans`): a UR10 measured over 96-147° of
its joints' 720° has errors of 18-30° period there (joints 1 and 2) that series over the travel cannot resolve
(series C of the public dataset: 0.44 -> 0.27 mm held-out mean on interleaved poses, 0.42 -> 0.26 mm beyond
joint 1's measured span). Along such axes the basis is then chosen on their held-out ends
(:func:`~vecpin.selection.stage.along_ends`), each axis' two ends (the outer fifth of its measured span) held
out on a problem of its own, so that no end is predicted by a fit that saw any of its commands: each kind's
choice by the one-SE rule keeps its other axes, and the basis of each partly measured axis becomes the one with
the fewest terms (never more than it had) within one standard error of the lowest held-out mean on the ends of
every partly measured axis, so the model keeps only what extrapolates (a constant or a line, where the rest
extrapolates wildly), while the axes it interpolates keep their richer functions; of the kinds so chosen, the
one-SE rule on every held-out row decides. A campaign over the whole travel keeps interleaved folds only, and
the choice as before.

When the noise level is not stated (``noise_from_data``), gross rows are found first by the robust fit of the
first stage's best candidate (:mod:`~vecpin.selection.screen`: a few left out and named, many that drive the noise
level refused); then that candidate tells the level: every noise sigma is scaled by sqrt(chi2 / expected) of its
linearised fit, the folded problems are rescaled (no new linearisation) and the search runs with that noise, once.

Only candidates the campaign can determine take part: fewer unknowns (the model's terms that move anything, the
tracker pose and the instruments' unknowns) than the campaign has equations, the count the fit holds every model
to. Larger ones are left out (the table says how many), so a small campaign gets the best model it can support,
judged on held-out data like any other, and its fit is never refused for its size; with ``underdetermined``
every candidate takes part, the priors deciding what the data cannot. A campaign too small for any candidate,
even constant errors, is refused with how many more poses it needs.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from vecpin.errors import IdentifiabilityError, InputError, VecpinError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.poses import unique_rows
from vecpin.measurement.registration import check_campaign_frames
from vecpin.models import MODELS, ErrorModel, make_model
from vecpin.selection.orders import check_folds
from vecpin.selection.design import (CHEB_ORDERS, DEFAULT_FAMILIES, FAMILIES, PART_OF_TRAVEL, AxisChoice, axis_options,
                                     choice_folds, measured_spans, partly_measured, per_turn_measured)
from vecpin.selection.screen import GrossRowsRefused, Screen, screen_rows, trimmed_registration
from vecpin.selection.search import Candidate, Problem, Search, one_standard_error, supported
from vecpin.selection.stage import KindStage, ends_choice, kind_stage, other_kinds, rescaled
from vecpin.threads import one_blas_thread, side_by_side

_Problem = Problem  # the name the tests and older scripts use
MAX_SELECTION_ROWS = 3000  # larger campaigns choose on a subsample grouped by command
MIN_GROUP_ROWS = 20        # ... in which a command repeated more often keeps this many rows (or its share)
SCREEN_PARAMETERS = 2000   # a fixed model scored for its gross rows up to this size (larger: the fit's own checks first)


@dataclass
class ModelChoice:
    """Every candidate scored, the lowest, and the one chosen by the one-SE rule."""

    machine: Machine
    candidates: list[Candidate]
    best: Candidate
    chosen: Candidate
    standard_error_mm: float
    reason: str
    folds: int
    rows: int
    uncompensated_mm: tuple[float, float]
    seconds: float
    fixed_unknowns: int = 6  # tracker-pose and instrument unknowns in every candidate
    equations: int = 0       # the campaign's equations: every candidate has fewer unknowns
    left_out: int = 0        # candidates with as many unknowns or more, not scored
    part_turn: tuple = ()    # axes travelling over a turn but measured over less: no series per turn tried
    ends: tuple = ()         # axes measured over part of their travel: the ends of their span held out whole
    noise_scale: float = 1.0  # every noise sigma times this (the data's level when the noise was not stated)
    before_ends: Candidate | None = None  # the chosen kind's choice before its bases along ``ends`` were judged on them
    chosen_noise_scale: float = 1.0  # the level the chosen candidate's own linearised fit gives: the fit starts there
    gross: Screen | None = None  # rows left out as gross errors before the noise level was taken from the data
    fixed: bool = False          # a fixed model's one candidate, scored for its gross rows and noise level only
    subsample: tuple = ()    # (rows chosen on, the campaign's rows, seed) when the choice judged a subsample
    grouping: str = "pose"   # what the folds keep together: poses, or the sweeps of a design moving one joint at a time
    given: str = ""          # why a choice was made although the kind and the order were given
    screened: tuple = ()     # kinds judged at the first kind's bases only, and why (selection.stage.screen_kind)

    def table(self, limit: int = 30) -> str:
        nests = " and any table nest's" if self.machine.has_workpiece else ""  # nest rows are judged as tool rows are
        lines = [f"model choice: {len(self.candidates)} candidates by {self.folds}-fold cross-validation grouped by "
                 f"{self.grouping} ({self.rows} rows judged: every reading of a point, the tool's{nests}; "
                 "linearised), mm",
                 f"  {'candidate':<58s} {'model terms':>11s} {'held-out mean':>13s} {'max':>8s}",
                 f"  {'uncompensated, the rows scored (tracker frame)':<58s} {'':>11s} {self.uncompensated_mm[0]:13.4f} "
                 f"{self.uncompensated_mm[1]:8.4f}"]
        shown = sorted(self.candidates, key=lambda c: c.mean)[:limit]
        shown += [self.chosen] * (self.chosen not in shown)
        for c in sorted(shown, key=lambda c: c.mean):
            mark = " <- chosen" if c is self.chosen else (" <- lowest" if c is self.best else "")
            lines.append(f"  {c.label():<58s} {c.n_terms:11d} {c.mean:13.4f} {c.max:8.4f}{mark}")
        if len(self.candidates) > len(shown):
            lines.append(f"  ({len(self.candidates) - len(shown)} more candidates scored, not shown)")
        eff = self.chosen.effective_terms
        lines.append(f"chosen: {self.chosen.label(self.machine.axis_names)} ({self.chosen.n_terms} model terms"
                     f"{'' if eff is None else f', {eff:.1f} effective after smoothing'}): {self.reason}")
        lines.append(f"  (model terms: the model's offsets, constants and series coefficients; every candidate also "
                     f"carries the {self.fixed_unknowns} tracker-pose and instrument unknowns of this campaign)")
        if self.part_turn:
            lines.append(f"  (no series per turn on {', '.join(self.part_turn)}: measured over less than a turn, where "
                         "they cannot be told from series over the travel and extrapolate over the rest of the turn)")
        if self.ends:
            lines.append(f"  (measured over less than {PART_OF_TRAVEL:.0%} of their travel (or zone): "
                         f"{', '.join(self.ends)}; "
                         "their series are built over the span measured and only their lines carry on beyond it; the "
                         "commands at each end of that span were held out together, so the held-out "
                         "rows judge how each candidate extrapolates beyond what it was fitted on, too)")
        if self.before_ends is not None and self.before_ends is not self.chosen:
            b = self.before_ends
            lines.append(f"  (before the bases along them were chosen on their held-out ends: {b.label()}, "
                         f"{b.n_terms} model terms, held-out mean {b.mean:.4f} mm)")
        lines += [f"  ({text})" for text in self.screened]
        if self.gross is not None:
            lines.append(f"gross errors: {self.gross.text}")
        if self.subsample:
            lines.append(f"  (chosen on a subsample: {self.subsample[0]} of the campaign's {self.subsample[1]} rows, "
                         f"whole commands drawn at random with seed {self.subsample[2]}, the same rows on every run; "
                         "the chosen model is then fitted to every row)")
        if self.left_out:
            lines.append(f"  ({self.left_out} larger candidates left out: as many unknowns as the campaign's "
                         f"{self.equations} equations or more, which its {self.rows} rows cannot determine; the choice "
                         "is among the models this campaign supports; unknowns: the tracker pose's, the instruments' "
                         "and the model terms that move the tip unlike the others, not the redundant ones)")
        return "\n".join([self.given] * bool(self.given) + lines)

    def sweep(self, kind: str) -> list[Candidate]:
        """The common-order candidates of one kind with Chebyshev everywhere (Paper I Table 2)."""
        return sorted([c for c in self.candidates if c.kind == kind and len(set(c.axes)) == 1
                       and c.axes[0].family == "chebyshev"], key=lambda c: c.axes[0].order)

    def to_dict(self) -> dict:
        return {"method": f"{self.folds}-fold cross-validation grouped by {self.grouping}, linearised at nominal",
                "rule": "one standard error: the fewest model terms within one paired standard error of the lowest mean",
                "rows": self.rows, "standard_error_mm": self.standard_error_mm, "reason": self.reason,
                "equations": self.equations, "left_out_unsupported": self.left_out,
                "no_series_per_turn": list(self.part_turn), "ends_held_out": list(self.ends),
                "noise_scale": self.noise_scale, "chosen_noise_scale": self.chosen_noise_scale,
                "gross_error_lines": [] if self.gross is None else [int(v) for v in self.gross.lines],
                "subsample": list(self.subsample) or None,
                "seconds": None, "uncompensated_mm": {"mean": self.uncompensated_mm[0], "max": self.uncompensated_mm[1]},
                "chosen": self.chosen.to_dict(self.machine), "lowest": self.best.to_dict(self.machine),
                "before_ends": None if self.before_ends is None else self.before_ends.to_dict(self.machine),
                "candidates": [c.to_dict(self.machine) for c in sorted(self.candidates, key=lambda c: c.mean)]}


def check_basis(machine: Machine, basis: str, alternatives: str = "chebyshev, spline or auto") -> None:
    """Refuse a per-turn basis (``fourier``, ``fourier_trend``) on a machine without a
    rotary axis that travels more than a turn: it would apply to no axis."""
    if basis in ("fourier", "fourier_trend") and not any(a.multiturn for a in machine.axes):
        raise InputError(f"no rotary axis of {machine.name} travels more than a turn; `basis` {basis} applies to "
                         f"none: use {alternatives}")


def _check_request(kinds, families, orders) -> list[int]:
    """Refuse unknown kinds and families and orders below 0: the orders sorted."""
    if not (orders := sorted(set(int(o) for o in orders))) or orders[0] < 0:
        raise InputError("orders are whole numbers >= 0")
    for k in kinds:
        if k not in MODELS:
            raise InputError(f"unknown model '{k}' (choose {' or '.join(MODELS)})")
    for f in families:
        if f not in FAMILIES:
            raise InputError(f"unknown basis family '{f}' (one of {', '.join(FAMILIES)})")
    return orders


def _what_to_try(machine: Machine, campaign: Campaign, judged: Campaign, families, plans, orders, per_axis: bool,
                 fixed_order: bool):
    """(plans, options per axis, axes measured over less than a turn): the families tried
    on every axis at once and every basis of each axis (no more terms than the ``judged``
    rows have positions there), series per turn only on axes the ``campaign`` measured
    over a turn unless ``plans`` asks for them."""
    spans = np.ptp(campaign.q, axis=0) if plans is None else [None] * machine.n_axes
    short = tuple(a.name for a, sp in zip(machine.axes, spans) if a.multiturn and sp is not None
                  and not per_turn_measured(sp) and {"fourier", "fourier_trend"} & set(families))
    # penalised splines join axis by axis (all smoothings at the cost of one) rather than all at once
    plans = tuple(p for p in (plans or [f for f in families if f != "pspline" or not per_axis] or families)
                  if p in families)
    if plans and all(p in ("fourier", "fourier_trend") for p in plans):
        check_basis(machine, plans[0], ", ".join(f for f in families if f not in ("fourier", "fourier_trend"))
                    or "chebyshev")
    options = [supported(axis_options(a, orders, families, fixed_order, sp), judged.q[:, a.index])
               for a, sp in zip(machine.axes, spans)]
    return plans, options, short


@one_blas_thread
def choose_model(machine: Machine, campaign: Campaign, noise: NoiseModel | None = None, *, kinds=None,
                 families=DEFAULT_FAMILIES, plans=None, orders=CHEB_ORDERS, per_axis: bool = True, folds: int = 5,
                 seed: int = 0, fixed_order: bool = False, opts: dict | None = None, underdetermined: bool = False,
                 noise_from_data: bool = False, travel: tuple[np.ndarray, np.ndarray] | None = None,
                 progress: Callable[[str], None] | None = None, screen: bool = True) -> ModelChoice:
    """Score the candidates by linearised k-fold CV and choose one (module docstring). ``kinds`` (default: every
    registered kind, ``vecpin.models.MODELS``; the first searched, the others screened at its bases:
    :func:`~vecpin.selection.stage.other_kinds`), ``families``, ``orders``: what to try; ``plans``: the families
    tried on every axis at once (default ``families``); ``per_axis``: refine each axis' basis around the best common
    one; ``fixed_order``: ``orders`` is one order the user fixed (splines then have that many knots, trends are at
    most that order); ``folds``: their number, or (N,) the user's fold of each row (no ends held out then); ``seed``:
    the folds (and the subsample of a large campaign); ``opts``: the model options (``prior_scale``,
    ``tool_lengths``) every candidate carries; ``underdetermined``: also candidates with as many unknowns as
    equations or more; ``noise_from_data``: the noise level is not known: when the best common candidate's chi2
    leaves its band, every noise sigma is scaled by what it says (:func:`_noise_level`, ``ModelChoice.noise_scale``),
    after the gross rows are left out (:mod:`vecpin.selection.screen`; ``screen``: look for them, the default)."""
    args = dict(locals())   # the arguments, for the choice again without the gross rows
    t0 = time.perf_counter()
    kinds = tuple(kinds or MODELS)
    say = progress or (lambda s: None)
    check_folds(campaign, folds)
    check_campaign_frames(machine, campaign)
    orders = _check_request(kinds, families, orders)
    noise = noise or NoiseModel.default(machine)
    camp = campaign if (picked := _subsample(campaign, seed, rows=True)) is None else campaign.subset(picked)
    plans, options, short = _what_to_try(machine, campaign, camp, families, plans, orders, per_axis, fixed_order)
    ends = () if np.ndim(folds) else partly_measured(machine, campaign, travel)   # given folds: the user's own
    spans = measured_spans(machine, campaign, travel)
    fold, grouping = choice_folds(camp, folds, seed, ends, picked)   # labels given, or whole sweeps, or poses

    make = lambda kind, opt=options, setup=None: Problem(  # noqa: E731 (the linearised problem of a kind)
        kind, machine, camp, noise, opt, fold, opts, setup, spans=spans)

    def linearised(kind: str) -> tuple[Problem, Search]:   # the kinds side by side, here and below
        say(f"{kind}: linearising {len(camp)} rows with every candidate basis")
        prob = make(kind)
        return prob, _common_stage(prob, machine, campaign, plans, orders, options, underdetermined, say)

    problems, search = _first_kind(kinds, linearised, machine, campaign)
    lowest = min(search.cands, key=lambda c: c.mean)
    gross = _screened(screen and noise_from_data, problems[lowest.kind], lowest, camp, campaign,
                      lambda setup: make(lowest.kind, [[c] for c in lowest.axes], setup))
    if gross is not None:   # the choice again without them (linearised again: their rows steered the first)
        say(gross.text)
        kept = np.setdiff1d(np.arange(len(campaign)), gross.rows)   # (and their fold labels)
        return _with_gross(choose_model(**(args | {"campaign": campaign.subset(kept), "noise": noise, "screen": False,
                                                   "folds": folds[kept] if np.ndim(folds) else folds})), gross)
    scale = _noise_level(problems[lowest.kind], lowest) if noise_from_data else 1.0
    if scale != 1.0:  # the choice made again with the noise the data give (no new linearisation)
        say(f"noise from the data: {scale:.2f} x the stated noise; scoring again with it")
    problems = {kind: rescaled(prob, scale) for kind, prob in problems.items()}

    def staged(kind: str) -> KindStage:
        if new := kind not in problems:   # a kind the screen let in: linearised now, at the data's noise
            problems[kind] = rescaled(make(kind), scale)
        prob = problems[kind]
        own = (_common_stage(prob, machine, campaign, plans, orders, options, underdetermined, say)
               if scale != 1.0 or new else search.of_kind(kind))
        return kind_stage(own, prob, camp, options, ends, per_axis, say)

    stages = side_by_side(staged, list(problems), processes=True)   # small results, much Python: processes
    stages += other_kinds([k for k in kinds if k not in problems], stages[0], problems, search.limit, scale, say,
                          make, staged)
    search = _joined([own.search for own in stages])
    cands, first = search.cands, problems[kinds[0]]
    best = min(cands, key=lambda c: c.mean)
    if ends and per_axis:   # along axes the model is used beyond, what extrapolates (ends_choice)
        chosen, se, reason, before = ends_choice([own for own in stages if own.end is not None], problems)
    else:
        chosen, se, reason, before = (*one_standard_error(cands, best, lambda c: problems[c.kind].size(c),
                                                          lambda c: problems[c.kind].size_bound(c)), None)
    say(f"chose {chosen.label()} ({len(cands)} candidates in {time.perf_counter() - t0:.1f} s)")
    own_scale, limit = scale * _noise_level(problems[chosen.kind], chosen) if noise_from_data else 1.0, search.limit
    return ModelChoice(machine, cands, best, chosen, se, reason, int(fold.max()) + 1, int(first.judged.sum()),
                       (float(first.uncompensated.mean()), float(first.uncompensated.max())),
                       time.perf_counter() - t0, first.n_fixed,
                       int(round(limit)) if math.isfinite(limit) else first.n_equations, len(search.left_out), short,
                       tuple(machine.axes[a].name for a in ends), scale, before, own_scale, grouping=grouping,
                       subsample=(len(camp), len(campaign), seed) if picked is not None else (),
                       screened=tuple(own.note for own in stages if own.note))


def _common_stage(prob: Problem, machine: Machine, campaign: Campaign, plans, orders, options,
                  underdetermined: bool, say) -> Search:
    """A new search of one kind with its common-basis candidates scored."""
    search = Search()
    if not underdetermined:  # the whole campaign's equations (the choice may judge a subsample)
        search.limit = prob.n_equations * len(campaign) / len(prob.judged)
    search.common(prob, machine, plans, orders, options)
    say(f"{prob.kind}: {len(search.cands)} common-basis candidates scored")
    return search


def _first_kind(kinds, linearised, machine: Machine, campaign: Campaign) -> tuple[dict, Search]:
    """(problems, search): the first kind's, its common-basis candidates scored (the others are screened at its
    bases: :func:`~vecpin.selection.stage.other_kinds`); every kind's where the first supports no candidate."""
    firsts = side_by_side(linearised, kinds[:1])
    if not firsts[0][1].cands:
        firsts += side_by_side(linearised, kinds[1:])
    problems = {kind: prob for kind, (prob, _) in zip(kinds, firsts)}
    search = _joined([own for _, own in firsts])
    if not search.cands:
        raise _too_small(machine, campaign, problems, search.limit)
    return problems, search


def _joined(searches: list[Search]) -> Search:
    """One search of the kinds' own (in the kinds' order: the same table whichever
    kind finished first)."""
    search = Search()
    for own in searches:
        search.limit = own.limit
        search.merge(own)
    return search


def _with_gross(choice: ModelChoice, gross: Screen) -> ModelChoice:
    """``choice`` (made without the gross rows) with them."""
    choice.gross = gross
    return choice


def _screened(on: bool, prob: Problem, cand: Candidate, judged: Campaign, campaign: Campaign,
              again) -> Screen | None:
    """The gross rows of ``campaign`` by the robust linearised fit of ``cand`` on the rows
    ``judged`` (:func:`~vecpin.selection.screen.screen_rows`), linearised again by
    ``again(setup)`` at a trimmed registration when gross rows pulled the default one (with
    ``cand``'s own bases only: its columns, without the rest of every basis' union)
    (None when not ``on``: the noise stated, or the rows screened already)."""
    if not on:
        return None
    fp = prob.problem
    rows = np.flatnonzero((judged.station == 0) & prob.judged)
    robust = trimmed_registration(prob.setup, fp.r, judged.xyz, rows)
    if robust is not None:
        prob = again(robust)
    cols, fac = prob.columns(cand.axes)
    fp = prob.problem
    return screen_rows(fp.J[..., cols] * fac, fp.w, prob.valid, fp.x0[cols], judged, campaign)


def _noise_level(prob: Problem, cand: Candidate, rounds: int = 6) -> float:
    """The scale of the stated noise the data give, from the linearised full-data fit of
    ``cand`` (the fit's own chi2 and expected value: the equations less the effective
    parameters): 1 when its chi2 lies in the 3-sigma band, else every sigma scaled by
    sqrt(chi2 / expected) until that settles within 1 % (the priors weigh more as the
    noise grows, so the expected value moves with it). Rescales ``prob`` in place."""
    cols, fac = prob.columns(cand.axes)
    scale = 1.0
    for k in range(rounds):
        chi2 = prob.problem.chi2(cols, fac)
        dof = max(prob.n_equations - prob.problem.effective_terms(cols, fac), 1.0)
        step = math.sqrt(chi2 / dof)
        if (k == 0 and abs(chi2 - dof) <= 3 * math.sqrt(2 * dof)) or abs(step - 1) < 0.01:
            break
        prob.problem.rescale(step)
        scale *= step
    if scale != 1.0:
        prob.problem.rescale(1.0 / scale)   # the caller rescales every kind's problem at once
    return scale


def _too_small(machine: Machine, campaign: Campaign, problems: dict, limit: float) -> IdentifiabilityError:
    """The refusal of a campaign that supports no candidate: the smallest candidate of the
    kinds tried (constant errors) and how many more poses it needs."""
    need = {}
    for kind, prob in problems.items():
        const = tuple(AxisChoice("chebyshev", 0) for _ in machine.axes)
        need[kind] = prob.unknowns(const)
    kind = min(need, key=need.get)
    per_row = limit / len(campaign)
    more = max(1, math.ceil((need[kind] + 1 - limit) / per_row))
    return IdentifiabilityError(
        f"{campaign.source}: {len(campaign)} rows give {int(round(limit))} equations, and the smallest model tried "
        f"({MODELS[kind].display_name} with constant errors) has {need[kind]} unknowns: measure at least {more} more "
        f"{'pose' if more == 1 else 'poses'} (or fit with `underdetermined` to let the priors decide the rest)")


def _subsample(campaign: Campaign, seed: int, rows: bool = False) -> Campaign | np.ndarray | None:
    """At most :data:`MAX_SELECTION_ROWS` rows, the rows of a command kept together. A
    command measured more often than its share (``cap`` rows: a campaign of a few
    commands repeated many times) keeps a random ``cap`` of its rows, so the subsample
    always holds whole groups of many commands, never none. ``rows``: the rows kept instead (None: all)."""
    if len(campaign) <= MAX_SELECTION_ROWS:
        return None if rows else campaign
    group = unique_rows(np.round(campaign.q, 9))[1]
    rng = np.random.default_rng(seed)
    order = rng.permutation(group.max() + 1)
    per = np.bincount(group)
    cap = max(-(-MAX_SELECTION_ROWS // len(per)), MIN_GROUP_ROWS)
    keep_row = np.ones(len(group), bool)
    if per.max() > cap:  # rank of each row within its command, in a random order
        perm = rng.permutation(len(group))
        by_group = perm[np.argsort(group[perm], kind="stable")]
        rank = np.empty(len(group), int)
        rank[by_group] = np.arange(len(group)) - np.repeat(np.cumsum(per) - per, per)
        keep_row = rank < cap
        per = np.minimum(per, cap)
    keep_groups = order[np.cumsum(per[order]) <= MAX_SELECTION_ROWS]
    keep = np.flatnonzero(np.isin(group, keep_groups) & keep_row)
    return keep if rows else campaign.subset(keep)


def parse_order(text) -> int | str:
    """'auto' or a whole number >= 0."""
    if str(text).strip().lower() == "auto":
        return "auto"
    try:
        v = int(str(text))
    except ValueError:
        raise InputError(f"`order` {text!r}: 'auto' or a whole number >= 0") from None
    if v < 0:
        raise InputError(f"`order` {text}: the order must be >= 0")
    return v


def fixed_model(machine: Machine, kind: str, basis: str, order: int, **opts) -> ErrorModel:
    """The model of a fully fixed choice: ``basis`` on the axes it applies to (per-turn
    families on rotary axes that travel more than a turn, Chebyshev elsewhere; a Fourier
    series of ``order`` with a Chebyshev trend of order min(2, ``order``)); ``spline``: on
    every axis, ``order`` interior knots. (A penalised spline is never fully fixed: its
    smoothing is chosen by :func:`choose_model`.)"""
    check_basis(machine, basis)
    if basis == "pspline":
        raise InputError("`basis` pspline: the smoothing is chosen by held-out data; use choose_or_fix")
    if basis in ("chebyshev", "fourier"):  # the seed's choice and vecpin's former default
        return make_model(kind, machine, order, basis=basis, **opts)
    axes = []
    for a in machine.axes:
        if basis == "spline":
            axes.append(AxisChoice("spline", order))
        elif basis == "fourier_trend" and a.multiturn:
            axes.append(AxisChoice("fourier_trend", order, min(2, order)))
        else:
            axes.append(AxisChoice("chebyshev", order))
    return make_model(kind, machine, order, bases=[c.basis(a) for a, c in zip(machine.axes, axes)], **opts)


BASES = ("auto",) + FAMILIES


def choose_or_fix(machine: Machine, campaign: Campaign, noise: NoiseModel, kind: str = "auto", basis: str = "auto",
                  order: int | str = "auto", *, folds: int | np.ndarray = 5, seed: int = 0, underdetermined: bool = False,
                  progress: Callable[[str], None] | None = None, noise_from_data: bool = False,
                  travel: tuple[np.ndarray, np.ndarray] | None = None, **opts):
    """(unfitted model, the choice or None): the model the data choose, with any of
    ``kind``, ``basis`` (a family on the axes it applies to) and ``order`` fixed; a fully
    fixed choice builds the model directly. ``opts``: model options (tool_lengths,
    prior_scale), which the candidates carry too. A fixed ``order`` keeps the families
    whose size it defines (Chebyshev and Fourier series of that order, trends up to it);
    splines only with ``basis="spline"`` or ``"pspline"``, ``order`` then being the number
    of interior knots; a penalised spline's smoothing is always chosen by held-out data.
    ``seed``: the cross-validation folds; ``underdetermined``: the choice may also take
    candidates with more unknowns than equations (:func:`choose_model`); ``noise_from_data``:
    the choice scales the noise to what the data say (:func:`choose_model`; a fixed
    choice too, its one candidate scored, so that its gross rows are found before the
    noise level is taken from the data, unless it has more than :data:`SCREEN_PARAMETERS`
    parameters or the choice cannot score it (too few commands for the folds, too few
    equations): the fit's own checks then refuse it or it takes the level as before); ``travel``: where the model will be used
    (:func:`~vecpin.selection.design.partly_measured`)."""
    if kind not in ("auto", *MODELS):
        raise InputError(f"`model` {kind}: one of auto, {', '.join(MODELS)}")
    if basis not in BASES:
        raise InputError(f"`basis` {basis}: one of {', '.join(BASES)}")
    order = parse_order(order)
    check_basis(machine, basis)
    fixed = kind != "auto" and basis not in ("auto", "pspline") and order != "auto"
    if fixed:
        model = fixed_model(machine, kind, basis, order, **opts)
        if not noise_from_data or model.n_parameters > SCREEN_PARAMETERS:
            return model, None
    if basis == "auto":
        families = DEFAULT_FAMILIES if order == "auto" else ("chebyshev", "fourier", "fourier_trend")
    elif basis in ("spline", "pspline") and order != "auto":
        families = (basis,)
    else:
        families = tuple(dict.fromkeys((basis, "chebyshev")))
    try:
        choice = choose_model(machine, campaign, noise, kinds=None if kind == "auto" else (kind,), families=families,
                              plans=None if basis == "auto" else (basis,),
                              orders=CHEB_ORDERS if order == "auto" else (order,), fixed_order=order != "auto",
                              per_axis=order == "auto" and basis == "auto", folds=folds, seed=seed, opts=opts,
                              underdetermined=underdetermined, noise_from_data=noise_from_data, travel=travel,
                              progress=progress)
    except GrossRowsRefused:
        raise
    except VecpinError:
        if fixed:   # a fixed model the choice cannot score (too few commands or equations): the fit's own checks
            return model, None
        raise
    if fixed:   # its one candidate scored for the noise level and its gross rows (:mod:`.screen`)
        choice.fixed = True
        return model, choice
    if kind != "auto" and order != "auto" and basis == "auto":
        choice.given = (f"the kind ({kind}) and order ({order}) were given, not the basis: the data chose each axis' "
                        "basis of that order below (Chebyshev; on an axis turning a full turn also Fourier, with or "
                        "without a trend); with a basis given too the model is fitted with no choice")
    return choice.chosen.model(machine, **opts), choice
