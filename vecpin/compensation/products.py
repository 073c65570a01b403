"""Product terms: a table of a turning table's axis times a fixed ramp of a linear axis.

A tilt of the working volume fixed to a table that turns is, in the machine's axes, a
correction such as Δz = a(C) x + b(C) y: a function of the rotary axis times a linear axis'
position, which no sum of one-axis tables can carry (:mod:`vecpin.compensation.follow`).
A controller that multiplies one table by another (SINUMERIK 840D sl / 828D,
``$AN_CEC_MULT_BY_TABLE``, Function Manual K3 03/2013 p.245 item 8, p.249) carries it as
the product of a table over the rotary axis R and a fixed ramp table over the linear axis L
(-1 .. 1 across L's measured range), both with the output axis O. With the ramp fixed, the
set stays linear in the table coefficients, so the product terms are columns of the same
table problem (:class:`~vecpin.compensation.tableproblem.TableProblem`, ``products``).

They are offered on machines whose table turns (a rotary axis on the table branch), with
the full table set (not where the controller's table limit forces a subset), and chosen by
forward selection on the error they are expected to leave on the machine (:class:`ProductEvidence`):
the model's linearised error plus twice the share of the model's own uncertainty (its parameters'
covariance from the campaign) the terms would follow, so a term the campaign does not determine
(its coefficients mostly the fit's noise) is not chosen, however much of the model it removes. A
term stays when it lowers that error's RMS by at least :data:`MIN_GAIN` of what is left, within
the controller's table count (two tables per term). The set with them is kept only when its
model-predicted error in the part's frame is lower.

By default (:func:`products_wanted`) they are on where the campaign reads the table's face
(the fit was given the nests' heights above it: the tables keep the table, and a tilt fixed
to it is what is left) and the controller carries them exactly as planned (vecpin's generic
files, vecpin's LinuxCNC component); written, they come with the tables' turn of the volume against
the face held at zero (:func:`~vecpin.compensation.plan._table_problem`); where none is used, the
hold goes with them (:func:`with_products`): the tables are then the one-axis tables least squares
gives, as without product terms. Where the controller's meaning of a product is
inferred (``ControllerLimits.products_caveat``: SINUMERIK) they are computed and their gain
printed, but written only when asked for.
"""
from __future__ import annotations

import copy

import numpy as np
from scipy import linalg

from vecpin.compensation.functions import FRAME
from vecpin.compensation.limits import ControllerLimits
from vecpin.compensation.tableproblem import TURN_WEIGHT, TableProblem, ridged
from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.registration import rigid_motion_basis
from vecpin.units import norm_mm

MIN_GAIN = 0.01       # a product term is kept when it lowers the expected error by this share of what is left
TABLES_PER_TERM = 2   # the table over the rotary axis and the ramp over the linear axis


def product_candidates(machine: Machine) -> list[tuple[str, str, str]]:
    """(output, table axis, factor axis) of every product term: each rotary axis of the table
    branch, each linear axis as the factor and as the output; none on a machine whose table
    does not turn."""
    rotary = [a.name for a in machine.axes if a.kind == "rotary" and a.side == "table" and machine.has_workpiece]
    linear = [a.name for a in machine.axes if a.kind == "linear"]
    return [(o, r, f) for o in linear for r in rotary for f in linear]


