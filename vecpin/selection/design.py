"""The candidate bases of each axis and the linearised problem that scores them.

Per axis the candidate bases are (:class:`AxisChoice`): Chebyshev series over the
travel and cubic B-splines with uniform knots (local errors); on a rotary axis that
travels more than a turn also Fourier series per turn, alone or with a Chebyshev trend
over the travel. :class:`Design` linearises one model kind at the nominal machine with
the union of every candidate function of every axis as columns; :class:`FoldedDesign`
adds the normal equations of every cross-validation fold, so a candidate's held-out
distances are a small solve per fold over its columns (:mod:`vecpin.selection.choice`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import linalg
from scipy.linalg import blas

from vecpin.errors import InputError
from vecpin.identification.likelihood import Likelihood
from vecpin.identification.redundancy import active_columns
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.models.basis import AxisBasis, basis_text, smoothing_transform
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


@dataclass(frozen=True)
class AxisChoice:
    """The basis of one axis: ``family`` and ``order`` (series order; interior knots of
    a spline), ``trend`` (Chebyshev trend order beside a Fourier series), ``smoothing``
    (the penalty λ of a penalised spline, :mod:`vecpin.models.basis`)."""

    family: str
    order: int
    trend: int = 0
    smoothing: float = 0.0

    def basis(self, axis) -> AxisBasis:
        rot = axis.kind == "rotary"
        if self.family == "chebyshev":
            return AxisBasis(axis.lower, axis.upper, self.order, "chebyshev", rotary=rot)
        if self.family == "fourier":
            return AxisBasis(axis.lower, axis.upper, self.order, "fourier", rotary=rot)
        if self.family == "fourier_trend":
            return AxisBasis(axis.lower, axis.upper, self.order, "fourier_trend", rotary=rot, trend=self.trend)
        if self.family in ("spline", "pspline"):
            knots = np.linspace(axis.lower, axis.upper, self.order + 2)[1:-1]
            return AxisBasis(axis.lower, axis.upper, 3, "bspline" if self.family == "spline" else "pspline",
                             rotary=rot, knots=tuple(knots), smoothing=self.smoothing)
        raise InputError(f"unknown basis family '{self.family}' (one of {', '.join(FAMILIES)})")

    def functions(self) -> tuple[str, ...]:
        """Names of its non-constant functions in the union of :func:`axis_functions`."""
        if self.family == "chebyshev":
            return tuple(f"c{j}" for j in range(1, self.order + 1))
        if self.family in ("fourier", "fourier_trend"):
            four = tuple(f"{'cos' if j % 2 else 'sin'}{math.ceil(j / 2)}" for j in range(1, self.order + 1))
            return four + tuple(f"c{j}" for j in range(1, self.trend + 1))
        return tuple(f"{'b' if self.family == 'spline' else 'p'}{self.order}.{i}" for i in range(1, self.order + 4))

    def scales(self) -> np.ndarray:
        """The factor of each of :meth:`functions` on the union's column: 1, except a
        penalised spline's ``1 / sqrt(1 + λ e_j)`` (its union columns are those of λ = 0)."""
        if self.family != "pspline":
            return np.ones(len(self.functions()))
        e = smoothing_transform(self.order + 3, 0.0)[1]
        return 1.0 / np.sqrt(1.0 + self.smoothing * e)

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


def axis_functions(axis, options: list[AxisChoice], q: np.ndarray) -> tuple[list[str], np.ndarray]:
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
    for fam in ("spline", "pspline"):
        for k in sorted({o.order for o in options if o.family == fam}):
            names += list(AxisChoice(fam, k).functions())
            cols.append(AxisChoice(fam, k).basis(axis).values(q)[:, 1:])
    return names, (np.concatenate(cols, axis=1) if cols else np.zeros((len(q), 0)))



