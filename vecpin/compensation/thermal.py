"""Thermal terms in the controllers' form, fitted from a campaign with temperatures.

A controller's temperature compensation (Siemens K3, Beckhoff/ISG, Heidenhain
TEMPCOMP, Fanuc's growth along the tool, LinuxCNC through vecpin's HAL component)
takes, per linear axis, a straight error line that moves with the temperature T [°C]:

    error_i(T, p) = a_i (T - T0) + b_i (T - T0) (p - P0_i)

``a_i`` [µm/K] the offset at the reference position ``P0_i`` [mm], ``b_i`` [µm/m/K]
the slope (the axis' expansion), ``p`` the axis' commanded position [mm]; and the
tool's growth along its direction ``c (T - T0)`` [µm/K] (positive: the tool gets
longer). These are *errors* (where the axis or tool tip actually is, less where it was
commanded); the correction the controller applies is their negative. ``T`` is the
sensor's temperature seen through a first-order lag of ``lag_h`` hours
(:func:`~vecpin.models.effects.thermal.lagged`): the structure follows the air slowly.

:func:`fit_thermal` fits them together with the geometric model on the campaign (the
geometric model's own terms refitted with them, so the geometry does not absorb the
drift), the lag scanned over :data:`~vecpin.models.effects.thermal.LAGS_H` and refined
between them with the curvature free (:func:`refine_lag`), and says in words where the data cannot separate them
(:func:`separability`). :func:`remaining_mm` predicts what the terms leave at a steady
temperature as a point figure (with the chance it holds to 20 %) and a band, from draws
of the coefficients' error as time blocks held out show it
(:mod:`vecpin.compensation.thermalheld`), the lag's uncertainty, and the curvature the
campaign cannot rule out per term (:func:`~vecpin.compensation.thermalheld.curvature`),
extrapolated. The controllers' forms are straight in T: the curvature is not written, and
the prediction is of what the written straight terms leave, the curvature part of it.
The effects fitted (:class:`ThermalTermsEffect`, the curvature's) are in
:mod:`vecpin.compensation.thermaleffect`.
"""
from __future__ import annotations

import dataclasses
import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

from vecpin.compensation.thermaleffect import BENT_GROWTH, ThermalTermsEffect
from vecpin.compensation.thermalheld import (LagProblem, bend_terms, bent_fit, curvature, curvature_draws, held_out,
                                              with_lag)
from vecpin.errors import InputError, VecpinError
from vecpin.fileio import write_text
from vecpin.measurement.features import Features
from vecpin.models.effects.base import TipContext
from vecpin.models.effects.thermal import LAGS_H, lagged

UM_PER_M = 1e6
FRAME = ("the tool tip's displacement relative to the workpiece (the table's frame; the base frame on a machine "
         "without a table), its 3D length averaged over the commands, no translation removed, from where the "
         "geometric tables leave the tip (the thermal state at T0, the campaign's mean)")
DESCRIPTION = ("vecpin thermal terms: per linear axis the error offset_um_per_k (T - t0_c) + slope_um_per_m_per_k "
               "(T - t0_c) (p - p0_mm) / 1000 [um] and the tool's growth growth_um_per_k (T - t0_c) [um] along it "
               "(errors: where the axis or tip is, less where it was commanded; the controller corrects their "
               "negative), T the sensor's temperature [degC] through a first-order lag of lag_h hours. held_out and "
               "curvature give what the terms leave (the predicted thermal figures), measured as " + FRAME + ".")
COLLINEAR = 0.95      # |correlation| above which two drivers cannot be told apart
ILL_CONDITIONED = 1e3  # condition number of the thermal columns above which the terms are not separable
LAG_STEP_H = 0.02     # h: the refined lag's resolution (lags are kept to 0.01 h)
LAG_DELTA_H = 0.03    # h: the step of the second difference that gives the lag's standard deviation


