"""The table floor: the best tables that exist for a simulated true machine.

Tables are separable (each a function of one axis) while a machine's errors mix axes
through its kinematics, so even perfect knowledge of the machine leaves a residual.
:func:`table_floor` fits the tables straight to the true machine (simulation only: a
real machine is never known this well), with the same table functions, limits and
pseudo-measurements vecpin uses for a model; the ratio of vecpin's true compensated
error to this floor says how much the identification costs."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.compensation.functions import (all_table_names, pitch_names, pseudo_commands, rich_table_bases,
                                           truth_as_actual)
from vecpin.compensation.tableproblem import TableProblem
from vecpin.compensation.frame import in_reference_frame, reference_frame
from vecpin.compensation.report import compensated_errors
from vecpin.compensation.plan import table_commands
from vecpin.compensation.limits import NO_LIMITS, ControllerLimits
from vecpin.compensation.selection import exact_search
from vecpin.compensation.tables import TableSet
from vecpin.measurement.campaign import PAPER_I_TOOLS_MM
from vecpin.units import M_PER_MM, norm_mm

PAPER_I_TOOLS = tuple(t * M_PER_MM for t in PAPER_I_TOOLS_MM)  # m


@dataclass
class Floor:
    """The floor tables and their true compensated error [mm] on the judged points."""

    tables: TableSet
    mean_mm: float
    max_mm: float


def true_compensated_error(truth, tables: TableSet | None, q: np.ndarray, tool: np.ndarray,
                           judged: str = "part") -> tuple[float, float]:
    """(mean, max) [mm] of the true machine commanded through ``tables`` (None:
    uncompensated) against the nominal kinematics, the tool tip relative to the workpiece
    (of every tool point), in the part's frame (the truth's table is where the part is:
    its origin and the rotation about the spindle removed, nothing else), ``judged``
    "reference" (the same on a table aligned to the truth's own reference lines, as tracker
    data alone can know it: :func:`~vecpin.compensation.functions.reference_frame`), or
    "shape" (the best rigid motion removed)."""
    m = truth.machine
    P = len(m.tool_links)
    qq, tt = np.tile(q, (P, 1)), np.tile(tool, P)
    point = 0 if P == 1 else np.repeat(np.arange(P), len(q))
    if judged == "reference":   # the part's frame on the table aligned to the truth's reference lines
        actual, judged = truth_on_its_reference_lines(truth), "part"
    else:
        actual = truth_as_actual(truth)
    d = norm_mm(compensated_errors(actual, m, tables, qq, tt, judged, point=point))
    return float(d.mean()), float(d.max())


def truth_on_its_reference_lines(truth, tools=PAPER_I_TOOLS):
    """The true machine (an :class:`~vecpin.compensation.functions.ActualMachine`) with its table aligned
    to its own reference lines over ``tools`` [m], as tracker data alone can know it
    (:func:`~vecpin.compensation.frame.reference_frame`)."""
    actual = truth_as_actual(truth)
    return in_reference_frame(actual, reference_frame(actual, truth.machine, tools))


def table_floor(truth, q: np.ndarray, tool: np.ndarray, limits: ControllerLimits = NO_LIMITS,
                n_commands: int | None = None, tools=PAPER_I_TOOLS, n_points: int = 1024, seed: int = 0,
                judged: str = "part", keep: str = "reference") -> Floor:
    """The best tables for ``truth`` under ``limits``, judged on commands ``q`` [m, rad]
    with tool lengths ``tool`` [m]; fitted on ``n_commands`` pseudo-commands (default as
    many as vecpin's tables take: :func:`~vecpin.compensation.plan.table_commands`).
    ``keep``: "reference", the best tables that keep the machine's own reference frame (all
    that tracker data can know of where the table is: the truth's table may lie turned
    against it); "table", the best tables in the true table's frame (what a campaign that
    reads the table's face can aim at)."""
    m = truth.machine
    pseudo = pseudo_commands(m, n_commands or table_commands(m, len(tools)), seed)
    if keep == "table":
        from vecpin.compensation.frame import ReferenceFrame
        frame = ReferenceFrame(np.eye(3), np.zeros(3), "the true table")
    else:
        frame = reference_frame(truth_as_actual(truth), m, tools)
    actual = in_reference_frame(truth_as_actual(truth), frame)
    problem = TableProblem(actual, m, pseudo, tools, bases=rich_table_bases(m), hold_turn=frame.hold_turn)
    names = all_table_names(m)
    if not limits.cross_tables:
        names = pitch_names(m)
    elif limits.needs_selection(m.axis_names):
        search = TableProblem(actual, m, pseudo, tools, order=8, basis="fourier", hold_turn=frame.hold_turn)
        chosen = exact_search(search, limits.constraints(None, axis_names=m.axis_names), n_points=n_points)
        names = pitch_names(m) + chosen.tables
    tables = problem.solve(names).discretise(n_points)
    return Floor(tables, *true_compensated_error(truth, tables, q, tool, judged))