class Design:
    """The linearised problem at the nominal machine on one campaign, with every
    candidate function of every axis for one model kind: whitened columns ``J``
    (N,3,P), metric columns ``A`` (N,3,P), residuals ``w`` and ``metric`` (N,3).

    The first :attr:`n_fixed` columns are in every candidate: E_0 (station 0's pose
    correction) and the instruments' own unknowns (other stations' poses, ball-bar
    pivots, tool targets, nest positions). Then the model's offsets (T_offset, a length
    per tool with ``tool_lengths``), the constants and the functions. Every column is
    scaled by the prior standard deviation of its term in the model the candidate
    builds (``opts``: the model options, ``prior_scale`` among them), so the unit ridge
    of the solves is the model's own prior. ``setup``: the tracker poses to linearise at
    (default: registered on this campaign)."""

    def __init__(self, kind: str, machine: Machine, campaign: Campaign, noise: NoiseModel, options,
                 opts: dict | None = None, setup=None):
        self.kind, self.machine = kind, machine
        c = campaign
        opts = {k: v for k, v in (opts or {}).items() if k in ("tool_lengths", "prior_scale")}
        lik = Likelihood(make_model("ap", machine, 0), c, noise, setup=setup)
        self.setup = lik.setup
        ev = lik.evaluate(np.zeros(lik.n_unknowns), operators=True)
        point = ev.valid.all(axis=1) & np.isfinite(ev.y).all(axis=1)
        self.judged = point if point.any() else ev.valid[:, 0]
        self.metric, self.w = ev.metric, ev.w
        # every row's own point (tool tip, target, nest) through the one likelihood's requests
        proto, proto1 = make_model(kind, machine, 0, **opts), make_model(kind, machine, 1, **opts)
        tool_dir, S = lik.sensitivity(proto)
        # E_0 and the instruments' unknowns (stations, pivots, targets, nests) are in every candidate
        self.fixed = np.r_[np.arange(6), np.arange(6 + lik.n_model, lik.n_unknowns)]
        self.slots = list(proto.slot_axis) if kind == "6dof" else list(range(machine.n_axes))
        n, n_off = machine.n_axes, proto._n_offsets()
        prior0 = proto.priors[n_off:]                                      # the constants' priors
        prior1 = np.array([p.prior for p in proto1.base_parameters if p.order == 1])  # the functions'
        off = proto._offset_columns(c.tool, tool_dir) * proto.priors[:n_off]
        cols = [off[:, :, k] for k in range(n_off)]
        index = {("offset", k): k for k in range(n_off)}
        functions = [axis_functions(a, options[i], c.q[:, i]) for i, a in enumerate(machine.axes)]
        if kind == "ap":  # a constant per output; per input axis its functions into every output
            prior1 = prior1.reshape(n, n)
            for j in range(n):
                index[("const", j)] = len(cols)
                cols.append(S[:, :, j] * prior0[j])
            for i in range(n):
                names, F = functions[i]
                for f, name in enumerate(names):
                    for j in range(n):
                        index[(i, name, j)] = len(cols)
                        cols.append(S[:, :, j] * F[:, f, None] * prior1[i, j])
        else:  # per slot (an axis or a mimic joint): its constants, then its driving axis' functions
            prior0, prior1 = prior0.reshape(-1, 6), prior1.reshape(-1, 6)
            for s, i in enumerate(self.slots):
                for comp in range(6):
                    index[(s, "0", comp)] = len(cols)
                    cols.append(S[:, :, s, comp] * prior0[s, comp])
                names, F = functions[i]
                for f, name in enumerate(names):
                    for comp in range(6):
                        index[(s, name, comp)] = len(cols)
                        cols.append(S[:, :, s, comp] * F[:, f, None] * prior1[s, comp])
        D = np.stack(cols, axis=-1)                                     # d point / d psi (N,3,P)
        self.J = np.concatenate([ev.J[:, :, self.fixed], ev.Gw @ D], axis=-1)
        self.A = np.concatenate([ev.A[:, :, self.fixed], ev.Gm @ D], axis=-1)
        self.index = index
        self.n_offsets = n_off
        self.uncompensated = norm_mm(ev.metric[self.judged])
        # what a fit counts (identification.fit): its equations, and the columns that move anything
        self.n_equations = int(ev.valid.sum())
        norms = np.sqrt(np.einsum("nkp,nkp->p", self.J, self.J))
        self.active = active_columns(norms)

    def unknowns(self, choice: tuple[AxisChoice, ...]) -> int:
        """The unknowns a fit of this candidate counts against the equations: its columns
        that move anything (E_0 and the instruments' unknowns included)."""
        return int(self.active[self.columns(choice)[0]].sum())

    @property
    def n_fixed(self) -> int:
        return len(self.fixed)

    def columns(self, choice: tuple[AxisChoice, ...]) -> tuple[np.ndarray, np.ndarray]:
        """(column indices, factor on each) of a candidate: E_0 and the instruments'
        unknowns, the offsets, then its constants and functions (6-DoF: on every slot the
        axis drives); the factors are 1 except a penalised spline's (:meth:`AxisChoice.scales`)."""
        idx = [self.index[("offset", k)] for k in range(self.n_offsets)]
        n = self.machine.n_axes
        one = [np.ones(len(idx))]
        if self.kind == "ap":
            idx += [self.index[("const", j)] for j in range(n)]
            one.append(np.ones(n))
            for i, c in enumerate(choice):
                idx += [self.index[(i, name, k)] for name in c.functions() for k in range(n)]
                one.append(np.repeat(c.scales(), n))
        else:
            for s, i in enumerate(self.slots):
                idx += [self.index[(s, "0", k)] for k in range(6)]
                idx += [self.index[(s, name, k)] for name in choice[i].functions() for k in range(6)]
                one += [np.ones(6), np.repeat(choice[i].scales(), 6)]
        return (np.r_[np.arange(self.n_fixed), self.n_fixed + np.array(idx, int)],
                np.concatenate([np.ones(self.n_fixed)] + one))