@dataclass
class ThermalTerms:
    """Fitted thermal terms (errors, see the module text), in the units controllers take:
    ``t0_c`` [°C], ``lag_h`` [h], per axis ``p0_mm`` [mm], ``offset_um_per_k`` (a),
    ``slope_um_per_m_per_k`` (b) and their standard deviations; ``growth_um_per_k`` (c,
    None where the tool's growth is one of the axes' offsets on this machine, see
    ``notes``); ``t_range_c``: the lagged temperatures the campaign saw; ``notes``: what
    the data could not separate, in words; ``held_out``: what the fit leaves, judged on
    time blocks held out (:func:`vecpin.compensation.thermalheld.held_out`: the
    coefficients' covariance with the lag's uncertainty, the residual's floor);
    ``curvature``: how far the error may bend beyond the measured temperatures
    (:func:`curvature`)."""

    machine: str
    axes: list[str]
    t0_c: float
    lag_h: float
    p0_mm: dict[str, float]
    offset_um_per_k: dict[str, float]
    slope_um_per_m_per_k: dict[str, float]
    growth_um_per_k: float | None
    offset_std: dict[str, float] = field(default_factory=dict)
    slope_std: dict[str, float] = field(default_factory=dict)
    growth_std: float | None = None
    t_range_c: tuple[float, float] = (20.0, 20.0)
    notes: list[str] = field(default_factory=list)
    held_out: dict = field(default_factory=dict)   # see :mod:`vecpin.compensation.thermalheld`
    curvature: dict = field(default_factory=dict)  # see :func:`curvature`

    def axis_error_mm(self, axis: str, pos_mm, temperature_c) -> np.ndarray:
        """The axis' thermal error [mm] at commanded positions [mm] and (lagged) temperatures [°C]."""
        d = np.asarray(temperature_c, float) - self.t0_c
        return (self.offset_um_per_k[axis] + self.slope_um_per_m_per_k[axis] * (np.asarray(pos_mm, float)
                                                                                  - self.p0_mm[axis]) * 1e-3) * d * 1e-3

    def axis_correction_mm(self, axis: str, pos_mm, temperature_c) -> np.ndarray:
        """What the controller adds to the axis' command [mm]: minus its error."""
        return -self.axis_error_mm(axis, pos_mm, temperature_c)

    def growth_mm(self, temperature_c) -> np.ndarray:
        """The tool's growth along its direction [mm] (0 where it is carried by an axis' offset)."""
        c = self.growth_um_per_k or 0.0
        return c * (np.asarray(temperature_c, float) - self.t0_c) * 1e-3

    def to_dict(self) -> dict:
        return asdict(self) | {"t_range_c": list(self.t_range_c), "format": "vecpin thermal terms 1",
                               "description": DESCRIPTION}

    def save(self, path) -> None:
        write_text(Path(path), json.dumps(self.to_dict(), indent=1) + "\n")

    @classmethod
    def load(cls, path) -> "ThermalTerms":
        from vecpin.compensation.thermalfile import check_terms
        try:
            d = json.loads(Path(path).read_text())
            check_terms(path, d)
            d.pop("format", None)
            d.pop("description", None)
            d["t_range_c"] = tuple(d["t_range_c"])
            d.setdefault("held_out", {})
            d.setdefault("curvature", {})
            return cls(**d)
        except InputError:
            raise
        except (OSError, ValueError, TypeError, KeyError) as exc:
            raise InputError(f"{path}: not a vecpin thermal terms file ({exc})") from None

    def lines(self) -> list[str]:
        """The terms in words, one line each."""
        out = [f"thermal terms (errors; the controller corrects their negative): T0 {self.t0_c:.2f} degC, lag "
               f"{self.lag_h:g} h, fitted over {self.t_range_c[0]:.2f} .. {self.t_range_c[1]:.2f} degC (the sensor's "
               "readings through the lag)"]
        for a in self.axes:
            out.append(f"  {a}: offset {self.offset_um_per_k[a]:+.3f} ± {self.offset_std.get(a, 0.0):.3f} um/K at "
                       f"P0 {self.p0_mm[a]:g} mm, slope {self.slope_um_per_m_per_k[a]:+.3f} ± "
                       f"{self.slope_std.get(a, 0.0):.3f} um/m/K")
        if self.growth_um_per_k is not None:
            out.append(f"  tool growth {self.growth_um_per_k:+.3f} ± {self.growth_std or 0.0:.3f} um/K along the tool")
        return out + [f"  note: {n}" for n in self.notes]