def room_for_products(limits: ControllerLimits, n_cross: int) -> int | None:
    """How many product terms fit beside ``n_cross`` cross tables (None: no limit); 0 where the
    controller does not multiply tables."""
    if not limits.products:
        return 0
    if limits.max_cross_tables is None:
        return None
    return max(0, (limits.max_cross_tables - n_cross) // TABLES_PER_TERM)


class ProductEvidence:
    """The error the tables ``base`` plus product terms of ``problem`` are expected to leave on the machine,
    [m^2 x rows], for any set of the terms: the model's linearised error they leave (the weighted least-squares
    residual, :meth:`TableProblem.cost` squared times the rows) plus twice the share of the model's own
    uncertainty they take on (Mallows' C_p; ``noise``: (3R, k) F with F F' the covariance of the model's
    predicted errors at the problem's rows, :func:`prediction_noise`; None: none).

    Tables fitted to the model ê = e + δ (e the machine's error, δ its estimate's error, covariance F F')
    leave e - H ê on the machine (H: the tables' linear map), whose expected square is |(I - H) e|^2 +
    tr(H F F' H'); |(I - H) e|^2 is estimated by |(I - H) ê|^2 - tr((I - H) F F' (I - H)'), so the
    expected square is |(I - H) ê|^2 + 2 tr(F' H F) less a constant: a term whose coefficients the
    campaign does not determine follows δ, and pays for it here. The one-axis tables ``base`` are
    eliminated once (Schur complement): each set of terms is then a solve of its own columns only."""

    def __init__(self, problem: TableProblem, base: list[str], noise: np.ndarray | None = None):
        self.names = list(problem.products)
        cb = problem.columns(base)
        sizes = [len(problem.blocks[n]) for n in self.names]
        self.spans = dict(zip(self.names, np.split(np.arange(sum(sizes)), np.cumsum(sizes)[:-1])))
        cols = np.concatenate([cb] + [problem.blocks[n] for n in self.names])
        G = ridged(problem.G[np.ix_(cols, cols)], problem.ridge, problem.ridge_base[cols])
        nb, g = len(cb), problem.g[cols]
        cf = linalg.cho_factor(G[:nb, :nb])
        W = linalg.cho_solve(cf, G[:nb, nb:])
        self.S, self.h = G[nb:, nb:] - G[nb:, :nb] @ W, g[nb:] - W.T @ g[:nb]
        self.base = problem.e0e0 - g[:nb] @ linalg.cho_solve(cf, g[:nb])
        self.P = self.Pw = None
        self.base_noise = 0.0   # tr(F' H F) of the base alone [m^2 x rows]
        if noise is not None:
            phi = problem.A.T @ noise                      # (columns, k): A' F, the data rows
            phi_w = phi if problem._turn is None else phi + TURN_WEIGHT * (problem._turn.T @ problem.A).T @ (
                problem._turn.T @ noise)                   # with the rows that hold the turn: the tables' response
            self.P, self.Pw = (f[cols][nb:] - W.T @ f[cols][:nb] for f in (phi, phi_w))
            self.base_noise = float(np.sum(phi[cols][:nb] * linalg.cho_solve(cf, phi_w[cols][:nb])))

    def total(self, terms) -> float:
        """Expected square error [m^2 x rows] of the base with ``terms``, less a constant of the problem."""
        return self.value(terms) + 2.0 * self.base_noise

    def value(self, terms) -> float:
        """Expected square error [m^2 x rows] of the base with ``terms``, less a constant of the base."""
        if not len(terms):
            return self.base
        idx = np.concatenate([self.spans[t] for t in terms])
        rhs = self.h[idx, None] if self.P is None else np.column_stack([self.h[idx], self.Pw[idx]])
        x = linalg.solve(self.S[np.ix_(idx, idx)], rhs, assume_a="pos")
        noise = 0.0 if self.P is None else float(np.sum(self.P[idx] * x[:, 1:]))
        return self.base - float(self.h[idx] @ x[:, 0]) + 2.0 * noise


def prediction_noise(model, problem: TableProblem, rotation: np.ndarray) -> np.ndarray:
    """(3R, k) F with F F' the covariance [m^2] of ``model``'s predicted tip errors at the problem's rows
    from its parameters' covariance (``cov_``, the tracker pose's six left out), turned by ``rotation``
    into the frame the tables keep, less a rigid motion of the whole volume: a translation (the problem's
    errors are registered so) and a rotation, which the tracker's pose absorbs (the parameters' marginal
    covariance holds it as a large, near-unobservable turn) and which moves the frame the tables keep with
    it (the reference lines, the mean orientation, the nests' face are the same fit's): not an error the
    tables follow (as :func:`~vecpin.compensation.plan.parameter_spread` takes each draw into its own frame)."""
    out = model.tool_tip(problem.q, problem.L, model.b_, jacobian=True, frame=FRAME, point=problem._pt)
    J = np.einsum("ij,njp->nip", rotation, out.J_b).reshape(3 * len(problem.q), -1)
    cov = np.asarray(model.cov_, float)[6:, 6:]
    w, U = np.linalg.eigh(0.5 * (cov + cov.T))
    keep = w > 0
    F = J @ (U[:, keep] * np.sqrt(w[keep]))
    tips = problem.machine.kinematics(problem.q, problem.L, frame=FRAME, point=problem._pt).tip
    Q = rigid_motion_basis(tips)
    return np.ascontiguousarray(F - Q @ (Q.T @ F))


def choose_products(problem: TableProblem, base: list[str], room: int | None, noise: np.ndarray | None = None,
                    release: bool = False) -> list[str]:
    """Product terms of ``problem`` added to the tables ``base`` by forward selection on the error they are
    expected to leave on the machine (:class:`ProductEvidence`; ``noise``: the model's prediction noise,
    None: the model taken as exact): each step takes the term that lowers it most, while that lowers its
    RMS by at least :data:`MIN_GAIN` of what is left and ``room`` (None: no limit) allows. ``release``: the
    problem holds the volume's turn only for the terms (the table's face): they must then also beat the base
    without that hold (the one-axis tables least squares gives), else none is chosen."""
    evidence = ProductEvidence(problem, base, noise)
    chosen: list[str] = []
    left = list(evidence.names)
    rms = np.sqrt(max(evidence.total([]), 0.0))
    while left and (room is None or len(chosen) < room):
        values = np.sqrt(np.maximum([evidence.total(chosen + [p]) for p in left], 0.0))
        best = int(np.argmin(values))
        if rms - values[best] < MIN_GAIN * rms:
            break
        chosen.append(left.pop(best))
        rms = float(values[best])
    if release and chosen:   # the terms with the hold against the one-axis tables without it
        free = copy.copy(problem)
        free.release_turn()
        without = np.sqrt(max(ProductEvidence(free, base, noise).total([]), 0.0))
        if without - rms < MIN_GAIN * without:
            return []
    return sorted(chosen)


LABEL = "product terms (a table of a turning table's axis times a ramp of a linear axis)"


def products_wanted(asked: bool | None, limits: ControllerLimits, face: bool, machine: Machine,
                    subset: bool) -> tuple[bool, str, str]:
    """(offer product terms, why they are computed but not written ('' : written), the report's line
    when none are offered ('' : none)). ``asked``: True / False, or None: the default (on where the
    campaign read the table's face, ``face``, and ``limits`` carry them without a caveat);
    ``subset``: the controller's table limit forces a subset of the cross tables. Asked for on a machine
    whose table does not turn: refused (:class:`InputError`), before anything is solved."""
    if not product_candidates(machine):
        if asked:
            raise InputError(f"`products`: {machine.name} has no rotary axis that turns the table, and product terms "
                             "multiply a turning table's table by a linear axis' ramp: leave them out")
        return False, "", ""
    if asked is False:
        return False, "", f"{LABEL}: turned off" if face else ""
    if not limits.products:
        return False, "", (f"{LABEL}: none, {limits.name} does not multiply tables (a tilt fixed to the turning table "
                           "stays)" if asked or face else "")
    if subset:
        return False, "", (f"{LABEL}: left out, the controller's table limit takes a subset of the cross tables and "
                           "they would compete for it" if asked or face else "")
    if asked is None and not face:
        return False, "", (f"{LABEL}: not by default, the campaign did not read the table's face (nests' heights above "
                           "it); ask for them with `products`")
    if asked is None and limits.products_caveat:
        return True, limits.products_caveat + "; ask for them with `products`", ""
    return True, "", ""


def product_note(chosen: list[str], kept: bool, before_mm: float, after_mm: float, why: str = "",
                 held_back: str = "") -> str:
    """The report's line on product terms: which, what they do in the part's frame, and whether they are used
    (``held_back``: why they are computed but not written)."""
    if not chosen:
        return f"{LABEL}: none chosen{why}"
    verdict = ("used" if kept and not held_back else f"not written by default: {held_back}" if kept else
               "not used (they do not lower the error in the part's frame)")
    return (f"product terms {' '.join(chosen)} (a table of the rotary axis times a fixed ramp of the linear axis, "
            f"-1 .. 1 over its measured range: a tilt fixed to the turning table): the full tables leave "
            f"{before_mm:.4f} mm, with them {after_mm:.4f} mm (model-predicted, part's frame); {verdict}")


def with_products(problem: TableProblem, limits: ControllerLimits, full, after: np.ndarray, add, n_points: int,
                  notes: list[str], held_back: str = "", noise: np.ndarray | None = None, release: bool = False):
    """The table set to write: the full set ``full`` (its errors ``after`` (N,3) [m], part's frame)
    with the chosen product terms where they lower the error in the part's frame and are not
    ``held_back`` (why not written: then their row and what they would gain are reported, and
    ``full`` returned); ``add(label, tables, n)`` adds a report row and returns its errors; the
    report's line on them goes into ``notes``; ``noise``: the model's prediction noise
    (:func:`prediction_noise`), which the terms chosen must beat. ``release``: the problem holds the
    volume's turn only for the terms (the table's face); where none are used, the hold goes with them
    and the one-axis tables are re-solved without it (:meth:`TableProblem.release_turn`), as without
    product terms. The problem has product columns (:func:`products_wanted` offered them)."""
    base = [t.name for t in full.tables]
    room = room_for_products(limits, sum(not t.is_pitch for t in full.tables))
    chosen = choose_products(problem, base, room, noise, release)
    if not chosen:
        beyond = "" if noise is None else " beyond twice the model's uncertainty it would take on"
        notes.append(product_note([], False, 0.0, 0.0, f": none lowers the error by {MIN_GAIN:.0%} or more{beyond}"))
        return _without_hold(problem, base, add, n_points) if release else full
    tables = problem.solve(base + chosen).discretise(n_points)
    err = add(f"full tables + product terms {' '.join(chosen)} (model-predicted{', not written' if held_back else ''})",
              tables, len(tables.tables) + TABLES_PER_TERM * len(chosen))
    before_mm, after_mm = (float(norm_mm(e).mean()) for e in (after, err))
    kept = after_mm < before_mm
    notes.append(product_note(chosen, kept, before_mm, after_mm, held_back=held_back))
    if kept and not held_back:
        return tables
    return _without_hold(problem, base, add, n_points) if release else full


def _without_hold(problem: TableProblem, base: list[str], add, n_points: int):
    """The one-axis tables ``base`` re-solved with the volume's turn left to least squares (the hold was
    for the product terms, none used), with their report row."""
    problem.release_turn()
    full = problem.solve(base).discretise(n_points)
    add("full tables, their tilt against the face left to least squares (model-predicted)", full, len(full.tables))
    return full
