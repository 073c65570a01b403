"""Let the data choose the model: kind, basis of every axis and order, by held-out data.

Every candidate model is a set of columns of one linearised problem. The models are
linear in their parameters to about 1e-4 around the nominal machine, the whitening of
each row (instrument and positioning noise, :mod:`vecpin.identification.likelihood`)
does not depend on the model, and a model's columns are the kinematic sensitivity of
each axis' error components times functions of that axis' position. So one set of
normal equations per model kind, over the union of every candidate function of every
axis, serves the k-fold cross-validation of every candidate: a small solve per
candidate and fold (folds grouped by command, both tools of a pose in one fold).

Per axis the candidate bases are (:class:`AxisChoice`): Chebyshev series over the
travel (orders 0-8) and cubic B-splines with uniform knots (local errors); on a rotary
axis that travels more than a turn also Fourier series per turn, alone or with a
Chebyshev trend over the travel (errors that repeat every turn, and those that do not:
cable wind-up, torsion, a gear behind the encoder, drift over a long travel). The
search scores every model kind with one family on all axes at a common order, then
refines axis by axis (family and order) from the best; the choice follows the
one-standard-error rule: among the candidates whose held-out mean distance is within
one paired standard error of the lowest, the one with the fewest terms.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy import linalg

from vecpin.errors import InputError
from vecpin.identification.crossval import command_folds
from vecpin.identification.likelihood import Likelihood
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.registration import check_campaign_frames
from vecpin.models import MODELS, ErrorModel, make_model
from vecpin.models.basis import AxisBasis
from vecpin.models.parameters import DEFAULT_PRIORS
from vecpin.selection.orders import check_folds
from vecpin.units import MM_PER_M, M_PER_MM

KINDS = ("6dof", "ap")
FAMILIES = ("chebyshev", "fourier", "fourier_trend", "spline")
CHEB_ORDERS = tuple(range(0, 9))
FOURIER_ORDERS = (2, 4, 6, 8, 10, 12)
TRENDS = (1, 2, 4, 6, 8)
SPLINE_KNOTS = {"short": (3, 7, 15), "multiturn": (3, 7, 15)}
MAX_SELECTION_ROWS = 3000  # larger campaigns choose on a subsample grouped by command


def multiturn(axis) -> bool:
    return axis.kind == "rotary" and axis.travel > 2 * math.pi + 1e-9


@dataclass(frozen=True)
class AxisChoice:
    """The basis of one axis: ``family`` and ``order`` (series order; interior knots of
    a spline), ``trend`` (Chebyshev trend order beside a Fourier series)."""

    family: str
    order: int
    trend: int = 0

    def basis(self, axis) -> AxisBasis:
        rot = axis.kind == "rotary"
        if self.family == "chebyshev":
            return AxisBasis(axis.lower, axis.upper, self.order, "chebyshev", rotary=rot)
        if self.family == "fourier":
            return AxisBasis(axis.lower, axis.upper, self.order, "fourier", rotary=rot)
        if self.family == "fourier_trend":
            return AxisBasis(axis.lower, axis.upper, self.order, "fourier_trend", rotary=rot, trend=self.trend)
        if self.family == "spline":
            knots = np.linspace(axis.lower, axis.upper, self.order + 2)[1:-1]
            return AxisBasis(axis.lower, axis.upper, 3, "bspline", rotary=rot, knots=tuple(knots))
        raise InputError(f"unknown basis family '{self.family}' (one of {', '.join(FAMILIES)})")

    def functions(self) -> tuple[str, ...]:
        """Names of its non-constant functions in the union of :func:`_axis_functions`."""
        if self.family == "chebyshev":
            return tuple(f"c{j}" for j in range(1, self.order + 1))
        if self.family in ("fourier", "fourier_trend"):
            four = tuple(f"{'cos' if j % 2 else 'sin'}{math.ceil(j / 2)}" for j in range(1, self.order + 1))
            return four + tuple(f"c{j}" for j in range(1, self.trend + 1))
        return tuple(f"b{self.order}.{i}" for i in range(1, self.order + 4))

    @property
    def size(self) -> int:
        return 1 + len(self.functions())

    def label(self) -> str:
        return {"chebyshev": f"cheb{self.order}", "fourier": f"fourier{self.order}",
                "fourier_trend": f"fourier{self.order}+trend{self.trend}", "spline": f"spline{self.order}"}[self.family]


def axis_options(axis, orders=CHEB_ORDERS, families=FAMILIES) -> list[AxisChoice]:
    """Every basis worth trying on an axis."""
    out = []
    if "chebyshev" in families:
        out += [AxisChoice("chebyshev", o) for o in orders]
    if multiturn(axis):
        if "fourier" in families:
            out += [AxisChoice("fourier", o) for o in FOURIER_ORDERS if o <= 2 * max(orders, default=0) + 2]
        if "fourier_trend" in families:
            out += [AxisChoice("fourier_trend", o, t) for o in FOURIER_ORDERS[:4] for t in TRENDS]
    if "spline" in families:
        out += [AxisChoice("spline", k) for k in SPLINE_KNOTS["multiturn" if multiturn(axis) else "short"]]
    return out


def _axis_functions(axis, options: list[AxisChoice], q: np.ndarray) -> tuple[list[str], np.ndarray]:
    """The union of the options' non-constant functions at positions q: (names, (N, F))."""
    names, cols = [], []
    cheb = max((o.order for o in options if o.family == "chebyshev"), default=0)
    cheb = max([cheb] + [o.trend for o in options])
    if cheb:
        names += [f"c{j}" for j in range(1, cheb + 1)]
        cols.append(AxisBasis(axis.lower, axis.upper, cheb, rotary=axis.kind == "rotary").values(q)[:, 1:])
    four = max((o.order for o in options if o.family in ("fourier", "fourier_trend")), default=0)
    if four:
        names += list(AxisChoice("fourier", four).functions())
        cols.append(AxisChoice("fourier", four).basis(axis).values(q)[:, 1:])
    for k in sorted({o.order for o in options if o.family == "spline"}):
        names += list(AxisChoice("spline", k).functions())
        cols.append(AxisChoice("spline", k).basis(axis).values(q)[:, 1:])
    return names, (np.concatenate(cols, axis=1) if cols else np.zeros((len(q), 0)))