def tip_errors(terms: ThermalTerms, machine, q: np.ndarray, tool, temperature_c) -> np.ndarray:
    """(N,3) [m] the tool tip's thermal error the terms predict at commands ``q`` (N,n)
    [m, rad], tool lengths [m] and (lagged) temperatures [°C]: each axis where its error
    line puts it, and the tool's growth along its direction; relative to the workpiece
    (the machine's default frame: the table's, or the base frame on a machine without a
    table; a table-side axis' error moves the workpiece, not the tip), see :data:`FRAME`."""
    q = np.atleast_2d(np.asarray(q, float))
    T = np.broadcast_to(np.asarray(temperature_c, float), (len(q),))
    e = np.zeros_like(q)
    for a in terms.axes:
        ax = machine.axis(a)
        e[:, ax.index] = ax.to_si(terms.axis_error_mm(a, ax.to_user(q[:, ax.index]), T))
    nominal = machine.kinematics(q, tool, jacobian=False)
    moved = machine.kinematics(q + e, tool, jacobian=False)
    return moved.tip - nominal.tip + moved.tool_dir * (terms.growth_mm(T) * 1e-3)[:, None]


DRAWS = 2000  # draws behind a predicted remaining error (seeded: the same figure each time)


def _unit_terms(terms: ThermalTerms, name: str) -> ThermalTerms:
    """The terms with every coefficient 0 but ``name`` (thermalheld's order) at 1 (µm/K or µm/m/K)."""
    z = dataclasses.replace(terms, offset_um_per_k={a: 0.0 for a in terms.axes},
                            slope_um_per_m_per_k={a: 0.0 for a in terms.axes},
                            growth_um_per_k=None if terms.growth_um_per_k is None else 0.0)
    if name == "tool_growth_per_K":
        z.growth_um_per_k = 1.0
    else:
        axis, kind = name.split(".")
        (z.offset_um_per_k if kind == "offset_per_K" else z.slope_um_per_m_per_k)[axis] = 1.0
    return z


BAND = (5.0, 95.0)   # percentiles of the draws that bound the predicted remaining error


@dataclass
class Remaining:
    """What the thermal terms are predicted to leave at one steady temperature, as the
    mean over the commands of the tip's error [mm]: ``expected`` (the draws' mean),
    ``low`` .. ``high`` (:data:`BAND`: the draws' 5th and 95th percentiles), ``floor``
    (what the model leaves at any temperature, the held-out residual's floor); ``point``
    the figure to hold vecpin to (:func:`point_within`: the one the most draws lie within
    :data:`WITHIN` of) and ``chance`` the draws' share within it (the chance vecpin gives
    the error of landing within 20 % of ``point``; NaN without draws); ``draws`` [mm]."""

    expected: float
    low: float
    high: float
    floor: float
    point: float = float("nan")
    chance: float = float("nan")
    draws: np.ndarray | None = field(default=None, repr=False)


WITHIN = 0.2   # the relative distance a point prediction is held to


def point_within(draws, within: float = WITHIN) -> tuple[float, float]:
    """(the value m with the most ``draws`` in [(1 - within) m, (1 + within) m], their
    share): the point prediction with the best chance of holding to ``within``."""
    s = np.sort(np.asarray(draws, float))
    inside = np.searchsorted(s, (1 + within) * s, "right") - np.searchsorted(s, (1 - within) * s, "left")
    k = int(np.argmax(inside))
    return float(s[k]), float(inside[k] / len(s))


def _contribution(terms: ThermalTerms, names, machine, q, tool, d: float) -> np.ndarray:
    """(N, 3, P) [m per unit] the tip's error per unit coefficient of ``names`` at a
    temperature change ``d`` [K] (or a curvature [K^2])."""
    return np.stack([tip_errors(_unit_terms(terms, nm), machine, q, tool, terms.t0_c + d) for nm in names], -1)