class FoldedDesign(Design):
    """:class:`Design` with the normal equations of every fold (folds grouped by
    command): fold f's estimate comes from the normal equations less fold f's rows."""

    def __init__(self, kind: str, machine: Machine, campaign: Campaign, noise: NoiseModel, options, fold, folds,
                 opts: dict | None = None):
        super().__init__(kind, machine, campaign, noise, options, opts)
        P = self.J.shape[-1]
        self.G_train, self.g_train = np.empty((folds, P, P)), np.empty((folds, P))   # first each fold's own
        for f in range(folds):
            sel = fold == f
            Jf = self.J[sel].reshape(-1, P)
            U = blas.dsyrk(1.0, Jf.T, trans=0)                      # Jf^T Jf, upper triangle (symmetric)
            self.G_train[f] = U
            self.G_train[f] += np.triu(U, 1).T
            self.g_train[f] = Jf.T @ self.w[sel].ravel()
        self.G, self.g = self.G_train.sum(axis=0), self.g_train.sum(axis=0)
        np.subtract(self.G, self.G_train, out=self.G_train)         # (folds, P, P): every fold left out
        np.subtract(self.g, self.g_train, out=self.g_train)
        # the judged rows sorted by fold (a row is judged by its own fold's estimate only, so each
        # fold's equations are one contiguous slice); d metric / d psi one contiguous row per
        # column: (P, 3 n_judged)
        judged = np.flatnonzero(self.judged)
        self.judged_order = np.argsort(fold[judged], kind="stable")
        sorted_rows = judged[self.judged_order]
        self.metric_sorted = self.metric[sorted_rows]
        self.A_rows = np.ascontiguousarray(np.moveaxis(self.A[sorted_rows], -1, 0).reshape(self.A.shape[-1], -1))
        ends = 3 * np.cumsum(np.bincount(fold[judged], minlength=folds))
        self.fold_slices = [slice(int(a), int(b)) for a, b in zip(np.r_[0, ends[:-1]], ends)]

    def heldout(self, cols: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """Held-out distances [mm] of the judged rows for the candidate with these columns
        (each times its factor): :meth:`heldout_blocks` with every column shared."""
        return self.heldout_blocks(cols, scale, [(np.zeros(0, int), np.zeros(0))])[0]

    def _in_campaign_order(self, change: np.ndarray) -> np.ndarray:
        """Distances [mm] of the judged rows changed by ``change`` (3 n_judged, fold-sorted
        as :attr:`A_rows`), returned in the campaign's order."""
        out = np.empty(len(self.judged_order))
        out[self.judged_order] = norm_mm(self.metric_sorted + change.reshape(-1, 3))
        return out

    def heldout_sweep(self, cols: np.ndarray, scales: list[np.ndarray]) -> list[np.ndarray]:
        """:meth:`heldout` of one candidate's columns under several sets of factors (a
        penalised spline at several smoothings): :meth:`heldout_blocks` with the columns
        whose factor never changes as the common part."""
        pen = np.any([s != scales[0] for s in scales], axis=0)
        return self.heldout_blocks(cols[~pen], scales[0][~pen], [(cols[pen], s[pen]) for s in scales])

    def heldout_blocks(self, F: np.ndarray, sF: np.ndarray,
                       blocks: list[tuple[np.ndarray, np.ndarray]]) -> list[np.ndarray]:
        """:meth:`heldout` of several candidates that share the columns ``F`` (factors
        ``sF``) and differ in a block of columns ``P`` (factors ``sP``) each, e.g. one axis'
        basis or smoothing: F is eliminated once per fold and each candidate solves only
        the Schur complement of its block, S_P (G_PP - G_PF N_FF^-1 G_FP) S_P + I, whose
        bracket is shared by blocks with the same columns. Returns one array per block;
        the same algebra as :meth:`heldout`, rearranged."""
        groups: dict = {}
        for k, (P, _) in enumerate(blocks):
            groups.setdefault(tuple(P), []).append(k)
        # the union of every block's columns: one elimination of F per fold serves them all
        # (the blocks of one axis overlap, e.g. Chebyshev orders nest)
        U = np.unique(np.concatenate([np.asarray(P, int) for P, _ in blocks] + [np.zeros(0, int)]))
        at = {int(c): i for i, c in enumerate(U)}
        where = {key: np.array([at[int(c)] for c in key], int) for key in groups}
        psi = [np.zeros((len(self.G_train), len(F) + len(P))) for P, _ in blocks]
        nF = len(F)
        for f, (Gf, gf) in enumerate(zip(self.G_train, self.g_train)):
            A = Gf[F[:, None], F] * np.outer(sF, sF)
            A[np.arange(nF), np.arange(nF)] += 1.0                              # the unit prior
            cho = linalg.cho_factor(A, check_finite=False)
            y = linalg.cho_solve(cho, gf[F] * sF, check_finite=False)
            GFU = Gf[F[:, None], U] * sF[:, None]
            XU = linalg.cho_solve(cho, GFU, check_finite=False)
            MU = Gf[U[:, None], U] - GFU.T @ XU                                 # the Schur bracket of U
            rU = gf[U] - GFU.T @ y
            for key, ks in groups.items():
                if not key:
                    for k in ks:
                        psi[k][f, :nF] = -sF * y
                    continue
                w = where[key]
                X, M, r = XU[:, w], MU[w[:, None], w], rU[w]                   # the block's share of U
                for k in ks:
                    sP = blocks[k][1]
                    Sc = M * np.outer(sP, sP)
                    Sc[np.arange(len(w)), np.arange(len(w))] += 1.0
                    xP = -linalg.cho_solve(linalg.cho_factor(Sc, check_finite=False), sP * r, check_finite=False)
                    psi[k][f, :nF] = sF * (-y - X @ (sP * xP))
                    psi[k][f, nF:] = sP * xP
        # every block's change of the judged rows, fold by fold: the shared columns F for all
        # blocks at once, then each group's own columns
        change = np.empty((len(blocks), self.A_rows.shape[1]))
        for f, sl in enumerate(self.fold_slices):
            AU = self.A_rows[U, sl]
            ch = np.stack([p[f, :nF] for p in psi]) @ self.A_rows[F, sl]
            for key, ks in groups.items():
                if key:
                    ch[ks] += np.stack([psi[k][f, nF:] for k in ks]) @ AU[where[key]]
            change[:, sl] = ch
        return [self._in_campaign_order(c) for c in change]

    def normal_matrix(self, cols: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """The candidate's whitened normal matrix J^T J from every row (its scaled columns)."""
        return self.G[np.ix_(cols, cols)] * np.outer(scale, scale)

    def estimate(self, cols: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """The candidate's linearised estimate from every row in the union's units: the
        change of the point is ``D[..., cols] @ psi`` (the factor applied)."""
        G = self.normal_matrix(cols, scale)
        return -scale * np.linalg.solve(G + np.eye(len(cols)), scale * self.g[cols])

    def effective_terms(self, cols: np.ndarray, scale: np.ndarray) -> float:
        """The effective number of model terms, trace((G + I)^-1 G) over the model's
        columns: what the data determine beyond the prior (a penalised spline's smooth
        shapes count one each, its penalised wiggles little)."""
        G = self.normal_matrix(cols, scale)
        L = linalg.cholesky(G + np.eye(len(cols)), lower=True, check_finite=False)
        Linv = linalg.solve_triangular(L, np.eye(len(cols)), lower=True, check_finite=False)
        diag = 1.0 - np.einsum("ij,ij->j", Linv, Linv)   # diag((G + I)^-1 G) = 1 - diag((G + I)^-1)
        return float(diag[self.n_fixed:].sum())
