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
forward selection on the problem's linearised error: a term stays when it lowers it by at
least :data:`MIN_GAIN` of what is left, within the controller's table count (two tables per
term). The set with them is kept only when its error in the part's frame is lower.

By default (:func:`products_wanted`) they are on where the campaign reads the table's face
(the fit was given the nests' heights above it: the tables keep the table, and a tilt fixed
to it is what is left) and the controller carries them exactly as planned (vecpin's generic
files, vecpin's LinuxCNC component); written, they come with the tables' turn of the volume against
the face held at zero (:func:`~vecpin.compensation.plan._table_problem`). Where the controller's meaning of a product is
inferred (``ControllerLimits.products_caveat``: SINUMERIK) they are computed and their gain
printed, but written only when asked for.
"""
from __future__ import annotations

import numpy as np

from vecpin.compensation.limits import ControllerLimits
from vecpin.compensation.tableproblem import TableProblem
from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.units import norm_mm

MIN_GAIN = 0.01       # a product term is kept when it lowers the linearised error by this share of what is left
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


def choose_products(problem: TableProblem, base: list[str], room: int | None) -> list[str]:
    """Product terms of ``problem`` added to the tables ``base`` by forward selection on the
    linearised RMS error: each step takes the term that lowers it most, while that is at least
    :data:`MIN_GAIN` of the error left and ``room`` (None: no limit) allows."""
    chosen: list[str] = []
    left = list(problem.products)
    cost = problem.cost(base)
    while left and (room is None or len(chosen) < room):
        costs = np.array([problem.cost(base + chosen + [p]) for p in left])
        best = int(np.argmin(costs))
        if cost - costs[best] < MIN_GAIN * cost:
            break
        chosen.append(left.pop(best))
        cost = float(costs[best])
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
                  notes: list[str], held_back: str = ""):
    """The table set to write: the full set ``full`` (its errors ``after`` (N,3) [m], part's frame)
    with the chosen product terms where they lower the error in the part's frame and are not
    ``held_back`` (why not written: then their row and what they would gain are reported, and
    ``full`` returned); ``add(label, tables, n)`` adds a report row and returns its errors; the
    report's line on them goes into ``notes``. The problem has product columns
    (:func:`products_wanted` offered them)."""
    base = [t.name for t in full.tables]
    room = room_for_products(limits, sum(not t.is_pitch for t in full.tables))
    chosen = choose_products(problem, base, room)
    if not chosen:
        notes.append(product_note([], False, 0.0, 0.0, f": none lowers the error by {MIN_GAIN:.0%} or more"))
        return full
    tables = problem.solve(base + chosen).discretise(n_points)
    err = add(f"full tables + product terms {' '.join(chosen)} (model-predicted{', not written' if held_back else ''})",
              tables, len(tables.tables) + TABLES_PER_TERM * len(chosen))
    before_mm, after_mm = (float(norm_mm(e).mean()) for e in (after, err))
    kept = after_mm < before_mm
    notes.append(product_note(chosen, kept, before_mm, after_mm, held_back=held_back))
    return tables if kept and not held_back else full