def _draws(cov, rng, dof: int) -> np.ndarray:
    """(DRAWS, P) zero-mean draws of a covariance estimated with ``dof`` degrees of freedom
    (its negative eigenvalues clipped): Student's t, the normal draws scaled by
    sqrt(dof / chi2_dof) (a covariance from a few held-out blocks is itself uncertain)."""
    w, V = np.linalg.eigh(np.asarray(cov, float))
    z = rng.standard_normal((DRAWS, len(w))) * np.sqrt(np.clip(w, 0, None)) @ V.T
    return z * np.sqrt(dof / rng.chisquare(dof, (DRAWS, 1))) if dof > 0 else z


def _only(terms: ThermalTerms, name: str, along: str | None = None) -> ThermalTerms:
    """The terms of one bent term ``name`` (an axis, :data:`BENT_GROWTH`, or all of them), the others 0;
    ``along``: the axis whose offset carries the tool's growth (bent as :data:`BENT_GROWTH`, its slope as the axis)."""
    if name not in terms.axes and name != BENT_GROWTH:
        return terms
    offsets = {name} if name in terms.axes and name != along else {along} if name == BENT_GROWTH else set()
    slopes = {name} if name in terms.axes else set()
    off, slope = terms.offset_um_per_k, terms.slope_um_per_m_per_k
    return dataclasses.replace(terms, offset_um_per_k={a: v * (a in offsets) for a, v in off.items()},
                               slope_um_per_m_per_k={a: v * (a in slopes) for a, v in slope.items()},
                               growth_um_per_k=terms.growth_um_per_k if name == BENT_GROWTH else None)


def remaining_mm(terms: ThermalTerms, machine, q: np.ndarray, tool, temperature_c: float) -> Remaining:
    """What the written (straight) terms leave at the commands ``q`` (N,n) [m, rad], tool
    lengths [m], at the steady (lagged) temperature ``temperature_c`` [°C]
    (:class:`Remaining`), from draws of (1) the coefficients' error, their covariance over
    time blocks held out and the lag's uncertainty (:mod:`vecpin.compensation.thermalheld`;
    Student's t, the blocks less one its degrees of freedom), and (2) the curvature per
    term the straight terms cannot follow, as the campaign bounds it
    (:func:`~vecpin.compensation.thermalheld.curvature`, drawn by
    :func:`~vecpin.compensation.thermalheld.curvature_draws`, each term's error bent by its
    own, extrapolated to this temperature). Without ``held_out`` (an older
    ``thermal.json``): the 1-sigma coefficients' error alone, floor 0."""
    q = np.atleast_2d(np.asarray(q, float))
    h, c = terms.held_out, terms.curvature
    d = float(temperature_c) - terms.t0_c
    if not h:
        sigma = dataclasses.replace(terms, offset_um_per_k=dict(terms.offset_std),
                                    slope_um_per_m_per_k=dict(terms.slope_std), growth_um_per_k=terms.growth_std)
        e = float(np.linalg.norm(tip_errors(sigma, machine, q, tool, temperature_c), axis=1).mean() * 1e3)
        return Remaining(e, e, e, 0.0, e)
    rng = np.random.default_rng(0)
    coef = _draws(h["cov"], rng, int(h.get("blocks", 0)) - 1)
    e = np.einsum("nip,dp->dni", _contribution(terms, h["names"], machine, q, tool, d), coef)
    if c:
        bend = d ** 2 - c["alpha"][0] - c["alpha"][1] * d
        names, per_k, cov = bend_terms(c)
        kappa = curvature_draws(per_k, cov, rng, DRAWS)
        bent = np.stack([tip_errors(_only(terms, nm, c.get("growth_axis")), machine, q, tool, terms.t0_c + bend)
                         for nm in names], -1)
        e = e + np.einsum("nik,dk->dni", bent, kappa)
    mean = np.linalg.norm(e, axis=2).mean(axis=1) * 1e3
    lo, hi = np.percentile(mean, BAND)
    return Remaining(float(mean.mean()), float(lo), float(hi), h["floor_um"] * 1e-3, *point_within(mean), mean)


