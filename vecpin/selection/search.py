"""The model choice's search (:mod:`vecpin.selection.choice`): a candidate model and its
held-out distances (:class:`Candidate`), the folded problem of one model kind that scores
candidates (:class:`Problem`), the search over them (:class:`Search`: every family at
a common order on every axis, then axis by axis around the best), the candidates the
campaign can determine only, and the one-standard-error rule that picks among them.
"""
from __future__ import annotations

import copy
import functools
import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from vecpin.identification.nested import heldout_nested, nested_order
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.models import MODELS, make_model
from vecpin.models.basis import AxisBasis, bases_text
from vecpin.selection.design import AxisChoice, Design


@dataclass
class Candidate:
    """One model: kind, a basis per axis, held-out distances [mm] per judged row;
    ``effective_terms``: the number the one-SE rule compares (``n_terms`` unless a
    penalised spline makes it smaller, :meth:`Design.effective_terms`); ``spans``: per
    axis, where its bases are built (:func:`~vecpin.selection.design.measured_spans`;
    empty: every travel)."""

    kind: str
    axes: tuple[AxisChoice, ...]
    n_terms: int
    heldout: np.ndarray = field(repr=False)
    effective_terms: float | None = None
    spans: tuple = ()

    @property
    def size(self) -> float:
        return self.n_terms if self.effective_terms is None else self.effective_terms

    @functools.cached_property
    def mean(self) -> float:   # (kept: the search sorts and compares the candidates by it many times)
        return float(self.heldout.mean())

    @functools.cached_property
    def max(self) -> float:
        return float(self.heldout.max())

    def label(self, axis_names: list[str] | None = None) -> str:
        """Compact ('AP cheb7/cheb6/...', for the table), or in words with ``axis_names``."""
        if axis_names is not None:
            return bases_text(MODELS[self.kind].display_name, axis_names, [a.readable() for a in self.axes])
        labels = [a.label() for a in self.axes]
        body = labels[0] if len(set(labels)) == 1 else "/".join(labels)
        return f"{MODELS[self.kind].display_name} {body}"

    def bases(self, machine: Machine) -> list[AxisBasis]:
        spans = self.spans or (None,) * machine.n_axes
        return [c.basis(a, sp) for a, c, sp in zip(machine.axes, self.axes, spans)]

    def model(self, machine: Machine, **kw):
        """The unfitted model of this candidate (custom bases)."""
        return make_model(self.kind, machine, max(c.order for c in self.axes), bases=self.bases(machine), **kw)

    def to_dict(self, machine: Machine) -> dict:
        return {"kind": self.kind, "bases": {a.name: c.label() for a, c in zip(machine.axes, self.axes)},
                "model_terms": self.n_terms, "heldout_mean_mm": self.mean, "heldout_max_mm": self.max} | \
            ({} if self.effective_terms is None else {"effective_model_terms": self.effective_terms})