@dataclass
class Candidate:
    """One model: kind, a basis per axis, held-out distances [mm] per judged row."""

    kind: str
    axes: tuple[AxisChoice, ...]
    n_terms: int
    heldout: np.ndarray = field(repr=False)

    @property
    def mean(self) -> float:
        return float(self.heldout.mean())

    @property
    def max(self) -> float:
        return float(self.heldout.max())

    def label(self) -> str:
        labels = [a.label() for a in self.axes]
        body = labels[0] if len(set(labels)) == 1 else "/".join(labels)
        return f"{MODELS[self.kind].display_name} {body}"

    def bases(self, machine: Machine) -> list[AxisBasis]:
        return [c.basis(a) for a, c in zip(machine.axes, self.axes)]

    def model(self, machine: Machine, **kw):
        """The unfitted model of this candidate (custom bases)."""
        return make_model(self.kind, machine, max(c.order for c in self.axes), bases=self.bases(machine), **kw)

    def to_dict(self, machine: Machine) -> dict:
        return {"kind": self.kind, "bases": {a.name: c.label() for a, c in zip(machine.axes, self.axes)},
                "terms": self.n_terms, "heldout_mean_mm": self.mean, "heldout_max_mm": self.max}


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

    def table(self, limit: int = 30) -> str:
        lines = [f"model choice: {len(self.candidates)} candidates by {self.folds}-fold cross-validation grouped by "
                 f"command ({self.rows} rows judged, linearised), mm",
                 f"  {'candidate':<58s} {'terms':>5s} {'held-out mean':>13s} {'max':>8s}",
                 f"  {'uncompensated':<58s} {'':>5s} {self.uncompensated_mm[0]:13.4f} {self.uncompensated_mm[1]:8.4f}"]
        shown = sorted(self.candidates, key=lambda c: c.mean)[:limit]
        if self.chosen not in shown:
            shown.append(self.chosen)
        for c in sorted(shown, key=lambda c: c.mean):
            mark = " <- chosen" if c is self.chosen else (" <- lowest" if c is self.best else "")
            lines.append(f"  {c.label():<58s} {c.n_terms:5d} {c.mean:13.4f} {c.max:8.4f}{mark}")
        if len(self.candidates) > len(shown):
            lines.append(f"  ({len(self.candidates) - len(shown)} more candidates scored, not shown)")
        lines.append(f"chosen: {self.chosen.label()} ({self.chosen.n_terms} terms): {self.reason}")
        return "\n".join(lines)

    def sweep(self, kind: str) -> list[Candidate]:
        """The common-order candidates of one kind with Chebyshev everywhere (Paper I Table 2)."""
        return sorted([c for c in self.candidates if c.kind == kind and len(set(c.axes)) == 1
                       and c.axes[0].family == "chebyshev"], key=lambda c: c.axes[0].order)

    def to_dict(self) -> dict:
        return {"method": f"{self.folds}-fold cross-validation grouped by command, linearised at the nominal machine",
                "rule": "one standard error: the fewest terms within one paired standard error of the lowest mean",
                "rows": self.rows, "standard_error_mm": self.standard_error_mm, "reason": self.reason,
                "seconds": None, "uncompensated_mm": {"mean": self.uncompensated_mm[0], "max": self.uncompensated_mm[1]},
                "chosen": self.chosen.to_dict(self.machine), "lowest": self.best.to_dict(self.machine),
                "candidates": [c.to_dict(self.machine) for c in sorted(self.candidates, key=lambda c: c.mean)]}