def default_p0(machine, axes) -> dict[str, float]:
    """The middle of each axis' travel [m]: a reference position that keeps offset and
    slope apart (the controllers let the user state another)."""
    return {a: 0.5 * (machine.axis(a).lower + machine.axis(a).upper) for a in axes}


def growth_axis(model, campaign) -> str | None:
    """The linear axis whose motion is along the tool on every row (a tool that keeps its
    direction: the tool's growth and that axis' offset are one term), else None."""
    m = model.machine
    tips = model.tool_tip(campaign.q, campaign.tool, model.b_, jacobian=True)
    d = tips.tool_dir
    if np.abs(d - d[0]).max() > 1e-3:   # a fitted model's tilts are µrad
        return None
    for a in m.axes:
        if a.kind != "linear":
            continue
        col = tips.J_q[:, :, a.index]
        n = np.linalg.norm(col, axis=1)
        if np.all(n > 0) and np.all(np.abs(np.abs(np.einsum("ij,ij->i", col, d)) / n - 1.0) < 1e-4):
            return a.name
    return None


def separability(model, campaign, effect: ThermalTermsEffect) -> list[str]:
    """What the campaign cannot separate, in words: the lagged temperature against the
    time (a drift in time: the tracker's, the air's refraction), against an axis that the
    program visits in time order, and the thermal columns among themselves (condition
    number of the column-normalised columns at the model's tips)."""
    feats = Features.from_campaign(campaign)
    temp = effect.delta(feats)
    notes = []
    if np.ptp(temp) <= 0:
        return ["the temperature did not change during the campaign: no thermal term can be fitted"]
    if feats.has_time and np.ptp(feats.time) > 0:
        r = float(np.corrcoef(temp, feats.time)[0, 1])
        if abs(r) > COLLINEAR:
            notes.append(f"the temperature follows the time (correlation {r:+.3f}): the thermal terms cannot be told "
                         "from any drift in time during the campaign (the tracker's, the air's); measure while the "
                         "temperature goes up and down, or repeat poses at other times")
    for a in model.machine.axes:
        q = campaign.q[:, a.index]
        if np.ptp(q) > 0:
            r = float(np.corrcoef(temp, q)[0, 1])
            if abs(r) > COLLINEAR:
                notes.append(f"the temperature follows axis {a.name} (correlation {r:+.3f}: the program visits it in "
                             f"time order): its thermal terms cannot be told from its geometric errors; visit "
                             f"{a.name}'s positions in another order")
    tips = model.tool_tip(campaign.q, campaign.tool, model.b_, jacobian=True, features=feats)
    ctx = TipContext(model.machine, campaign.q, tips.tip, tips.tool_dir)
    cols = np.einsum("pin,pnk->pik", tips.J_q, effect.command(campaign.q, feats)) + effect.tip(ctx, feats)
    G = cols.reshape(-1, cols.shape[-1])
    norms = np.linalg.norm(G, axis=0)
    if np.any(norms == 0):
        return notes
    G = G / norms
    cond = float(np.linalg.cond(G))
    if cond > ILL_CONDITIONED:
        names = [p.name for p in effect.parameters()]
        C = np.abs(G.T @ G - np.eye(len(names)))
        i, j = np.unravel_index(int(np.argmax(C)), C.shape)
        notes.append(f"the thermal terms are nearly collinear on these rows (condition number {cond:.3g}; "
                     f"{names[i]} and {names[j]} correlate {C[i, j]:.3f}): their values are uncertain alone, "
                     f"only their sum is fitted well")
    return notes


