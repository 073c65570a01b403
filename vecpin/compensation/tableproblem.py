"""The table problem linearised around the actual machine (Paper I eq. 18-19, Paper II §2).

Pseudo-measurements at quasi-random commands and tool lengths, unknowns the gauge-line
change and the coefficients of every table function (:mod:`vecpin.compensation.functions`):
the compensated tool-tip errors relative to the workpiece [m] are linear in them, so the
least-squares tables of any subset are a small solve, which the subset selection of Paper II
exploits (:mod:`vecpin.compensation.selection`); :meth:`TableProblem.solve` then solves a
subset exactly by Gauss-Newton on the actual machine.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import linalg

from vecpin.compensation.functions import FRAME, ActualMachine, CompensationFunctions, nominal_tip, ramp, table_bases
from vecpin.compensation.tables import product_name, table_names
from vecpin.kinematics.machine import Machine
from vecpin.measurement.registration import rigid_motion_basis
from vecpin.models.basis import AxisBasis

TURN_WEIGHT = 1e3  # weight (squared) of the rows that hold the compensated volume's turn at 0 (in the error's norm)


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
    machine whose table turns, an arm; or the table's face with product terms written),
    rows weighted by ``TURN_WEIGHT`` hold the compensated
    error's best-fit rotation at 0: the least-squares tables would otherwise trade a turn of up to 0.1 mrad of
    the whole volume for a smaller error elsewhere, which a part on the table sees as a tilt. ``ridge``: relative
    to each column's squares before that projection (table values that only trade against a translation stay
    small). ``products``: (output, table axis, factor axis) of product terms
    (:mod:`~vecpin.compensation.products`), named like 'zc*x': their columns are the table axis' basis
    (no constant) times the fixed ramp of the factor axis, so the problem stays linear.
    """

    def __init__(self, actual: ActualMachine, machine: Machine, commands: np.ndarray, tools, order: int = 8,
                 basis: str = "fourier", modulo_axes=(), ridge: float = 1e-4, bases: list[AxisBasis] | None = None,
                 hold: dict[str, tuple[float, float]] | None = None, free_origin: bool = True,
                 hold_turn: bool = False, products=()):
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
        # product terms (output, table axis, factor axis): a table of the table axis (no constant) times a ramp
        self.products = {product_name(*k): tuple(k) for k in products}
        for name, (o, r, f) in self.products.items():
            size = self.bases[machine.axis(r).index].size - 1
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
        for name, (o, r, f) in self.products.items():
            if where[self.blocks[name][0]] >= 0:
                g = ramp(self.machine, self.hold, f, self.q[:, self.machine.axis(f).index])
                A[:, :, where[self.blocks[name]]] = (J[:, :, self.machine.axis(o).index, None]
                                                     * (Bv[self.machine.axis(r).index][:, 1:] * g[:, None])[:, None, :])
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

    def _normal(self, A: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(A'A, A'e) of the least-squares problem, with the rows that hold the volume's turn."""
        G, g = A.T @ A, A.T @ e
        if self._turn is not None:
            C, c = self._turn.T @ A, self._turn.T @ e
            G, g = G + TURN_WEIGHT * C.T @ C, g + TURN_WEIGHT * C.T @ c
        return G, g

    def release_turn(self) -> None:
        """Stop holding the compensated volume's turn at 0: the rows ``hold_turn`` added taken out of the
        normal equations (new arrays: a shallow copy keeps its own), as tables that leave the turn to least
        squares solve it (one-axis tables in the table's face frame, :mod:`~vecpin.compensation.products`)."""
        if self._turn is not None:
            C, c = self._turn.T @ self.A, self._turn.T @ self.e0
            self.G, self.g = self.G - TURN_WEIGHT * C.T @ C, self.g - TURN_WEIGHT * C.T @ c
            self.e0e0 -= TURN_WEIGHT * float(c @ c)
        self._turn, self.hold_turn = None, False

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
        coef, products = {}, {}
        for n in names:
            if n.lower() in self.products:
                products[self.products[n.lower()]] = x[self.blocks[n.lower()]].copy()
                continue
            o, i = self.pairs[self.names.index(n.lower())]
            coef[(o, i)] = x[self.blocks[n.lower()]].copy()
        return CompensationFunctions(self.machine, self.bases, coef, float(x[0]) if self.free_gauge else 0.0,
                                     self.modulo_axes, self.hold, products or None)

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
