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

from vecpin.errors import InputError
from vecpin.identification.likelihood import Likelihood
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.models.basis import AxisBasis
from vecpin.units import norm_mm

FAMILIES = ("chebyshev", "fourier", "fourier_trend", "spline")
CHEB_ORDERS = tuple(range(0, 9))
FOURIER_ORDERS = (2, 4, 6, 8, 10, 12)
TRENDS = (1, 2, 4, 6, 8)
SPLINE_KNOTS = (3, 7, 15)


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
        """Names of its non-constant functions in the union of :func:`axis_functions`."""
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


def axis_options(axis, orders=CHEB_ORDERS, families=FAMILIES, fixed_order: bool = False) -> list[AxisChoice]:
    """Every basis worth trying on an axis. ``fixed_order``: ``orders`` holds the one
    order the user fixed, which defines every family's size: Chebyshev and Fourier
    series of that order, Fourier plus a trend of at most that order, splines with
    that many interior knots."""
    out = []
    if "chebyshev" in families:
        out += [AxisChoice("chebyshev", o) for o in orders]
    if axis.multiturn:
        if "fourier" in families:
            out += [AxisChoice("fourier", o) for o in
                    (orders if fixed_order else [o for o in FOURIER_ORDERS if o <= 2 * max(orders, default=0) + 2])]
        if "fourier_trend" in families:
            out += [AxisChoice("fourier_trend", o, t) for o in (orders if fixed_order else FOURIER_ORDERS[:4])
                    for t in TRENDS if not fixed_order or t <= o]
    if "spline" in families:
        out += [AxisChoice("spline", k) for k in (orders if fixed_order else SPLINE_KNOTS)]
    return out


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
    for k in sorted({o.order for o in options if o.family == "spline"}):
        names += list(AxisChoice("spline", k).functions())
        cols.append(AxisChoice("spline", k).basis(axis).values(q)[:, 1:])
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

    @property
    def n_fixed(self) -> int:
        return len(self.fixed)

    def columns(self, choice: tuple[AxisChoice, ...]) -> np.ndarray:
        """Column indices of a candidate: E_0 and the instruments' unknowns, the offsets,
        then its constants and functions (6-DoF: on every slot the axis drives)."""
        idx = [self.index[("offset", k)] for k in range(self.n_offsets)]
        n = self.machine.n_axes
        if self.kind == "ap":
            idx += [self.index[("const", j)] for j in range(n)]
            for i, c in enumerate(choice):
                idx += [self.index[(i, name, k)] for name in c.functions() for k in range(n)]
        else:
            for s, i in enumerate(self.slots):
                idx += [self.index[(s, "0", k)] for k in range(6)]
                idx += [self.index[(s, name, k)] for name in choice[i].functions() for k in range(6)]
        return np.r_[np.arange(self.n_fixed), self.n_fixed + np.array(idx, int)]


class FoldedDesign(Design):
    """:class:`Design` with the normal equations of every fold (folds grouped by
    command): fold f's estimate comes from the normal equations less fold f's rows."""

    def __init__(self, kind: str, machine: Machine, campaign: Campaign, noise: NoiseModel, options, fold, folds,
                 opts: dict | None = None):
        super().__init__(kind, machine, campaign, noise, options, opts)
        grams = []
        for f in range(folds):
            sel = fold == f
            Jf = self.J[sel].reshape(-1, self.J.shape[-1])
            grams.append((Jf.T @ Jf, Jf.T @ self.w[sel].ravel()))
        self.G, self.g = sum(v[0] for v in grams), sum(v[1] for v in grams)
        self.G_train = np.stack([self.G - Gf for Gf, _ in grams])       # (folds, P, P)
        self.g_train = np.stack([self.g - gf for _, gf in grams])
        judged = np.flatnonzero(self.judged)
        self.metric_judged = self.metric[judged]
        # d metric / d psi of the judged rows, one contiguous row per column: (P, 3 n_judged)
        self.A_rows = np.ascontiguousarray(np.moveaxis(self.A[judged], -1, 0).reshape(self.A.shape[-1], -1))
        self.pick = (np.repeat(fold[judged], 3), np.arange(3 * len(judged)))  # each row's own fold

    def heldout(self, cols: np.ndarray) -> np.ndarray:
        """Held-out distances [mm] of the judged rows for the candidate with these columns."""
        N = self.G_train[:, cols[:, None], cols]
        N[:, np.arange(len(cols)), np.arange(len(cols))] += 1.0               # the unit prior
        g = self.g_train[:, cols]
        psi = np.stack([-linalg.cho_solve(linalg.cho_factor(Nf, check_finite=False), gf, check_finite=False)
                        for Nf, gf in zip(N, g)])                              # (folds, p): one solve per fold
        change = (psi @ self.A_rows[cols])[self.pick]                         # each row from its fold's estimate
        return norm_mm(self.metric_judged + change.reshape(-1, 3))

    def estimate(self, cols: np.ndarray) -> np.ndarray:
        """The candidate's linearised estimate from every row (prior-scaled, its columns)."""
        return -np.linalg.solve(self.G[np.ix_(cols, cols)] + np.eye(len(cols)), self.g[cols])