def fit_thermal(model, campaign, noise=None, *, p0_mm: dict | None = None, lags=None) -> tuple[ThermalTerms, object]:
    """(thermal terms, the model refitted with them): the geometric part of the fitted
    ``model`` refitted on ``campaign`` together with the controller-form terms, at each
    lag of ``lags`` [h] (default :data:`LAGS_H`; the model's own thermal effect's lag
    and its neighbours there when it has one); the lag whose fit leaves the smallest
    chi-square brackets the lag, refined between its neighbours with the curvature per
    term free (:func:`refine_lag`); the held-out spread and the curvature come from the
    fit with the curvature (:func:`~vecpin.compensation.thermalheld.bent_fit`).
    ``p0_mm``: reference position per axis [mm] (default: mid-travel)."""
    m = model.machine
    if campaign.temperature is None:
        raise InputError(f"{campaign.source}: the thermal terms need a 'temperature' column in the campaign")
    feats = Features.from_campaign(campaign)
    if not feats.has_time:
        lags = (0.0,)
    elif lags is None:
        own = [e for e in model.effects if e.name == "thermal" and getattr(e, "driver", "") == "temperature"]
        lags = LAGS_H if not own else _neighbours(own[0].lag_h)
    geometric, _ = model.geometric_part()
    axes = tuple(a.name for a in m.axes if a.kind == "linear")
    if not axes:
        raise VecpinError(f"machine '{m.name}' has no linear axis: the controllers' thermal terms act on linear axes")
    p0 = default_p0(m, axes)
    for a, v in (p0_mm or {}).items():
        if a not in axes:
            raise InputError(f"`p0_mm`: '{a}' is not a linear axis of {m.name} ({', '.join(axes)})")
        p0[a] = float(m.axis(a).to_si(v))
    along = growth_axis(geometric, campaign)

    noise = noise or geometric.noise_

    def effect(lag: float) -> ThermalTermsEffect:
        t0 = float(np.mean(lagged(feats.time, campaign.temperature, lag)))
        return ThermalTermsEffect(m, axes, t_ref=t0, lag_h=lag, p0=p0, growth=along is None)

    def fit_at(lag: float):
        eff = effect(lag)
        return eff, geometric.with_effects(list(geometric.effects) + [eff]).fit(campaign, noise)

    fits = {float(lag): fit_at(float(lag)) for lag in lags}
    scanned = fits[min(fits, key=lambda v: fits[v][1].report_.chi2)]
    values = scanned[1].b_[_slice(*scanned)]
    if np.ptp(campaign.temperature) > 0 and len(fits) > 1:   # (one lag: nothing to refine)
        lag, lag_std, gradient = refine_lag(fits, fit_at, LagProblem(scanned[1], campaign, feats, scanned[0], effect,
                                                                     values, along))
    else:
        lag, lag_std, gradient = scanned[0].lag_h, 0.0, None
    eff, fitted = fits[lag]
    terms = _terms(m, eff, fitted, campaign, feats, along)
    if np.ptp(eff.delta(feats)) > 0:
        bent, curve = bent_fit(geometric, campaign, noise, eff, fitted.b_[_slice(eff, fitted)], feats, along)
        terms.held_out = with_lag(held_out(bent, campaign, feats, eff, fixed=curve), lag_std, gradient)
        terms.curvature = curvature(bent, curve)
    else:
        terms.held_out = with_lag(held_out(fitted, campaign, feats, eff), lag_std, gradient)
    return terms, fitted


def _neighbours(lag: float) -> tuple[float, ...]:
    """``lag`` [h] and the scanned lags either side of it."""
    below, above = [v for v in LAGS_H if v < lag], [v for v in LAGS_H if v > lag]
    return tuple(below[-1:]) + (float(lag),) + tuple(above[:1])


def _slice(eff: ThermalTermsEffect, fitted) -> slice:
    """The thermal terms' parameters in ``fitted.b_``."""
    return next(s for e, s in fitted.effect_slices() if e is eff)


