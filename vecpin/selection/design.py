"""The candidate bases of each axis and the linearised problem that scores them.

Per axis the candidate bases are (:class:`AxisChoice`): Chebyshev series over the
travel and cubic B-splines with uniform knots (local errors); on a rotary axis that
travels more than a turn also Fourier series per turn, alone or with a Chebyshev trend
over the travel. :class:`Design` linearises one model kind at the nominal machine with
the union of every candidate function of every axis as columns (the kind's own
``candidate_columns``) and folds it for cross-validation
(:class:`vecpin.identification.crossval.FoldedProblem`), so a candidate's held-out
distances are a small solve per fold over its columns (:mod:`vecpin.selection.choice`).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from vecpin.errors import InputError
from vecpin.identification.crossval import FoldedProblem
from vecpin.identification.folds import command_folds
from vecpin.identification.likelihood import Likelihood
from vecpin.identification.redundancy import active_columns
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.poses import pose_blocks, sweep_folds
from vecpin.models import make_model
from vecpin.models.basis import AxisBasis, basis_text, smoothing_transform
from vecpin.models.recorded import STILL_SHARE
from vecpin.units import norm_mm

FAMILIES = ("chebyshev", "fourier", "fourier_trend", "spline", "pspline")
# what the default choice tries: penalised splines in place of plain ones (their columns span
# the plain splines of 3, 7 and 15 knots; the smoothing chosen by held-out data). On the
# spline and bump truths of benchmarks/bench_fit.py they bring the fit to 0.9-1.24x (plain:
# 1.1-1.7x) and 1.6-2.3x (plain: 2.3-3.1x) of the true family's fit and the tables to at
# most 1.13x the floor (plain: 1.32x), with a 590-row default fit of about 2 s; 31 knots
# gain a little more on bumps at 4-12 s, so 15 it is
DEFAULT_FAMILIES = ("chebyshev", "fourier", "fourier_trend", "pspline")
CHEB_ORDERS = tuple(range(0, 9))
FOURIER_ORDERS = (2, 4, 6, 8, 10, 12)
TRENDS = (1, 2, 4, 6, 8)
SPLINE_KNOTS = (3, 7, 15)
PSPLINE_KNOTS = 15        # interior knots of the penalised splines: 16 intervals over the travel
SMOOTHING = tuple(10.0 ** k for k in range(0, 9))  # their smoothing penalties λ, chosen by held-out data
PART_OF_TRAVEL = 0.9      # an axis whose commands span less of its travel is judged on extrapolation too


@dataclass(frozen=True)
class AxisChoice:
    """The basis of one axis: ``family`` and ``order`` (series order; interior knots of
    a spline), ``trend`` (Chebyshev trend order beside a Fourier series), ``smoothing``
    (the penalty λ of a penalised spline, :mod:`vecpin.models.basis`)."""

    family: str
    order: int
    trend: int = 0
    smoothing: float = 0.0

    def __post_init__(self):   # the hash kept: the search looks choices (tuples of these) up thousands of times
        object.__setattr__(self, "_hash", hash((self.family, self.order, self.trend, self.smoothing)))

    def __hash__(self) -> int:
        return self._hash

    def __getstate__(self) -> dict:   # a copy in another process hashes its strings anew
        return {k: v for k, v in self.__dict__.items() if k != "_hash"}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self.__post_init__()

    def basis(self, axis, span: tuple[float, float] | None = None) -> AxisBasis:
        """The basis on ``axis``: a Chebyshev series or a spline over ``span`` (lowest,
        highest command [m, rad], :func:`measured_spans`; default the travel), a series
        per turn (periodic) and its trend over the travel."""
        rot = axis.kind == "rotary"
        lo, hi = span or (axis.lower, axis.upper)
        if self.family == "chebyshev":
            return AxisBasis(lo, hi, self.order, "chebyshev", rotary=rot)
        if self.family == "fourier":
            return AxisBasis(axis.lower, axis.upper, self.order, "fourier", rotary=rot)
        if self.family == "fourier_trend":
            return AxisBasis(axis.lower, axis.upper, self.order, "fourier_trend", rotary=rot, trend=self.trend)
        if self.family in ("spline", "pspline"):
            knots = np.linspace(lo, hi, self.order + 2)[1:-1]
            return AxisBasis(lo, hi, 3, "bspline" if self.family == "spline" else "pspline",
                             rotary=rot, knots=tuple(knots), smoothing=self.smoothing)
        raise InputError(f"unknown basis family '{self.family}' (one of {', '.join(FAMILIES)})")

    def functions(self, spanned: bool = False) -> tuple[str, ...]:
        """Names of its non-constant functions in the union of :func:`axis_functions`
        (``spanned``: the axis' Chebyshev series lie over a measured span, so a trend over
        the travel is a function of its own, ``t1..``; else it is the series' ``c1..``)."""
        return _functions(self, spanned)

    def scales(self) -> np.ndarray:
        """The factor of each of :meth:`functions` on the union's column: 1, except a
        penalised spline's ``1 / sqrt(1 + λ e_j)`` (its union columns are those of λ = 0)."""
        return _scales(self).copy()

    @property
    def size(self) -> int:
        return 1 + len(self.functions())

    def readable(self) -> str:
        """In words: 'Chebyshev order 7', 'spline, 15 knots' (:func:`vecpin.models.basis.basis_text`)."""
        return basis_text(self.family, 3 if self.family in ("spline", "pspline") else self.order, self.trend,
                          self.order, self.smoothing)

    def label(self) -> str:
        return {"chebyshev": f"cheb{self.order}", "fourier": f"fourier{self.order}",
                "fourier_trend": f"fourier{self.order}+trend{self.trend}", "spline": f"spline{self.order}",
                "pspline": f"pspline{self.order}@{self.smoothing:.3g}"}[self.family]


# An AxisChoice's functions and factors, made once per choice: the search asks for them thousands of
# times, and a penalised spline's factors take an eigendecomposition each.
@functools.lru_cache(maxsize=4096)
def _functions(choice: AxisChoice, spanned: bool) -> tuple[str, ...]:
    """:meth:`AxisChoice.functions`."""
    if choice.family == "chebyshev":
        return tuple(f"c{j}" for j in range(1, choice.order + 1))
    if choice.family in ("fourier", "fourier_trend"):
        four = tuple(f"{'cos' if j % 2 else 'sin'}{math.ceil(j / 2)}" for j in range(1, choice.order + 1))
        return four + tuple(f"{'t' if spanned else 'c'}{j}" for j in range(1, choice.trend + 1))
    return tuple(f"{'b' if choice.family == 'spline' else 'p'}{choice.order}.{i}" for i in range(1, choice.order + 4))


@functools.lru_cache(maxsize=4096)
def _scales(choice: AxisChoice) -> np.ndarray:
    """:meth:`AxisChoice.scales` (the cached array: callers get a copy)."""
    if choice.family != "pspline":
        return np.ones(len(_functions(choice, False)))
    e = smoothing_transform(choice.order + 3, 0.0)[1]
    return 1.0 / np.sqrt(1.0 + choice.smoothing * e)


def axis_options(axis, orders=CHEB_ORDERS, families=DEFAULT_FAMILIES, fixed_order: bool = False,
                 measured: float | None = None) -> list[AxisChoice]:
    """Every basis worth trying on an axis. ``fixed_order``: ``orders`` holds the one
    order the user fixed, which defines every family's size: Chebyshev and Fourier
    series of that order, Fourier plus a trend of at most that order, splines with
    that many interior knots. ``measured``: the span of the axis' commands [rad]; series
    per turn only when it is a turn or more (:func:`per_turn_measured`)."""
    out = []
    if "chebyshev" in families:
        out += [AxisChoice("chebyshev", o) for o in orders]
    if axis.multiturn and (measured is None or per_turn_measured(measured)):
        if "fourier" in families:
            out += [AxisChoice("fourier", o) for o in
                    (orders if fixed_order else [o for o in FOURIER_ORDERS if o <= 2 * max(orders, default=0) + 2])]
        if "fourier_trend" in families:
            out += [AxisChoice("fourier_trend", o, t) for o in (orders if fixed_order else FOURIER_ORDERS[:4])
                    for t in TRENDS if not fixed_order or t <= o]
    if "spline" in families:
        out += [AxisChoice("spline", k) for k in (orders if fixed_order else SPLINE_KNOTS)]
    if "pspline" in families:
        out += [AxisChoice("pspline", k, 0, lam) for k in (orders if fixed_order else (PSPLINE_KNOTS,))
                for lam in SMOOTHING]
    return out


def per_turn_measured(span: float) -> bool:
    """True when commands spanning ``span`` [rad] cover a whole turn: a series per turn
    (errors that repeat every turn) can be told from one over the travel only then, and
    from less it extrapolates over the rest of the turn as it likes (a UR10's joint 1
    measured over 128°: the choice took 12 terms per turn there, 12.0 mm held-out mean
    just beyond the measured part; without series per turn 0.73 mm)."""
    return span >= 2 * math.pi * (1 - 1e-9)


def partly_measured(machine: Machine, campaign: Campaign, travel: tuple[np.ndarray, np.ndarray] | None = None
                    ) -> tuple[int, ...]:
    """Indices of the axes whose commands span less than :data:`PART_OF_TRAVEL` of the
    travel: the model will be used beyond what the campaign measured there (a robot works
    beyond its calibration poses, a prediction is asked over the whole travel), so the
    choice holds out the commands at both ends of their measured span
    (:func:`command_folds`' ``ends``) and judges how each candidate extrapolates along
    them. ``travel``: (low, high) [m, rad] per axis, where the model will be used
    (default: the axes' limits; a zone's model is used in its zone only). An axis that
    stood still (:data:`~vecpin.models.recorded.STILL_SHARE`) has no span whose ends could
    be held out: the fit says it did not move and holds its errors where it stood."""
    lo, hi = (machine.lower, machine.upper) if travel is None else travel
    span = np.ptp(campaign.q, axis=0)
    return tuple(a.index for a, sp in zip(machine.axes, span)
                 if STILL_SHARE * a.travel <= sp < PART_OF_TRAVEL * (hi[a.index] - lo[a.index]))


def axis_functions(axis, options: list[AxisChoice], q: np.ndarray,
                   span: tuple[float, float] | None = None) -> tuple[list[str], np.ndarray]:
    """The union of the options' non-constant functions at positions q: (names, (N, F));
    ``span``: as :meth:`AxisChoice.basis`."""
    names, cols = [], []
    cheb = max((o.order for o in options if o.family == "chebyshev"), default=0)
    trend = max((o.trend for o in options), default=0)
    travel = (axis.lower, axis.upper)
    series = [("c", cheb, span), ("t", trend, travel)] if span else [("c", max(cheb, trend), travel)]
    for prefix, order, (lo, hi) in series:   # a trend is the series' c1.. unless they lie over a span
        if order:
            names += [f"{prefix}{j}" for j in range(1, order + 1)]
            cols.append(AxisBasis(lo, hi, order, rotary=axis.kind == "rotary").values(q)[:, 1:])
    four = max((o.order for o in options if o.family in ("fourier", "fourier_trend")), default=0)
    if four:
        names += list(AxisChoice("fourier", four).functions())
        cols.append(AxisChoice("fourier", four).basis(axis).values(q)[:, 1:])
    for fam in ("spline", "pspline"):
        for k in sorted({o.order for o in options if o.family == fam}):
            names += list(AxisChoice(fam, k).functions())
            cols.append(AxisChoice(fam, k).basis(axis, span).values(q)[:, 1:])
    return names, (np.concatenate(cols, axis=1) if cols else np.zeros((len(q), 0)))


def measured_spans(machine: Machine, campaign: Campaign, travel: tuple[np.ndarray, np.ndarray] | None = None
                   ) -> tuple[tuple[float, float] | None, ...]:
    """Per axis, where its Chebyshev series and splines are built: (lowest, highest)
    command of ``campaign`` [m, rad] on the axes it measured over part of their travel
    (:func:`partly_measured`), None (the travel) elsewhere. A series over the whole
    travel of an axis measured over a part of it resolves little of that part (a UR10's
    joint 1 measured over 128° of its 720°, where its errors have periods of about 30°)
    and extrapolates beyond it what no command measured; over the measured span the same
    series resolve the part, and beyond it only each function's straight-line part carries
    on from its value at the nearer end (:class:`~vecpin.models.basis.AxisBasis`)."""
    ends = partly_measured(machine, campaign, travel)
    lo, hi = campaign.q.min(axis=0), campaign.q.max(axis=0)
    return tuple((float(lo[k]), float(hi[k])) if k in ends and hi[k] > lo[k] else None for k in range(machine.n_axes))


def fold_index(labels: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
    """(n,) fold indices 0..k-1 of the given rows (None: all) from one fold label per row."""
    labels = np.asarray(labels)
    return np.unique(labels if rows is None else labels[rows], return_inverse=True)[1].ravel()


def choice_folds(campaign: Campaign, k, seed: int, ends=(), rows: np.ndarray | None = None) -> tuple[np.ndarray, str]:
    """(the fold of each row, what the folds keep together): ``k`` labels, one per row of the
    whole campaign (the user's own folds; ``rows``: the rows of it ``campaign`` holds, None:
    all); else whole sweeps where the design moves one joint at a time
    (:func:`~vecpin.measurement.poses.pose_blocks`), else poses, the ends of the axes ``ends``
    held out whole (:func:`command_folds`); ``seed``: the deal."""
    if np.ndim(k):
        return fold_index(k, rows), "the given fold labels"
    swept, rng = pose_blocks(campaign, k), np.random.default_rng(seed)
    if swept is None:
        return command_folds(campaign, k, rng, ends), "pose"
    return sweep_folds(swept, k, rng), f"sweep ({swept.max() + 1} sweeps: one joint moved each)"


class Design:
    """The linearised problem at the nominal machine on one campaign, with every
    candidate function of every axis for one model kind, folded for cross-validation:
    :attr:`problem` (:class:`~vecpin.identification.crossval.FoldedProblem`, columns
    ``J``, ``A`` (N,3,P), residuals ``w``, ``r`` (N,3), the judged rows and the normal
    equations of every fold left out; folds ``fold`` grouped by command).

    The first :attr:`n_fixed` columns are in every candidate: E_0 (station 0's pose
    correction) and the instruments' own unknowns (other stations' poses, ball-bar
    pivots, tool targets, nest positions). Then the kind's own candidate columns
    (:meth:`~vecpin.models.base.ErrorModel.candidate_columns`: the offsets, the constants
    and every candidate function, its ``assemble`` over the union of the axes' candidate
    bases), each scaled by the prior standard deviation of its term in the model the
    candidate builds (``opts``: the model options, ``prior_scale`` and ``tool_lengths``),
    so the unit ridge of the solves is the model's own prior. ``setup``: the tracker
    poses to linearise at (default: registered on this campaign). ``spans``: per axis,
    where its bases are built (:func:`measured_spans`; default the travel)."""

    def __init__(self, kind: str, machine: Machine, campaign: Campaign, noise: NoiseModel, options,
                 fold: np.ndarray, opts: dict | None = None, setup=None, spans: tuple | None = None):
        self.kind, self.machine = kind, machine
        self.spans = tuple(spans or (None,) * machine.n_axes)
        c = campaign
        opts = {k: v for k, v in (opts or {}).items() if k in ("tool_lengths", "prior_scale")}
        self.proto = make_model(kind, machine, 0, **opts)
        lik = Likelihood(self.proto, c, noise, setup=setup)                  # at the nominal machine
        self.setup = lik.setup
        ev = lik.evaluate(np.zeros(lik.n_unknowns), operators=True)
        point = ev.valid.all(axis=1) & np.isfinite(ev.y).all(axis=1)
        judged = point if point.any() else ev.valid[:, 0]
        # every row's own point (tool tip, target, nest) through the one likelihood's requests
        tool_dir, S = lik.sensitivity(self.proto)
        functions = [axis_functions(a, options[i], c.q[:, i], self.spans[i]) for i, a in enumerate(machine.axes)]
        D, terms = self.proto.candidate_columns(S, c.tool, tool_dir, functions)   # d point / d psi (N,3,P)
        # E_0 and the instruments' unknowns (stations, pivots, targets, nests) are in every candidate
        fixed = np.r_[np.arange(6), np.arange(6 + lik.n_model, lik.n_unknowns)]
        self.n_fixed = len(fixed)
        # each term's function: its place in the axes' functions laid end to end (the last place: none)
        place = {(a.name, f): k for k, (a, f) in enumerate((a, f) for a, (names, _) in zip(machine.axes, functions)
                                                           for f in names)}
        self._places = place
        self._term_place = np.array([place.get((p.axis, p.label), len(place)) for p in terms], int)
        # the prediction's derivatives (the residual's, negated: crossval's convention)
        J = np.negative(np.concatenate([ev.J[:, :, fixed], ev.Gw @ D], axis=-1))
        A = np.negative(np.concatenate([ev.A[:, :, fixed], ev.Gm @ D], axis=-1))
        del D
        self.problem = FoldedProblem(J, A, ev.w, ev.metric, fold, judged)
        self.judged = judged
        self.uncompensated = norm_mm(ev.metric[judged])
        # what a fit counts (identification.fit): its equations, and the columns that move anything
        self.n_equations = int(ev.valid.sum())
        self.valid = ev.valid                                           # (N,3) each row's real equations
        self.active = active_columns(np.sqrt(np.einsum("nkp,nkp->p", J, J)))
        self._columns: dict = {}

    def unknowns(self, choice: tuple[AxisChoice, ...]) -> int:
        """The unknowns a fit of this candidate counts against the equations: its columns
        that move anything (E_0 and the instruments' unknowns included)."""
        return int(self.active[self.columns(choice)[0]].sum())

    def columns(self, choice: tuple[AxisChoice, ...]) -> tuple[np.ndarray, np.ndarray]:
        """(column indices, factor on each) of a candidate: E_0 and the instruments'
        unknowns, then its model's terms (the offsets, the constants and the terms of its
        functions, in the union's order); the factors are 1 except a penalised spline's
        (:meth:`AxisChoice.scales`)."""
        known = self._columns.get(choice)
        if known is not None:
            return known
        chosen, factor = np.zeros(len(self._places) + 1, bool), np.ones(len(self._places) + 1)
        chosen[-1] = True                                           # the terms of no function
        for a, c in zip(self.machine.axes, choice):
            at = [self._places[(a.name, f)] for f in c.functions(self.spans[a.index] is not None)]
            chosen[at], factor[at] = True, c.scales()
        mine = chosen[self._term_place]
        self._columns[choice] = (np.r_[np.arange(self.n_fixed), self.n_fixed + np.flatnonzero(mine)],
                                 np.r_[np.ones(self.n_fixed), factor[self._term_place[mine]]])
        return self._columns[choice]

    def effective_terms(self, cols: np.ndarray, scale: np.ndarray) -> float:
        """The effective number of model terms, trace((G + I)^-1 G) over the model's
        columns: what the data determine beyond the prior (a penalised spline's smooth
        shapes count one each, its penalised wiggles little)."""
        return self.problem.effective_terms(cols, scale, skip=self.n_fixed)
