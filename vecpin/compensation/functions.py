"""Compensation functions from an error model, and their effect (Paper I §3.3, Paper II §2).

The compensation functions ``t_oi(q_i)`` (output axis o, input axis i) are smooth
series in the input axis, like the model's, and the controller's gauge-line offset
``T_offset`` may change by ``dT``. They are chosen so that the compensated machine
follows the controller's nominal kinematics:
``F_a(q + t(q), L) ≈ F_n(q, L + dT)`` for every command and tool.

The tool tip that matters is the tip *relative to the workpiece* (on a machine with a
table branch; the base frame otherwise): what a compensated machine cuts into a part.
On a machine with several tool points driven by one command set (Spar Mill 23's
mirrored spindles) the tables serve every tool point at once.

* AP model: ``t = -q_hat`` and ``dT`` = the model's gauge-line correction (eq. 17)
  (:func:`from_ap_model`).
* Any model (6-DoF, AP, a true simulated machine): the pseudo-measurement projection
  (eq. 18-19): Gauss-Newton on ``sum |F_a(q + t(q)) - F_n(q, L + dT)|^2`` over
  quasi-random commands and two tool lengths, with the model's analytic Jacobian.

Which of the two a table set uses is decided in :func:`vecpin.compensation.plan.plan_tables`.
Either way the functions are held constant beyond the region the tables are fitted
in (the model's measured box, or a zone): a table must not extrapolate what was never
measured.

That problem linearised around the model is
:class:`~vecpin.compensation.tableproblem.TableProblem`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.stats import qmc

from vecpin.models.basis import AxisBasis
from vecpin.errors import VecpinError
from vecpin.kinematics.machine import Machine
from vecpin.models import APModel, ErrorModel
from vecpin.compensation.tables import (CompensationTable, ProductTable, TableSet, product_name, table_grid,
                                        table_name, table_names)

# actual(q, tool, jacobian, point) -> (tip (N,3) relative to the workpiece [m], d tip / d q (N,3,n) or None)
ActualMachine = Callable[..., tuple]
FRAME = "workpiece"  # tables correct the tool relative to the part (the base frame on a serial machine)


def geometric_model(model: ErrorModel) -> ErrorModel:
    """The part of a fitted model that tables can carry: the model without its effects
    that depend on the rows (thermal, backlash, an instrument shift); the model itself
    when it has none. Everything that computes or judges tables uses this part (a
    row-dependent effect cannot be evaluated without a campaign's rows)."""
    model._check_fitted()
    return model.geometric_part()[0] if model.row_dependent else model


def truth_as_actual(truth) -> ActualMachine:
    """A simulated true machine as the actual machine (for checking tables against
    truth, and for the table floor). Asked for a Jacobian it gives the nominal one: the
    true errors are small, so it only steers the Gauss-Newton steps; the tip is true."""

    def actual(q, tool, jacobian=False, point=0):
        tip = truth.tool_tip(q, tool, frame=FRAME, point=point)
        return tip, (truth.machine.kinematics(q, tool, True, frame=FRAME, point=point).jacobian if jacobian else None)
    return actual


def nominal_tip(machine: Machine, q: np.ndarray, tool, point=0) -> np.ndarray:
    """The controller's nominal tool tip (N,3) [m] relative to the workpiece."""
    return machine.tool_tip(q, tool, frame=FRAME, point=point)


TABLE_KNOTS = 15  # interior knots of the table functions: finer than any model's functions, coarser than a table


def rich_table_bases(machine: Machine, modulo_axes=(), knots: int = TABLE_KNOTS, lower: np.ndarray | None = None,
                     upper: np.ndarray | None = None) -> list[AxisBasis]:
    """Table functions able to follow any model: cubic B-splines with ``knots``
    uniform interior knots over the travel of each input axis (or over ``lower`` ..
    ``upper`` [m, rad]: the region the tables are fitted in, the measured box, held
    beyond it, so that every spline has pseudo-measurements under it; a rotary axis that
    travels more than a turn ``knots`` per turn, as its errors repeat every turn); a modulo axis a
    Fourier series per turn of order 2 (knots + 1) (its table repeats every turn)."""
    out = []
    for a in machine.axes:
        rot = a.kind == "rotary"
        if a.name in modulo_axes:
            out.append(AxisBasis(a.lower, a.upper, 2 * (knots + 1), "fourier", rotary=True))
        else:
            lo, hi = _span(a, lower, upper)
            n = knots if not rot or hi - lo <= 2 * np.pi else int(np.ceil(knots * (hi - lo) / (2 * np.pi)))
            k = tuple(np.linspace(lo, hi, n + 2)[1:-1])      # a rotary axis of several turns: ``knots`` per turn
            out.append(AxisBasis(lo, hi, 3, "bspline", rotary=rot, knots=k))
    return out


def table_bases(machine: Machine, order: int, basis: str = "fourier", modulo_axes=(), lower: np.ndarray | None = None,
                upper: np.ndarray | None = None) -> list[AxisBasis]:
    """Basis of the compensation functions of each *input* axis: Chebyshev over the
    travel (or over ``lower`` .. ``upper`` [m, rad], the region the tables are fitted
    in); Fourier on rotary axes travelling more than a turn (``basis="fourier"``) and on
    modulo axes (a modulo table must repeat every turn)."""
    out = []
    for a in machine.axes:
        periodic = a.kind == "rotary" and (a.name in modulo_axes or (basis == "fourier" and a.multiturn))
        lo, hi = _span(a, lower, upper)
        if periodic:
            lo, hi = a.lower, a.upper
        out.append(AxisBasis(lo, hi, order, "fourier" if periodic else "chebyshev", rotary=a.kind == "rotary"))
    return out


def _span(axis, lower: np.ndarray | None, upper: np.ndarray | None) -> tuple[float, float]:
    """(low, high) [m, rad] of an axis' table functions: ``lower``..``upper`` when given
    and not empty, else the travel."""
    if lower is None or upper is None or not upper[axis.index] > lower[axis.index]:
        return axis.lower, axis.upper
    return float(lower[axis.index]), float(upper[axis.index])


def hold_ranges(machine: Machine, lower: np.ndarray, upper: np.ndarray, modulo_axes=()) -> dict[str, tuple[float, float]]:
    """{input axis: (low, high) [m, rad]} of every axis whose region ``lower``..``upper``
    (the measured box or a zone) leaves part of its travel out: the table functions are
    held constant beyond it, exactly (their bases span only this region). Modulo axes
    repeat every turn and are never held."""
    out = {}
    for a in machine.axes:
        if a.name in modulo_axes:
            continue
        lo, hi = _span(a, lower, upper)
        if lo > a.lower or hi < a.upper:
            out[a.name] = (lo, hi)
    return out


@dataclass
class CompensationFunctions:
    """Smooth table functions: ``t_oi(q_i) = sum_k coef[(o, i)][k] B_i,k(q_i)`` (SI).

    Pitch functions (o == i) carry the constant column; off-diagonal ones do not (a
    constant is the same for every input)."""

    machine: Machine
    bases: list[AxisBasis]
    coef: dict[tuple[str, str], np.ndarray]
    gauge_offset_change: float = 0.0
    modulo_axes: tuple[str, ...] = ()
    hold: dict[str, tuple[float, float]] | None = None  # input axis -> measured (lo, hi) [m, rad]: constant outside
    products: dict[tuple[str, str, str], np.ndarray] | None = None  # (output, table axis, factor axis) -> coef

    @property
    def names(self) -> list[str]:
        return [table_name(o, i) for o, i in self.coef] + [product_name(*k) for k in self.products or {}]

    def ramp(self, axis: str, q_in: np.ndarray) -> np.ndarray:
        """The fixed factor of a product term over ``axis``: -1 .. 1 across its measured range
        (the travel where nothing is held), held beyond it (dimensionless)."""
        return ramp(self.machine, self.hold, axis, q_in)

    def product(self, key: tuple[str, str, str], q_table: np.ndarray) -> np.ndarray:
        """The table of product term ``key`` (output, table axis, factor axis) at the table axis' positions
        [m or rad of the output]: the table axis' basis without its constant."""
        o, r, _ = key
        c = self.products[key]
        if self.hold and r in self.hold and r not in self.modulo_axes:
            q_table = np.clip(q_table, *self.hold[r])
        return self.bases[self.machine.axis(r).index].values(np.asarray(q_table, float))[:, 1:1 + c.size] @ c

    def function(self, output_axis: str, input_axis: str, q_in: np.ndarray) -> np.ndarray:
        """t_oi at input positions [m, rad]; held at its value at the edge of the measured
        range beyond it (a table must not extrapolate what was never measured)."""
        i = self.machine.axis(input_axis).index
        c = self.coef[(output_axis, input_axis)]
        q_in = np.asarray(q_in, float)
        if self.hold and input_axis in self.hold and input_axis not in self.modulo_axes:
            q_in = np.clip(q_in, *self.hold[input_axis])
        B = self.bases[i].values(q_in)
        return B[:, :c.size] @ c if output_axis == input_axis else B[:, 1:1 + c.size] @ c

    def increments(self, q: np.ndarray) -> np.ndarray:
        q = np.atleast_2d(np.asarray(q, float))
        out = np.zeros_like(q)
        for (o, i), _ in self.coef.items():
            out[:, self.machine.axis(o).index] += self.function(o, i, q[:, self.machine.axis(i).index])
        for key in self.products or {}:
            o, r, f = (self.machine.axis(a).index for a in key)
            out[:, o] += self.product(key, q[:, r]) * self.ramp(key[2], q[:, f])
        return out

    def discretise(self, n_points: int = 1024) -> TableSet:
        """Tables of ``n_points`` over each input axis' travel (one turn on modulo axes)."""
        tables = []
        for (o, i) in self.coef:
            ax = self.machine.axis(i)
            modulo = i in self.modulo_axes
            start, step = table_grid(ax, n_points, modulo)
            pos = start + step * np.arange(n_points)
            vals = self.function(o, i, pos)
            if modulo:
                vals[-1] = vals[0]  # the two ends of a modulo table are the same physical position
            tables.append(CompensationTable(i, o, start, step, vals, modulo))
        products = []
        for key in self.products or {}:
            o, r, f = key
            start, step = table_grid(self.machine.axis(r), n_points, r in self.modulo_axes)
            vals = self.product(key, start + step * np.arange(n_points))
            if r in self.modulo_axes:
                vals[-1] = vals[0]
            fs, fstep = table_grid(self.machine.axis(f), n_points, False)
            ramp_values = self.ramp(f, fs + fstep * np.arange(n_points))
            products.append(ProductTable(CompensationTable(r, o, start, step, vals, r in self.modulo_axes),
                                         CompensationTable(f, o, fs, fstep, ramp_values)))
        return TableSet(self.machine.axis_names, tables, self.gauge_offset_change, products=products)


def ramp(machine: Machine, hold: dict | None, axis: str, q_in: np.ndarray) -> np.ndarray:
    """-1 .. 1 across ``axis``' range in ``hold`` (its travel when not held), held beyond (dimensionless)."""
    a = machine.axis(axis)
    lo, hi = (hold or {}).get(axis, (a.lower, a.upper))
    return np.clip((2.0 * np.asarray(q_in, float) - lo - hi) / (hi - lo), -1.0, 1.0)


def from_ap_model(model: APModel, modulo_axes=(), hold: dict[str, tuple[float, float]] | None = None
                  ) -> CompensationFunctions:
    """Tables of an AP model: the negated perturbations (eq. 17) and its gauge-line
    correction as the change of T_offset. ``modulo_axes``: rotary inputs whose tables
    repeat every turn (their basis must be periodic); ``hold``: {axis: (low, high)}
    [m, rad], the functions held constant beyond (the measured range)."""
    model._check_fitted()
    m = model.machine
    for a in modulo_axes:
        if model.bases[m.axis(a).index].kind != "fourier":
            raise VecpinError(f"a modulo table on {a} must repeat every turn, but the model's basis on {a} is not "
                              "periodic: fit with `basis` auto (Fourier on rotary axes travelling more than a turn)")
    c, a = model.split(model.b_)
    coef = {}
    for o, ao in enumerate(m.axes):
        for i, ai in enumerate(m.axes):
            B = model.bases[i]
            if o == i:
                coef[(ao.name, ai.name)] = -np.r_[c[o], a[:B.size - 1, i, o]]
            else:
                coef[(ao.name, ai.name)] = -a[:B.size - 1, i, o]
    return CompensationFunctions(m, list(model.bases), coef, float(model.b_[0]), tuple(modulo_axes), hold or None)


def pseudo_commands(machine: Machine, n: int = 1000, seed: int = 0, lower: np.ndarray | None = None,
                    upper: np.ndarray | None = None) -> np.ndarray:
    """Quasi-random (scrambled Halton) commands [m, rad] over the axis space, or over
    the box ``lower``..``upper`` (e.g. the measured region)."""
    lo = machine.lower if lower is None else np.asarray(lower, float)
    hi = machine.upper if upper is None else np.asarray(upper, float)
    u = qmc.Halton(machine.n_axes, seed=seed).random(n)
    return lo + u * (hi - lo)


def all_table_names(machine: Machine) -> list[str]:
    return table_names(machine.axis_names)


def pitch_names(machine: Machine) -> list[str]:
    return [table_name(a, a) for a in machine.axis_names]