def refine_lag(fits: dict, fit_at, problem: LagProblem) -> tuple[float, float, np.ndarray | None]:
    """(lag [h], its standard deviation [h], the coefficients' change per hour of lag):
    the scanned lags' fits ``fits`` (lag -> (effect, fitted), extended in place by the
    lag kept) bracket the lag (the best of them and its neighbours), and within that
    bracket the lag is the one whose fit *with the curvature per term* leaves the smallest
    objective (``problem``: that fit as a function of the lag, the geometry factorised
    once, :class:`~vecpin.compensation.thermalheld.LagProblem`; bounded Brent, to
    :data:`LAG_STEP_H`). Without the curvature, the curvature a wide temperature cycle
    shows moves the lag (a lag and a bend both change the gain the terms find over a
    cycle) by several of the straight fit's standard deviations. A lag off the truth by a
    fraction of the scan's step changes that gain by as much (the lag damps the cycle),
    and the steady error 10 K away with it: the lag's standard deviation (the
    objective's second difference over ± :data:`LAG_DELTA_H` about it, Δχ² = 1 times
    the fit's χ² per degree of freedom: the noise the residuals show; the curvature free,
    so its trade with the lag counted) and the coefficients' change with it (their
    central difference over the same solutions: the curvature's column is orthogonal to
    the straight terms', so they are the straight fit's) go into the prediction. A lag
    found within :data:`LAG_DELTA_H` of an end of the scan (the truth may lie beyond it),
    or one lag scanned: standard deviation 0 and no change, i.e. not counted."""
    lags = sorted(fits)
    k = min(range(len(lags)), key=lambda i: fits[lags[i]][1].report_.chi2)
    if len(lags) < 2:
        return lags[k], 0.0, None
    lo, hi = lags[max(k - 1, 0)], lags[min(k + 1, len(lags) - 1)]
    x = float(minimize_scalar(lambda v: problem.solve(v)[0], bounds=(lo, hi), method="bounded",
                              options={"xatol": LAG_STEP_H}).x)
    best = round(x, 2)
    if best not in fits:
        fits[best] = fit_at(best)
    if best - LAG_DELTA_H < lags[0] or best + LAG_DELTA_H > lags[-1]:
        return best, 0.0, None
    below, mid, above = (problem.solve(x + s * LAG_DELTA_H) for s in (-1, 0, 1))
    a = (below[0] + above[0] - 2 * mid[0]) / (2 * LAG_DELTA_H ** 2)
    scale = mid[0] / mid[1] if mid[1] > 0 else 1.0
    std = float(np.sqrt(scale / a)) if a > 0 else 0.5 * (hi - lo)   # flat: the bracket's half-width
    return best, std, (above[2] - below[2]) * UM_PER_M / (2 * LAG_DELTA_H)


def _terms(m, eff: ThermalTermsEffect, fitted, campaign, feats, along: str | None) -> ThermalTerms:
    """The fitted effect's parameters in the controllers' units, with the notes."""
    sl = next(s for e, s in fitted.effect_slices() if e is eff)
    v, s = fitted.b_[sl], fitted.std_[sl]
    off = {a: float(v[2 * k] * UM_PER_M) for k, a in enumerate(eff.axes)}
    slope = {a: float(v[2 * k + 1] * UM_PER_M) for k, a in enumerate(eff.axes)}
    notes = separability(fitted, campaign, eff)
    if along is not None:
        notes.append(f"the tool keeps its direction along {along} on this machine: its growth is {along}'s offset "
                     f"(carried there; no separate tool-direction term)")
    temp = lagged(feats.time, campaign.temperature, eff.lag_h)
    return ThermalTerms(m.name, list(eff.axes), eff.t_ref, eff.lag_h,
                        {a: float(m.axis(a).to_user(eff.p0[a])) for a in eff.axes}, off, slope,
                        None if along is not None else float(v[-1] * UM_PER_M),
                        {a: float(s[2 * k] * UM_PER_M) for k, a in enumerate(eff.axes)},
                        {a: float(s[2 * k + 1] * UM_PER_M) for k, a in enumerate(eff.axes)},
                        None if along is not None else float(s[-1] * UM_PER_M),
                        (float(temp.min()), float(temp.max())), notes)