class _Problem:
    """The linearised problem at the nominal machine, with every candidate function of
    every axis for one model kind: fold normal equations of the whitened columns."""

    def __init__(self, kind: str, machine: Machine, campaign: Campaign, noise: NoiseModel, options, fold, folds):
        self.kind, self.machine = kind, machine
        c = campaign
        zero = make_model("ap", machine, 0)
        lik = Likelihood(zero, c, noise)
        ev = lik.evaluate(np.zeros(lik.n_unknowns), operators=True)
        point = ev.valid.all(axis=1) & np.isfinite(ev.y).all(axis=1)
        self.judged = point if point.any() else ev.valid[:, 0]
        self.metric, self.fold = ev.metric, fold
        # every row's own point (tool tip, target, nest) through the one likelihood's requests
        proto = make_model(kind, machine, 0)
        tool_dir, S = lik.sensitivity(proto)
        # E_0 and the instruments' unknowns (stations, pivots, targets, nests) are in every candidate
        self.fixed = np.r_[np.arange(6), np.arange(6 + lik.n_model, lik.n_unknowns)]
        self.slots = list(proto.slot_axis) if kind == "6dof" else list(range(machine.n_axes))
        n = machine.n_axes
        cols, index = [tool_dir * DEFAULT_PRIORS["offset"]], {("T_offset",): 0}
        prior = np.array([DEFAULT_PRIORS["length"] if a.kind == "linear" else DEFAULT_PRIORS["angle"] for a in machine.axes])
        if kind == "ap":  # a constant per output; per input axis its functions into every output
            for j in range(n):
                index[("offset", j)] = len(cols)
                cols.append(S[:, :, j] * prior[j])
        functions = [_axis_functions(a, options[i], c.q[:, i]) for i, a in enumerate(machine.axes)]
        if kind == "6dof":  # per slot (an axis or a mimic joint), in its driving axis' functions
            for s, i in enumerate(self.slots):
                names, F = functions[i]
                for f, name in enumerate(names):
                    for comp in range(6):
                        index[(s, name, comp)] = len(cols)
                        cols.append(S[:, :, s, comp] * F[:, f, None] * M_PER_MM)
        else:
            for i in range(n):
                names, F = functions[i]
                for f, name in enumerate(names):
                    for j in range(n):
                        index[(i, name, j)] = len(cols)
                        cols.append(S[:, :, j] * F[:, f, None] * prior[j])
        if kind == "6dof":  # the constant of every slot's six components
            for s in range(len(self.slots)):
                for comp in range(6):
                    index[(s, "0", comp)] = len(cols)
                    cols.append(S[:, :, s, comp] * M_PER_MM)
        D = np.stack(cols, axis=-1)                                     # d point / d psi (N,3,P)
        self.J = np.concatenate([ev.J[:, :, self.fixed], np.einsum("pij,pjk->pik", ev.Gw, D)], axis=-1)
        self.A = np.concatenate([ev.A[:, :, self.fixed], np.einsum("pij,pjk->pik", ev.Gm, D)], axis=-1)
        self.index = index
        w = ev.w
        grams = []
        for f in range(folds):
            sel = fold == f
            Jf = self.J[sel].reshape(-1, self.J.shape[-1])
            grams.append((Jf.T @ Jf, Jf.T @ w[sel].ravel()))
        G, g = sum(v[0] for v in grams), sum(v[1] for v in grams)
        # each fold's estimate comes from the normal equations of the other folds
        self.train = [(G - Gf, g - gf) for Gf, gf in grams]
        self.test = [(np.flatnonzero(fold == f), self.A[fold == f]) for f in range(folds)]
        self.uncompensated = np.linalg.norm(ev.metric[self.judged], axis=1) * MM_PER_M

    def columns(self, choice: tuple[AxisChoice, ...]) -> np.ndarray:
        """Column indices of a candidate: E_0 and the instruments' unknowns, T_offset,
        then its functions (6-DoF: on every slot the axis drives)."""
        idx = [0]
        n = self.machine.n_axes
        nf = len(self.fixed)
        if self.kind == "ap":
            idx += [self.index[("offset", j)] for j in range(n)]
            for i, c in enumerate(choice):
                idx += [self.index[(i, name, k)] for name in c.functions() for k in range(n)]
        else:
            for s, i in enumerate(self.slots):
                idx += [self.index[(s, "0", k)] for k in range(6)]
                idx += [self.index[(s, name, k)] for name in choice[i].functions() for k in range(6)]
        return np.r_[np.arange(nf), nf + np.array(idx, int)]

    def heldout(self, cols: np.ndarray) -> np.ndarray:
        """Held-out distances [mm] of the judged rows for the candidate with these columns."""
        held = np.empty_like(self.metric)
        ix = np.ix_(cols, cols)
        N = np.stack([Gt[ix] for Gt, _ in self.train]) + np.eye(len(cols))
        rhs = np.stack([gt[cols] for _, gt in self.train])
        L = np.linalg.cholesky(N)  # batched over the folds
        psi = -_cho_solve(L, rhs)
        for (te, A_te), p in zip(self.test, psi):
            held[te] = self.metric[te] + A_te[:, :, cols] @ p
        return np.linalg.norm(held[self.judged], axis=1) * MM_PER_M

    def candidate(self, choice: tuple[AxisChoice, ...]) -> Candidate:
        cols = self.columns(choice)
        return Candidate(self.kind, choice, len(cols) - len(self.fixed), self.heldout(cols))


