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

:class:`TableProblem` is that problem linearised around the model; it is linear in
the table coefficients, which the subset selection of Paper II exploits
(:mod:`vecpin.compensation.selection`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy import linalg
from scipy.stats import qmc

from vecpin.models.basis import AxisBasis
from vecpin.errors import VecpinError
from vecpin.kinematics.machine import Machine
from vecpin.models import APModel, ErrorModel
from vecpin.measurement.registration import rigid_motion_basis
from vecpin.compensation.tables import CompensationTable, TableSet, table_grid, table_name, table_names

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


TURN_WEIGHT = 1e3  # weight (squared) of the rows that hold the compensated volume's turn at 0 (in the error's norm)
TABLE_KNOTS = 15  # interior knots of the table functions: finer than any model's functions, coarser than a table


def rich_table_bases(machine: Machine, modulo_axes=(), knots: int = TABLE_KNOTS, lower: np.ndarray | None = None,
                     upper: np.ndarray | None = None) -> list[AxisBasis]:
    """Table functions able to follow any model: cubic B-splines with ``knots``
    uniform interior knots over the travel of each input axis (or over ``lower`` ..
    ``upper`` [m, rad]: the region the tables are fitted in, the measured box, held
    beyond it, so that every spline has pseudo-measurements under it); a modulo axis a
    Fourier series per turn of order 2 (knots + 1) (its table repeats every turn)."""
    out = []
    for a in machine.axes:
        rot = a.kind == "rotary"
        if a.name in modulo_axes:
            out.append(AxisBasis(a.lower, a.upper, 2 * (knots + 1), "fourier", rotary=True))
        else:
            l, h = _span(a, lower, upper)
            k = tuple(np.linspace(l, h, knots + 2)[1:-1])
            out.append(AxisBasis(l, h, 3, "bspline", rotary=rot, knots=k))
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
        l, h = _span(a, lower, upper)
        if periodic:
            l, h = a.lower, a.upper
        out.append(AxisBasis(l, h, order, "fourier" if periodic else "chebyshev", rotary=a.kind == "rotary"))
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
        l, h = _span(a, lower, upper)
        if l > a.lower or h < a.upper:
            out[a.name] = (l, h)
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

    @property
    def names(self) -> list[str]:
        return [table_name(o, i) for o, i in self.coef]

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
        return TableSet(self.machine.axis_names, tables, self.gauge_offset_change)


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


def ridged(G: np.ndarray, ridge: float, base: np.ndarray | None = None) -> np.ndarray:
    """``G`` with ``ridge`` times its diagonal (or ``base``, per column) added. A column without any data cannot
    arise from :func:`rich_table_bases` over the measured box (every spline has
    pseudo-commands under it); should one arise all the same (a caller's own bases
    wider than its commands), it gets a tiny diagonal instead of none, so its
    coefficient solves to 0 rather than failing."""
    d = np.diag(G) if base is None else base
    floor = 1e-3 * max(float(d.max(initial=0.0)), 1e-300)
    return G + ridge * np.diag(np.maximum(d, floor))


class TableProblem:
    """The table problem linearised around the actual machine (eq. 18-19).

    Pseudo-measurements: every command in ``commands`` with every tool in ``tools`` at
    every tool point of the machine (``point``, (R,)), tips relative to the workpiece.
    Unknowns: the gauge-line change dT and the coefficients of all n x n table
    functions. ``A x + e0`` approximates the compensated errors (3R,) with ``x`` the
    unknowns; :meth:`cost` of any subset of tables is then a small solve.

    ``free_origin`` (default): the tables are fitted jointly with a translation of the
    whole volume, which they leave alone: the part's origin is probed, so a translation
    does not affect it. No rotation is free: the actual machine is given in the frame the
    tables keep (:func:`in_reference_frame`), and a rotation the tables added would turn the
    working volume against the table (a part set up by probing its origin and aligning
    an edge sees every tilt). ``A`` and ``e0`` are projected orthogonally to the three
    translations. With ``hold_turn`` (the frame kept is the volume's mean orientation: a
    machine whose table turns, an arm), rows weighted by ``TURN_WEIGHT`` hold the compensated
    error's best-fit rotation at 0: the least-squares tables would otherwise trade a turn of up to 0.1 mrad of
    the whole volume for a smaller error elsewhere, which a part on the table sees as a tilt. ``ridge``: relative to each column's squares before that projection
    (table values that only trade against a translation stay small).
    """

    def __init__(self, actual: ActualMachine, machine: Machine, commands: np.ndarray, tools, order: int = 8,
                 basis: str = "fourier", modulo_axes=(), ridge: float = 1e-4, bases: list[AxisBasis] | None = None,
                 hold: dict[str, tuple[float, float]] | None = None, free_origin: bool = True,
                 hold_turn: bool = False):
        self.actual, self.machine = actual, machine
        self.free_origin = free_origin  # fit the tables jointly with a translation of the whole volume
        self.hold_turn = hold_turn  # hold the compensated volume's best-fit rotation at 0
        self.tools = np.asarray(tools, float)
        P = len(machine.tool_links)
        commands = np.asarray(commands, float)
        self.q = np.tile(np.repeat(commands, len(self.tools), axis=0), (P, 1))
        self.L = np.tile(self.tools, len(commands) * P)
        self.point = np.repeat(np.arange(P), len(commands) * len(self.tools))
        self.bases = bases if bases is not None else table_bases(machine, order, basis, modulo_axes)
        self.hold = hold or None  # measured range per input axis [m, rad]: tables held constant beyond it
        self.free_gauge = True  # False: the gauge line (T_offset) stays as it is
        self.modulo_axes = tuple(modulo_axes)
        self.ridge = ridge
        self.pairs = [(ao.name, ai.name) for ao in machine.axes for ai in machine.axes]
        self.names = table_names(machine.axis_names)
        # column layout: [dT] + one block per pair
        self.blocks: dict[str, np.ndarray] = {}
        col = 1
        for (o, i), name in zip(self.pairs, self.names):
            size = self.bases[machine.axis(i).index].size - (0 if o == i else 1)
            self.blocks[name] = np.arange(col, col + size)
            col += size
        self.n_columns = col
        self._linearise()

    # -------------------------------------------------------------- linear algebra
    def _design(self, J: np.ndarray, u_nominal: np.ndarray, names=None) -> np.ndarray:
        """d tip error / d unknowns (3R, columns) [m]: every column, or those of :meth:`columns` ``names``, in order."""
        cols = np.arange(self.n_columns) if names is None else self.columns(names)
        where = np.full(self.n_columns, -1)
        where[cols] = np.arange(len(cols))
        A = np.empty((len(self.q), 3, len(cols)))
        if where[0] >= 0:
            A[:, :, where[0]] = -u_nominal
        Bv = [B.values(self._held(k, self.q[:, k])) for k, B in enumerate(self.bases)]
        for (o, i), name in zip(self.pairs, self.names):
            k, ii = self.machine.axis(o).index, self.machine.axis(i).index
            if where[self.blocks[name][0]] >= 0:
                A[:, :, where[self.blocks[name]]] = J[:, :, k, None] * (Bv[ii] if o == i else Bv[ii][:, 1:])[:, None, :]
        return A.reshape(-1, len(cols))

    def _linearise(self) -> None:
        nominal = self.machine.kinematics(self.q, self.L, jacobian=True, frame=FRAME, point=self._pt)
        self.u_nominal = nominal.tool_dir
        tip, J = self.actual(self.q, self.L, True, self._pt)
        # a linear axis moving along the tool everywhere (the W quill of an XYZBAW head) does what a gauge-line
        # change does: its pitch table carries it, and the two together have no unique solution. Judged on the
        # nominal machine: the actual one's angular errors tilt the quill off the tool by up to mrad
        Jn = nominal.jacobian / np.maximum(np.linalg.norm(nominal.jacobian, axis=1, keepdims=True), 1e-300)
        along = np.abs(np.einsum("pik,pi->pk", Jn, self.u_nominal)).min(axis=0) > 1 - 1e-9
        self.along_tool = [a.name for a in self.machine.axes if a.kind == "linear" and along[a.index]]
        if self.along_tool:
            self.free_gauge = False
        self.e0 = (tip - nominal.tip).ravel()
        self.A = self._design(J, self.u_nominal)
        self._rigid = np.tile(np.eye(3), (len(self.q), 1)) / np.sqrt(len(self.q)) if self.free_origin else None
        # the ridge's scale: the columns' squares before the translations are taken out (a pitch constant of a
        # linear axis is almost a translation: projected, its column nearly vanishes, and a ridge relative to
        # that would let it grow to metres)
        self.ridge_base = np.einsum("ij,ij->j", self.A, self.A)
        self.e0, self.A = self._registered(self.e0), self._registered(self.A)
        # where the frame kept is the volume's mean orientation, the tables may not turn it: the rotational
        # component of the compensated error is held at 0 (weighted rows, TURN_WEIGHT)
        self._turn = rigid_motion_basis(nominal.tip)[:, 3:] if self.free_origin and self.hold_turn else None
        self.G, self.g = self._normal(self.A, self.e0)
        self.e0e0 = float(self.e0 @ self.e0) + (0.0 if self._turn is None else
                                                  TURN_WEIGHT * float(np.sum((self._turn.T @ self.e0) ** 2)))
        self._scale = np.sqrt(np.maximum(np.diag(self.G), 1e-30))

    def _normal(self, A: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(A'A, A'e) of the least-squares problem, with the rows that hold the volume's turn."""
        G, g = A.T @ A, A.T @ e
        if self._turn is not None:
            C, c = self._turn.T @ A, self._turn.T @ e
            G, g = G + TURN_WEIGHT * C.T @ C, g + TURN_WEIGHT * C.T @ c
        return G, g

    def _registered(self, M: np.ndarray) -> np.ndarray:
        """``M`` (3R,) or (3R, k) with its share of a translation of the whole volume
        removed (projected orthogonally to the three translations): the tables are then
        fitted jointly with the best translation, which no table needs to cancel (the
        part's origin is probed). Unchanged when ``free_origin`` is off. A C-ordered
        (3R, k) ``M`` is overwritten (one BLAS pass through its transpose: M' = M - Q (Q' M))."""
        if self._rigid is not None and M.ndim == 2 and M.flags.c_contiguous and M.dtype == np.float64:
            return linalg.blas.dgemm(-1.0, self._rigid.T @ M, self._rigid, 1.0, M.T, trans_a=1, trans_b=1,
                                     overwrite_c=1).T
        return M if self._rigid is None else M - self._rigid @ (self._rigid.T @ M)

    def _held(self, k: int, q_in: np.ndarray) -> np.ndarray:
        """Positions of input axis k as the table functions see them: clipped to the
        held range (a command beyond the measured range gets the value at its edge)."""
        a = self.machine.axes[k]
        if self.hold and a.name in self.hold and a.name not in self.modulo_axes:
            return np.clip(q_in, *self.hold[a.name])
        return q_in

    @property
    def _pt(self):
        """The tool point of every row (one int on a machine with one tool point)."""
        return 0 if len(self.machine.tool_links) == 1 else self.point

    def columns(self, names) -> np.ndarray:
        """Columns of dT (unless the gauge line is fixed) and of the given tables."""
        head = [[0]] if self.free_gauge else []
        return np.concatenate(head + [self.blocks[n.lower()] for n in names]).astype(int)

    def gauge_std(self, names, J_b: np.ndarray, cov_b: np.ndarray) -> float:
        """Standard deviation [m] of the gauge-line change of the tables ``names`` from the
        model's parameter covariance ``cov_b`` (SI), with ``J_b`` (R,3,P) the model's
        d tip / d b at the problem's pseudo-measurements: dT is linear in the errors the
        tables cancel, so var(dT) = r cov r with r = d dT / d b."""
        cols = self.columns(names)
        G = self.G[np.ix_(cols, cols)]
        G = ridged(G, self.ridge, self.ridge_base[cols])
        z = linalg.solve(G, np.eye(len(cols))[0], assume_a="pos")      # row 0 of G^-1
        r = -(self.A[:, cols] @ z) @ J_b.reshape(self.A.shape[0], -1)      # d dT / d b
        return float(np.sqrt(max(r @ cov_b @ r, 0.0)))

    def solve_linear(self, names) -> np.ndarray:
        """Least-squares unknowns (full length, zeros outside the subset) of the linearised problem."""
        cols = self.columns(names)
        G = self.G[np.ix_(cols, cols)]
        G = ridged(G, self.ridge, self.ridge_base[cols])
        x = np.zeros(self.n_columns)
        x[cols] = -linalg.solve(G, self.g[cols], assume_a="pos")
        return x

    def cost(self, names) -> float:
        """Linearised RMS volumetric error [m] of the best tables restricted to ``names``."""
        x = self.solve_linear(names)
        return math.sqrt(max(self.e0e0 + x @ self.g, 0.0) / len(self.q))

    # -------------------------------------------------------------- exact solve
    def functions(self, x: np.ndarray, names) -> CompensationFunctions:
        coef = {}
        for n in names:
            o, i = self.pairs[self.names.index(n.lower())]
            coef[(o, i)] = x[self.blocks[n.lower()]].copy()
        return CompensationFunctions(self.machine, self.bases, coef, float(x[0]) if self.free_gauge else 0.0,
                                     self.modulo_axes, self.hold)

    def solve(self, names, iterations: int = 3) -> CompensationFunctions:
        """Tables restricted to ``names`` by Gauss-Newton on the actual machine
        (the linear solve, then re-linearised at the compensated commands)."""
        names = [n.lower() for n in names]
        cols = self.columns(names)
        x = self.solve_linear(names)
        for _ in range(iterations):
            qc = self.q + self.functions(x, names).increments(self.q)
            tip, J = self.actual(qc, self.L, True, self._pt)
            nominal = nominal_tip(self.machine, self.q, self.L + x[0], self._pt)
            e = self._registered((tip - nominal).ravel())
            A = self._registered(self._design(J, self.u_nominal, names))
            G, g = self._normal(A, e)
            dx = -linalg.solve(ridged(G, self.ridge, self.ridge_base[cols]), g, assume_a="pos")
            x[cols] += dx
            if np.abs(dx).max() < 1e-12:
                break
        return self.functions(x, names)


def all_table_names(machine: Machine) -> list[str]:
    return table_names(machine.axis_names)


def pitch_names(machine: Machine) -> list[str]:
    return [table_name(a, a) for a in machine.axis_names]
