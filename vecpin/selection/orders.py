"""Choosing the series order on held-out data (Paper I Table 2, Fig. 7-8).

For each order the model is fitted on the identification rows and judged on rows it
did not see: a validation campaign when one is given (as Paper I's 35 points), else
k-fold cross-validation in which both tool lengths of one command always fall in the
same fold (they share the axis position, so splitting them would leak), linearised at
the fit (:mod:`vecpin.identification.crossval`: each fold's estimate is a small solve,
not a refit; it agrees with refitting to about 1 %).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from vecpin.errors import InputError
from vecpin.measurement.campaign import Campaign
from vecpin.kinematics.machine import Machine
from vecpin.identification.folds import command_folds
from vecpin.identification.linearised import Linearised
from vecpin.models import MODELS, make_model
from vecpin.selection.design import partly_measured
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.registration import check_campaign_frames, rigid_registration
from vecpin.units import MM_PER_M


@dataclass
class OrderRow:
    """One line of the order table (distances in mm, time in s)."""

    order: int
    n_parameters: int
    seconds: float
    ident_mean: float
    ident_max: float
    heldout_mean: float
    heldout_max: float
    chi2_ratio: float  # chi2 / expected

    def reduction(self, base_mean: float, heldout: bool) -> float:
        return 100.0 * (1 - (self.heldout_mean if heldout else self.ident_mean) / base_mean)


@dataclass
class OrderSweep:
    kind: str
    basis: str
    method: str  # "validation file" or "k-fold CV"
    uncompensated_ident: tuple[float, float]
    uncompensated_heldout: tuple[float, float]
    rows: list[OrderRow]

    @property
    def best(self) -> OrderRow:
        return min(self.rows, key=lambda r: r.heldout_mean)

    def table(self) -> str:
        ui, uh = self.uncompensated_ident, self.uncompensated_heldout
        held = "Validation" if self.method == "validation file" else "Held out (CV)"
        lines = [f"{'Model':<14s} {'Order':>5s} {'Params':>6s} {'Time (s)':>8s} | {'Ident mean':>10s} {'max':>7s} {'red.':>6s} | "
                 f"{held + ' mean':>18s} {'max':>7s} {'red.':>6s} | {'chi2/E':>6s}",
                 f"{'Uncompensated':<14s} {'--':>5s} {'':>6s} {'':>8s} | {ui[0]:10.3f} {ui[1]:7.3f} {'-':>6s} | "
                 f"{uh[0]:18.3f} {uh[1]:7.3f} {'-':>6s} |"]
        name = MODELS[self.kind].display_name + ("" if self.basis == "chebyshev" else "*")
        best = self.best.order
        for r in self.rows:
            lines.append(f"{name:<14s} {r.order:5d} {r.n_parameters:6d} {r.seconds:8.2f} | {r.ident_mean:10.3f} {r.ident_max:7.3f} "
                         f"{r.reduction(ui[0], False):5.1f}% | {r.heldout_mean:18.3f} {r.heldout_max:7.3f} "
                         f"{r.reduction(uh[0], True):5.1f}% | {r.chi2_ratio:6.2f}" + ("  <- best" if r.order == best else ""))
        if self.basis != "chebyshev":
            lines.append("* Fourier series on rotary axes travelling more than a turn, Chebyshev elsewhere")
        return "\n".join(lines)


def _dist_mm(err: np.ndarray) -> np.ndarray:
    return np.linalg.norm(err, axis=1) * MM_PER_M


def campaign_equations(campaign: Campaign, noise: NoiseModel | None = None) -> int:
    """Equations a campaign gives a fit: 3 per tracker row (1 with ranges only), 1 per ball bar row."""
    per_row = 1 if noise is not None and noise.instrument == "range" else 3
    return per_row * len(campaign.tracker_rows) + len(campaign.ballbar_rows)


def check_orders(machine: Machine, campaign: Campaign, kinds, orders, *, folds: int | None = None,
                 noise: NoiseModel | None = None, basis: str = "chebyshev", option: str = "`orders`") -> None:
    """Refuse, before any fit, orders whose models have more unknowns than the campaign
    (each fold's training part with ``folds``) has equations, and folds that the
    campaign's distinct commands cannot fill."""
    orders = list(orders)
    if not orders or min(orders) < 0:
        raise InputError(f"{option}: orders are whole numbers >= 0")
    if folds is not None:
        check_folds(campaign, folds)
    eq = campaign_equations(campaign, noise)
    if folds is not None:
        eq = eq * (folds - 1) // folds
    for kind in kinds:
        def unknowns(o: int) -> int:
            return make_model(kind, machine, o, basis=basis).n_parameters + 6
        if unknowns(max(orders)) <= eq:
            continue
        best = -1  # the terms grow with the order: scan up to the first order the campaign cannot determine
        while best < max(orders) and unknowns(best + 1) <= eq:
            best += 1
        o = min(x for x in orders if x > best)
        hint = f"orders up to {best}" if best >= 0 else "no order: measure more points"
        raise InputError(f"{option}: order {o} of the {kind} model has {unknowns(o)} unknowns, but {campaign.source} "
                         f"gives {eq} equations{' in each fold' if folds else ''}; this campaign determines {hint}")


def check_folds(campaign: Campaign | None, folds, option: str = "`folds`") -> None:
    """k-fold cross-validation needs 2 <= k <= the campaign's distinct commands (rows of
    one command share a fold); ``campaign`` None: only the first. ``folds`` (N,) fold
    indices, one per row (the user's labels): one per row of ``campaign`` and two folds at least."""
    if np.ndim(folds):
        n = len(folds) if campaign is None else len(campaign)
        if len(folds) != n or len(np.unique(folds)) < 2:
            raise InputError(f"{option}: {len(folds)} fold labels, {len(np.unique(folds))} distinct, for {n} rows: "
                             "give one label per row and at least 2 distinct labels")
        return
    if int(folds) != folds or folds < 2:
        raise InputError(f"{option} {folds}: cross-validation needs at least 2 folds")
    if campaign is None:
        return
    q = np.round(campaign.q, 9)
    if len(np.unique(q[:10 * int(folds)], axis=0)) >= folds:
        return   # enough distinct commands among the first rows (a million rows need not all be sorted)
    n = len(np.unique(q, axis=0))
    if folds > n:
        raise InputError(f"{option} {folds}: {campaign.source} has {n} distinct commands, and the rows of one command "
                         f"share a fold; use at most {n} folds (5 or 10 is usual)")


def order_sweep(machine: Machine, campaign: Campaign, kind: str, orders=range(0, 8), *,
                validation: Campaign | None = None, folds: int = 5, noise: NoiseModel | None = None,
                basis: str = "fourier", seed: int = 0, progress: Callable[[str], None] | None = None) -> OrderSweep:
    """Fit ``kind`` ("6dof"/"ap") at every order; judge on ``validation`` or by k-fold CV."""
    noise = noise or NoiseModel.default(machine)
    check_orders(machine, campaign, [kind], orders, folds=None if validation is not None else folds, noise=noise,
                 basis=basis)
    for c in (campaign, validation) if validation is not None else (campaign,):
        check_campaign_frames(machine, c)
    # distances are judged on the rows one tracker pose describes (station 0's tracker rows)
    judged = np.ones(len(campaign), bool)
    if campaign.mixed:
        judged[:] = False
        judged[campaign.tracker_rows[campaign.station[campaign.tracker_rows] == 0]] = True
    primary = campaign.primary()
    validation = validation.primary() if validation is not None else None
    nominal = machine.tool_tip(campaign.q, campaign.tool, frame="base")
    R, t = rigid_registration(nominal[judged], campaign.xyz[judged])
    ui = _dist_mm(primary.xyz - (nominal[judged] @ R.T + t))
    if validation is not None:
        uv = _dist_mm(validation.xyz - (machine.tool_tip(validation.q, validation.tool, frame="base") @ R.T + t))
        method = "validation file"
    else:
        ends = partly_measured(machine, campaign)
        fold = command_folds(campaign, folds, np.random.default_rng(seed), ends)
        uv = np.full(len(campaign), np.nan)
        for f in range(folds):
            tr, te = (fold != f) & judged, (fold == f) & judged
            Rf, tf = rigid_registration(nominal[tr], campaign.xyz[tr])
            uv[te] = _dist_mm(campaign.xyz[te] - (nominal[te] @ Rf.T + tf))
        uv = uv[judged]
        method = "k-fold CV" + (f" (the ends of {', '.join(machine.axes[a].name for a in ends)} held out whole)"
                                if ends else "")
    rows = []
    for order in orders:
        t0 = time.perf_counter()
        model = make_model(kind, machine, order, basis=basis).fit(campaign, noise)
        secs = time.perf_counter() - t0
        di = _dist_mm(model.residuals(primary))
        if validation is not None:
            dh = _dist_mm(model.residuals(validation))
        else:  # the fit linearised at its solution, each fold's estimate from the other folds' rows
            dh = Linearised(model, campaign, noise).folded(fold, judged).heldout()
        rep = model.report_
        rows.append(OrderRow(order, model.n_parameters - len(rep.removed), secs, float(di.mean()), float(di.max()),
                             float(dh.mean()), float(dh.max()), rep.chi2 / rep.chi2_expected))
        if progress:
            progress(f"{kind} order {order}: ident mean {di.mean():.4f} mm, held-out mean {dh.mean():.4f} mm ({secs:.2f} s)")
    return OrderSweep(kind, basis, method, (float(ui.mean()), float(ui.max())), (float(uv.mean()), float(uv.max())), rows)