def _cho_solve(L: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve (L L^T) x = b for stacked lower triangles L (k,p,p) and right sides b (k,p)."""
    y = np.stack([linalg.solve_triangular(Lk, bk, lower=True, check_finite=False) for Lk, bk in zip(L, b)])
    return np.stack([linalg.solve_triangular(Lk, yk, lower=True, trans="T", check_finite=False)
                     for Lk, yk in zip(L, y)])


def choose_model(machine: Machine, campaign: Campaign, noise: NoiseModel | None = None, *, kinds=KINDS,
                 families=FAMILIES, plans=None, orders=CHEB_ORDERS, per_axis: bool = True, folds: int = 5,
                 seed: int = 0, progress: Callable[[str], None] | None = None) -> ModelChoice:
    """Score the candidates by linearised k-fold CV and choose one (module docstring).

    ``kinds``, ``families``, ``orders``: what to try (a fixed choice restricts them);
    ``plans``: the families tried on every axis at once (default ``families``);
    ``per_axis``: refine each axis' basis around the best common one."""
    t0 = time.perf_counter()
    say = progress or (lambda s: None)
    check_folds(campaign, folds)
    check_campaign_frames(machine, campaign)
    orders = sorted(set(int(o) for o in orders))
    if not orders or orders[0] < 0:
        raise InputError("orders are whole numbers >= 0")
    for k in kinds:
        if k not in KINDS:
            raise InputError(f"unknown model '{k}' (choose {' or '.join(KINDS)})")
    for f in families:
        if f not in FAMILIES:
            raise InputError(f"unknown basis family '{f}' (one of {', '.join(FAMILIES)})")
    noise = noise or NoiseModel.default(machine, "cartesian")
    camp = _subsample(campaign, seed)
    fold = command_folds(camp, folds, np.random.default_rng(seed))
    options = [axis_options(a, orders, families) for a in machine.axes]
    cands: list[Candidate] = []
    seen: set = set()

    def score(prob, choice):
        key = (prob.kind, choice)
        if key not in seen:
            seen.add(key)
            cands.append(prob.candidate(choice))
        return next(c for c in reversed(cands) if c.kind == prob.kind and c.axes == choice)

    problems = {}
    for kind in kinds:
        say(f"{kind}: linearising {len(camp)} rows with every candidate basis")
        prob = problems[kind] = _Problem(kind, machine, camp, noise, options, fold, folds)
        for plan in (plans or families):
            if plan not in families:
                continue
            for o in (orders if plan in ("chebyshev", "fourier", "fourier_trend") else [None]):
                for plan_axes in _plans(machine, plan, o, options):
                    score(prob, plan_axes)
        say(f"{kind}: {sum(c.kind == kind for c in cands)} common-basis candidates scored")
    best = min(cands, key=lambda c: c.mean)
    if per_axis:
        prob = problems[best.kind]
        cur = best
        for _ in range(3):
            improved = False
            for i in range(machine.n_axes):
                for opt in options[i]:
                    trial = cur.axes[:i] + (opt,) + cur.axes[i + 1:]
                    c = score(prob, trial)
                    if c.mean < cur.mean:
                        cur, improved = c, True
            if not improved:
                break
        say(f"refined axis by axis: {cur.label()}")
        best = min(cands, key=lambda c: c.mean)
    chosen, se, reason = one_standard_error(cands, best)
    unc = problems[kinds[0]].uncompensated
    say(f"chose {chosen.label()} ({len(cands)} candidates in {time.perf_counter() - t0:.1f} s)")
    return ModelChoice(machine, cands, best, chosen, se, reason, folds, int(problems[kinds[0]].judged.sum()),
                       (float(unc.mean()), float(unc.max())), time.perf_counter() - t0)


def _plans(machine: Machine, plan: str, order: int | None, options) -> list[tuple[AxisChoice, ...]]:
    """Candidates with one family everywhere it applies (Chebyshev elsewhere) at one order."""
    out = []
    if plan == "spline":
        knots = sorted({o.order for opts in options for o in opts if o.family == "spline"})
        for k in knots:
            out.append(tuple(AxisChoice("spline", k) if AxisChoice("spline", k) in opts else opts[0]
                             for opts in options))
        return out
    if plan == "chebyshev":
        return [tuple(AxisChoice("chebyshev", order) for _ in machine.axes)]
    fo = max(2, order + order % 2)
    for t in (TRENDS if plan == "fourier_trend" else (0,)):
        row = []
        for a, opts in zip(machine.axes, options):
            c = AxisChoice(plan, fo, t)
            row.append(c if c in opts else AxisChoice("chebyshev", order))
        if any(c.family == plan for c in row):
            out.append(tuple(row))
    return out


def one_standard_error(cands: list[Candidate], best: Candidate) -> tuple[Candidate, float, str]:
    """The fewest terms among the candidates within one paired standard error of the best."""
    n = best.heldout.size
    ok = []
    for c in cands:
        delta = c.heldout - best.heldout
        se = float(np.std(delta, ddof=1) / math.sqrt(n)) if n > 1 else 0.0
        if delta.mean() <= se:
            ok.append((c, se))
    chosen, se = min(ok, key=lambda x: (x[0].n_terms, x[0].mean))
    if chosen is best:
        return best, 0.0, f"lowest held-out mean ({best.mean:.4f} mm); no smaller model within one standard error"
    return chosen, se, (f"the fewest terms within one standard error ({se:.4f} mm) of the lowest held-out mean "
                        f"({best.label()}, {best.n_terms} terms, {best.mean:.4f} mm)")


def _subsample(campaign: Campaign, seed: int) -> Campaign:
    """At most :data:`MAX_SELECTION_ROWS` rows, whole commands kept together."""
    if len(campaign) <= MAX_SELECTION_ROWS:
        return campaign
    _, group = np.unique(np.round(campaign.q, 9), axis=0, return_inverse=True)
    group = np.asarray(group).ravel()
    rng = np.random.default_rng(seed)
    order = rng.permutation(group.max() + 1)
    per = np.bincount(group)
    keep_groups = order[np.cumsum(per[order]) <= MAX_SELECTION_ROWS]
    return campaign.subset(np.flatnonzero(np.isin(group, keep_groups)))


def parse_order(text) -> int | str:
    """'auto' or a whole number >= 0."""
    if str(text).strip().lower() == "auto":
        return "auto"
    try:
        v = int(str(text))
    except ValueError:
        raise InputError(f"--order {text!r}: 'auto' or a whole number >= 0") from None
    if v < 0:
        raise InputError(f"--order {text}: the order must be >= 0")
    return v


def fixed_model(machine: Machine, kind: str, basis: str, order: int, **opts) -> ErrorModel:
    """The model of a fully fixed choice: ``basis`` on the axes it applies to (Fourier
    families on rotary axes that travel more than a turn), Chebyshev elsewhere."""
    if basis in ("chebyshev", "fourier"):  # the seed's choice and vecpin's former default
        return make_model(kind, machine, order, basis="chebyshev" if basis == "chebyshev" else "auto", **opts)
    axes = []
    for a in machine.axes:
        if basis == "spline":
            axes.append(AxisChoice("spline", max(order, 1)))
        elif basis == "fourier_trend" and multiturn(a):
            axes.append(AxisChoice("fourier_trend", max(order + order % 2, 2), 2))
        else:
            axes.append(AxisChoice("chebyshev", order))
    return make_model(kind, machine, order, bases=[c.basis(a) for a, c in zip(machine.axes, axes)], **opts)


BASES = ("auto",) + FAMILIES


def choose_or_fix(machine: Machine, campaign: Campaign, noise: NoiseModel, kind: str = "auto", basis: str = "auto",
                  order: int | str = "auto", *, folds: int = 5, progress: Callable[[str], None] | None = None,
                  **opts):
    """(unfitted model, the choice or None): the model the data choose, with any of
    ``kind``, ``basis`` (a family on the axes it applies to) and ``order`` fixed; a fully
    fixed choice builds the model directly. ``opts``: model options (tool_lengths...)."""
    if kind not in ("auto",) + KINDS:
        raise InputError(f"--model {kind}: one of auto, {', '.join(KINDS)}")
    if basis not in BASES:
        raise InputError(f"--basis {basis}: one of {', '.join(BASES)}")
    order = parse_order(order)
    if kind != "auto" and basis != "auto" and order != "auto":
        return fixed_model(machine, kind, basis, order, **opts), None
    families = FAMILIES if basis == "auto" else tuple(dict.fromkeys((basis, "chebyshev")))
    choice = choose_model(machine, campaign, noise, kinds=KINDS if kind == "auto" else (kind,), families=families,
                          plans=None if basis == "auto" else (basis,),
                          orders=CHEB_ORDERS if order == "auto" else (order,),
                          per_axis=order == "auto" and basis == "auto", folds=folds, progress=progress)
    return choice.chosen.model(machine, **opts), choice
