"""From a fitted model to the tables a controller loads (issue workflow in one call).

Full tables when the controller takes them all (AP: eq. 17; 6-DoF: projection, eq.
18-19); otherwise the best admissible subset (Paper II), re-solved on the model. The
report gives the model-predicted volumetric error over quasi-random commands and the
campaign's tool lengths: uncompensated, full tables, pitch only, the chosen set.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.compensation.functions import (CompensationReport, TableProblem, all_table_names, compensated_errors, from_ap_model,
                           model_as_actual, pitch_names, pseudo_commands)
from vecpin.export.controllers import Controller, get_controller
from vecpin.errors import VecpinError
from vecpin.models import APModel, ErrorModel
from vecpin.compensation.tables import TableSet
from vecpin.compensation.selection import Selection, exact_search, genetic_search, impact_heuristic

DEFAULT_TOOLS_MM = (214.88, 312.86)


@dataclass
class TablePlan:
    tables: TableSet
    controller: Controller
    selection: Selection | None
    report: CompensationReport
    problem: TableProblem


def plan_tables(model: ErrorModel, controller: str | Controller = "generic", *, max_tables: int | None = None,
                no_circular: bool | None = None, forbid_output=(), points: int = 1024, method: str = "exact",
                n_commands: int = 1000, tools_mm=None, table_order: int | None = None, seed: int = 0,
                modulo_axes=(), commands: np.ndarray | None = None, progress=None) -> TablePlan:
    """Compensation tables of a fitted model for a controller.

    The pseudo-measurements are ``commands`` [m, rad] (e.g. a campaign's) or
    ``n_commands`` quasi-random ones, each with every tool length (``tools_mm``, default
    the fit's). ``modulo_axes``: rotary input axes whose tables cover one turn and repeat."""
    ctl = get_controller(controller) if isinstance(controller, str) else controller
    m = model.machine
    tools_mm = tools_mm or getattr(model.report_, "tool_lengths_mm", None) or DEFAULT_TOOLS_MM
    if len(tools_mm) < 2:
        tools_mm = list(tools_mm) + [t + 100.0 for t in tools_mm]  # two lengths fix position and orientation
    tools = np.array(tools_mm, float) * 1e-3
    actual = model_as_actual(model)
    for a in modulo_axes:
        if m.axis(a).kind != "rotary":
            raise VecpinError(f"only rotary axes have modulo tables, not {a}")
    q = pseudo_commands(m, n_commands, seed) if commands is None else np.unique(np.asarray(commands, float), axis=0)
    order = table_order if table_order is not None else max(model.order, 2)
    problem = TableProblem(actual, m, q, tools, order=order, basis=model.basis, modulo_axes=tuple(modulo_axes))
    cross = [n for n in all_table_names(m) if n[0] != n[1]]
    need_subset = (max_tables is not None or no_circular or forbid_output
                   or (ctl.max_cross_tables is not None and ctl.max_cross_tables < len(cross)))
    report = CompensationReport()
    err = lambda ts: compensated_errors(actual, m, ts, problem.q, problem.L)  # noqa: E731
    report.add("uncompensated", err(None))
    fit_res = model.report_.residuals_mm["all"]
    report.rows.append(("model (fit residual, measured)", fit_res["mean"], fit_res["max"], 0))
    if progress:
        progress("solving the full table set")
    if isinstance(model, APModel):
        full = from_ap_model(model, modulo_axes).discretise(points)
    else:
        full = problem.solve(all_table_names(m)).discretise(points)
    report.add(f"full tables ({len(full.tables)})", err(full), len(full.tables))
    pitch = problem.solve(pitch_names(m)).discretise(points)
    report.add("pitch only", err(pitch), len(pitch.tables))
    selection = None
    tables = full
    if need_subset:
        cons = ctl.constraints(max_tables, no_circular, tuple(forbid_output))
        if progress:
            progress(f"choosing {cons.max_tables} of the cross tables ({method})")
        if method == "exact":
            selection = exact_search(problem, cons, n_points=points)
        elif method == "ga":
            selection = genetic_search(problem, cons, seed=seed, n_points=points)
        elif method == "heuristic":
            selection = impact_heuristic(problem, cons, n_points=points)
        else:
            raise VecpinError(f"unknown selection method '{method}' (exact, ga, heuristic)")
        tables = problem.solve(pitch_names(m) + selection.tables).discretise(points)
        report.add(f"{method}: {' '.join(selection.tables)}", err(tables), len(tables.tables))
    return TablePlan(tables, ctl, selection, report, problem)