class Problem(Design):
    """:class:`~vecpin.selection.design.Design` that scores candidates on its folded problem."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._unpenalised: dict = {}   # the hat matrix' trace of a set of columns without penalties
        self._ends: dict = {}          # axis -> this problem judged on that axis' ends (on_ends)

    def on_ends(self, axis: int, campaign: Campaign) -> "Problem":
        """This problem judged on the ends of ``axis`` only (``campaign``: the rows it was
        linearised on; :meth:`~vecpin.identification.crossval.FoldedProblem.on_ends`):
        its held-out rows judge how a candidate extrapolates beyond the rest of the axis'
        measured span. The same columns, factors and sizes; cached per axis."""
        if axis not in self._ends:
            view = copy.copy(self)
            view.problem = self.problem.on_ends(campaign, axis)
            self._ends[axis] = view
        return self._ends[axis]

    def candidate(self, choice: tuple[AxisChoice, ...]) -> Candidate:
        cols, scale = self.columns(choice)
        return Candidate(self.kind, choice, len(cols) - self.n_fixed, self.problem.heldout(cols, scale),
                         spans=self.spans)

    def candidates(self, choices: list[tuple[AxisChoice, ...]]) -> list[Candidate]:
        """Candidates that share most columns (one axis' basis or smoothing differs), at
        about the cost of one (:meth:`FoldedProblem.heldout_blocks`)."""
        F, sF, blocks = self._shared(choices)
        held = self.problem.heldout_blocks(F, sF, blocks)
        return [Candidate(self.kind, c, len(F) + len(P) - self.n_fixed, h, spans=self.spans)
                for c, (P, _), h in zip(choices, blocks, held)]

    def nested(self, choices: list[tuple[AxisChoice, ...]]) -> list[Candidate]:
        """:meth:`candidate` of each choice; those whose columns nest (each holds a smaller
        one's, the same factors: one family at rising orders) scored as one chain from one
        factorisation per fold (:func:`~vecpin.identification.nested.heldout_nested`)."""
        chains: list[list] = []
        width = 1 + max((int(self.columns(c)[0].max()) for c in choices), default=0)
        for choice in sorted(choices, key=lambda c: len(self.columns(c)[0])):
            cols, fac = self.columns(choice)
            mine = np.full(width, np.nan)                 # this choice's factor per column (nan: not its column)
            mine[cols] = fac
            for chain in chains:
                last, last_fac = self.columns(chain[-1])
                if len(last) < len(cols) and np.array_equal(mine[last], last_fac):
                    chain.append(choice)
                    break
            else:
                chains.append([choice])
        out = {}
        for chain in chains:
            nest = nested_order([self.columns(c) for c in chain]) if len(chain) > 1 else None
            held = heldout_nested(self.problem, *nest) if nest is not None else None
            if held is None:
                out.update((c, self.candidate(c)) for c in chain)
                continue
            out.update((c, Candidate(self.kind, c, n - self.n_fixed, h, spans=self.spans))
                       for c, n, h in zip(chain, nest[2], held))
        return [out[c] for c in choices]

    def _shared(self, choices: list[tuple[AxisChoice, ...]]) -> tuple[np.ndarray, np.ndarray, list]:
        """(F, its factors, [(P_b, factors)]): the columns every choice has with the same
        factor (in the first choice's order: E_0 and the instruments' unknowns first), and
        each choice's others (in its own order)."""
        cols = [self.columns(c) for c in choices]
        width = 1 + max(int(c.max()) for c, _ in cols)
        factor = np.full((len(cols), width), np.nan)      # each choice's factor per column (nan: not its column)
        for row, (c, f) in zip(factor, cols):
            row[c] = f
        same = (factor == factor[0]).all(axis=0)          # nan never equals: columns every choice has, alike
        c0, f0 = cols[0]
        common = same[c0]
        blocks = [(c[~same[c]], f[~same[c]]) for c, f in cols]
        return c0[common], f0[common], blocks

    def size(self, cand: Candidate) -> float:
        """The candidate's number of model terms for the one-SE rule, less what its
        penalised splines' smoothing takes away: n_terms - (t_0 - t_λ), t the trace of
        the hat matrix over its model columns with the penalties λ and without (λ = 0),
        so that a penalised spline's heavily smoothed wiggles count little and every
        other candidate is counted as before."""
        if cand.effective_terms is None and any(a.family == "pspline" for a in cand.axes):
            cols, scale = self.columns(cand.axes)
            cand.effective_terms = cand.n_terms - (self._unpenalised_terms(cols) - self.effective_terms(cols, scale))
        return cand.size

    def sizes(self, cands: list[Candidate]) -> list[float]:
        """:meth:`size` of several candidates, their effective terms at about the cost of
        one: the columns they share eliminated once, the penalised splines of one set of
        columns at every smoothing sharing one bracket
        (:meth:`~vecpin.identification.crossval.FoldedProblem.effective_terms_blocks`)."""
        todo = list({id(c): c for c in cands if c.effective_terms is None
                     and any(a.family == "pspline" for a in c.axes)}.values())
        if len(todo) > 1:
            F, sF, blocks = self._shared([c.axes for c in todo])
            t = self.problem.effective_terms_blocks(F, sF, blocks, skip=self.n_fixed)
            t0 = self.problem.effective_terms_blocks(F, np.ones(len(F)), [(P, np.ones(len(P))) for P, _ in blocks],
                                                     skip=self.n_fixed)
            for c, lam, plain in zip(todo, t, t0):
                c.effective_terms = c.n_terms - (plain - lam)
        return [self.size(c) for c in cands]

    def size_bound(self, cand: Candidate) -> float:
        """A lower bound of :meth:`size` that costs one trace per set of columns (shared
        by every smoothing of them): n_terms - t_0 (t_λ >= 0); the size itself when
        known or when no penalised spline is in the candidate."""
        if cand.effective_terms is not None or not any(a.family == "pspline" for a in cand.axes):
            return cand.size
        return cand.n_terms - self._unpenalised_terms(self.columns(cand.axes)[0])

    def _unpenalised_terms(self, cols: np.ndarray) -> float:
        """t_0: the hat matrix' trace over these columns without penalties (cached)."""
        key = cols.tobytes()
        if key not in self._unpenalised:
            self._unpenalised[key] = self.effective_terms(cols, np.ones(len(cols)))
        return self._unpenalised[key]


class Search:
    """The candidates scored so far (of every kind) and those left out: larger than the
    campaign's equations (``limit``) can determine."""

    def __init__(self):
        self.cands: list[Candidate] = []
        self.scored: dict = {}
        self.left_out: set = set()
        self.limit = math.inf

    def of_kind(self, kind: str) -> "Search":
        """A search of its own for one kind, with this one's candidates of that kind so
        far (the kinds' searches then run side by side, :meth:`merge` joins them)."""
        own = Search()
        own.limit = self.limit   # the campaign's equations: the same for every kind
        own.cands = [c for c in self.cands if c.kind == kind]
        own.scored = {key: c for key, c in self.scored.items() if key[0] == kind}
        own.left_out = {key for key in self.left_out if key[0] == kind}
        return own

    def merge(self, other: "Search") -> None:
        """Add the candidates ``other`` scored (and left out) that this search has not."""
        for c in other.cands:
            if (c.kind, c.axes) not in self.scored:
                self.add(c)
        self.left_out |= other.left_out

    def supported(self, prob: Problem, choice: tuple) -> bool:
        if prob.unknowns(choice) < self.limit:
            return True
        self.left_out.add((prob.kind, choice))
        return False

    def add(self, c: Candidate) -> Candidate:
        self.scored[(c.kind, c.axes)] = c
        self.cands.append(c)
        return c

    def score(self, prob: Problem, choice: tuple) -> Candidate | None:
        key = (prob.kind, choice)
        if key not in self.scored and self.supported(prob, choice):
            self.add(prob.candidate(choice))
        return self.scored.get(key)

    def common(self, prob: Problem, machine: Machine, plans, orders, options) -> None:
        """Every plan (one family on every axis it applies to) at every order, scored in
        chains of nested candidates (:meth:`Problem.nested`), added in the plans' order."""
        todo = {}
        for plan in plans:
            for o in (orders if plan not in ("spline", "pspline") else [None]):
                for plan_axes in plans_at(machine, plan, o, options):
                    if (prob.kind, plan_axes) not in self.scored and self.supported(prob, plan_axes):
                        todo.setdefault(plan_axes, None)
        scored = {c.axes: c for c in prob.nested(list(todo))}
        for choice in todo:
            self.add(scored[choice])

    def refine(self, prob: Problem, options) -> Candidate | None:
        """Around the kind's best, every basis and smoothing of one axis at a time (the
        other axes eliminated once), axis after axis, while the held-out mean improves
        (three passes at most): the best candidate reached."""
        own = [c for c in self.cands if c.kind == prob.kind]
        if not own:
            return None
        cur = min(own, key=lambda c: c.mean)
        for _ in range(3):
            improved = False
            for i in range(len(options)):
                trials = [t for t in (cur.axes[:i] + (o,) + cur.axes[i + 1:] for o in options[i])
                          if (prob.kind, t) not in self.scored and (prob.kind, t) not in self.left_out
                          and self.supported(prob, t)]
                for c in (prob.candidates(trials) if len(trials) > 1 else []):
                    self.add(c)
                for opt in options[i]:
                    c = self.score(prob, cur.axes[:i] + (opt,) + cur.axes[i + 1:])
                    if c is not None and c.mean < cur.mean:
                        cur, improved = c, True
            if not improved:
                break
        return cur


def supported(options: list[AxisChoice], q: np.ndarray) -> list[AxisChoice]:
    """The options with no more terms than the axis has distinct positions ``q`` (the
    smallest when none has): more could not be told apart on this campaign."""
    n = len(np.unique(np.round(q, 9)))
    return [o for o in options if o.size <= n] or [min(options, key=lambda o: o.size)]


def plans_at(machine: Machine, plan: str, order: int | None, options) -> list[tuple[AxisChoice, ...]]:
    """Candidates with one family everywhere it applies (Chebyshev elsewhere) at one
    order: a per-turn series of the lowest order offered that is at least ``order``."""
    out = []
    if plan == "spline":
        knots = sorted({o.order for opts in options for o in opts if o.family == "spline"})
        for k in knots:
            out.append(tuple(AxisChoice("spline", k) if AxisChoice("spline", k) in opts else opts[0]
                             for opts in options))
        return out
    if plan == "pspline":  # one knot count and smoothing on every axis
        for c in dict.fromkeys(o for opts in options for o in opts if o.family == "pspline"):
            out.append(tuple(c if c in opts else opts[0] for opts in options))
        return out
    cheb = AxisChoice("chebyshev", order)
    if plan == "chebyshev":  # capped where an axis has too few positions for this order
        return [tuple(cheb if cheb in opts else max((o for o in opts if o.family == "chebyshev" and o.order < order),
                                                    key=lambda o: o.order, default=opts[0]) for opts in options)]
    per_turn = [o for opts in options for o in opts if o.family == plan]
    if not per_turn:
        return out
    fo = min((o.order for o in per_turn if o.order >= order), default=max(o.order for o in per_turn))
    for t in sorted({o.trend for o in per_turn}):
        c = AxisChoice(plan, fo, t)
        row = tuple(c if c in opts else (cheb if cheb in opts else opts[0]) for opts in options)
        if any(x.family == plan for x in row):
            out.append(row)
    return out


def one_standard_error(cands: list[Candidate], best: Candidate, size: Callable[[Candidate], float] | None = None,
                       bound: Callable[[Candidate], float] | None = None) -> tuple[Candidate, float, str]:
    """The fewest terms among the candidates within one paired standard error of the best
    (``size``: a candidate's number of terms, default ``n_terms``; only asked of those
    within, and with ``bound``, a lower bound of it, only of those the bound leaves a
    chance: :func:`_fewest`)."""
    size = size or (lambda c: c.n_terms)
    n = best.heldout.size
    ok = []
    for c in cands:
        delta = c.heldout - best.heldout
        se = float(np.std(delta, ddof=1) / math.sqrt(n)) if n > 1 else 0.0
        if delta.mean() <= se:
            ok.append((c, se))
    chosen, se = _fewest(ok, size, bound)
    if chosen is best:
        return best, 0.0, f"lowest held-out mean ({best.mean:.4f} mm); no smaller model within one standard error"
    return chosen, se, (f"the fewest model terms within one standard error ({se:.4f} mm) of the lowest held-out "
                        f"mean ({best.label()}, {best.n_terms} model terms, {best.mean:.4f} mm)")


def _fewest(ok: list[tuple[Candidate, float]], size: Callable[[Candidate], float],
            bound: Callable[[Candidate], float] | None) -> tuple[Candidate, float]:
    """The (candidate, se) of ``ok`` that is least by (whole terms, nominal terms, mean):
    sizes in whole terms, so a smoothing that leaves as many effective terms as a plain
    candidate ties with it and the tie goes to the plain one. With ``bound`` (a lower
    bound of ``size``), candidates are taken in the order of their bound and the search
    stops where no later one can win, the sizes of the rest never computed."""
    key = lambda i, f: (round(f(ok[i][0])), ok[i][0].n_terms, ok[i][0].mean, i)   # noqa: E731 (exact ties: the first)
    if bound is None:
        return ok[min(range(len(ok)), key=lambda i: key(i, size))]
    best, best_key = None, None
    for i in sorted(range(len(ok)), key=lambda i: key(i, bound)):
        if best_key is not None and key(i, bound) > best_key:
            break
        k = key(i, size)
        if best_key is None or k < best_key:
            best, best_key = ok[i], k
    return best
