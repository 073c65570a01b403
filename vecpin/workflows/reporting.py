"""One HTML page about fitted models on a campaign (the ``report`` command).

Problem -> solve -> result: the inputs are checked (one machine, the models' tracker
pose, the orders the campaign determines), then every figure's numbers are computed here
(residual tables, order sweeps, table plans, the compensated errors the tables would
leave, the genetic algorithm's convergence) into a :class:`vecpin.viz.report.ReportData`,
which :func:`vecpin.viz.report.write_report` only draws.
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np

from vecpin.compensation.functions import all_table_names
from vecpin.compensation.frame import model_as_actual
from vecpin.compensation.report import compensated_errors
from vecpin.compensation.plan import TablePlan
from vecpin.fileio import check_output_dir
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.registration import check_same_pose, station0
from vecpin.models import MODELS, ErrorModel
from vecpin.models.modelfile import check_same_machine
from vecpin.selection.orders import check_orders, order_sweep
from vecpin.units import norm_mm
from vecpin.viz.report import ReportData, labels as model_labels, stats_rows, write_report
from vecpin.measurement.uncompensated import uncompensated
from vecpin.workflows.tables import make_tables

GA_RATES, GA_SEEDS = (0.0, 0.2, 0.85), 5   # the convergence figure: mutation rates x seeds (Paper II Fig. 4)


def report(models: ErrorModel | list[ErrorModel], campaign: Campaign, out_dir, validation: Campaign | None = None,
           orders: list[int] | None = None, controller: str = "generic", max_tables: int | None = None,
           progress: Callable[[str], None] | None = None, profile=None) -> Path:
    """Write ``index.html``, ``figures/*.png`` and ``scene.html`` into ``out_dir`` for one
    or several fitted models of the same machine; returns the page's path. ``orders``:
    also sweep these series orders of both seed kinds (judged on ``validation``, or by
    5-fold CV); ``controller``, ``profile``, ``max_tables``: the tables, made as ``vecpin
    tables`` makes them (:func:`~vecpin.workflows.tables.make_tables`), their files written
    into ``out_dir``/tables_K/ (K: the model's place) and read back, so the page shows the
    same rows, the files as written included."""
    models = [models] if isinstance(models, ErrorModel) else list(models)
    say = progress or (lambda s: None)
    check_output_dir(out_dir)
    _check(models, campaign, validation, orders)
    labels = model_labels(models)
    say("residual tables")
    rows, hist, vhist = _residuals(models, labels, campaign, validation)
    sweeps = _sweeps(models[0], campaign, validation, orders, say) if orders else []
    plans = []
    for k, (lab, mod) in enumerate(zip(labels, models), 1):
        say(f"compensation tables of {lab}")
        plans.append(make_tables(mod, Path(out_dir) / f"tables_{k}", controller, profile=profile,
                                 max_tables=max_tables).plan)
    say("compensated errors at the measured points")
    judged = validation if validation is not None else campaign
    data = ReportData(models, labels, campaign.primary(), rows, hist, vhist, plans, controller,
                      _solutions(models[0].machine, labels, plans), _compensated(models, labels, plans, judged),
                      "validation" if validation is not None else "identification", sweeps,
                      _ga(plans[0], models[0].machine.axis_names, max_tables, say), _vectors(models[0], plans[0]))
    say("figures and 3D scene")
    return write_report(data, out_dir)


def _check(models: list[ErrorModel], campaign: Campaign, validation: Campaign | None, orders) -> None:
    """One machine; campaigns measured with the tracker pose the models were fitted with;
    orders the campaign determines — all before any work."""
    m = models[0].machine
    for k, mod in enumerate(models[1:], 2):
        check_same_machine(m, mod.machine, "model 1", f"model {k}")
    if orders:
        check_orders(m, campaign, ("6dof", "ap"), orders, folds=None if validation is not None else 5,
                     noise=models[0].noise_, option="`orders`")
    for c in (campaign, validation) if validation is not None else (campaign,):
        c0 = station0(c)
        for k, mod in enumerate(models, 1):
            check_same_pose(m.tool_tip(c0.q, c0.tool, frame="base"), mod.predict_nominal(c0.q, c0.tool), c0.xyz,
                            c.source, f"model {k}", c0.lines)


def _residuals(models, labels, campaign, validation):
    """The before/after table rows and the histograms' distances [mm]: the uncompensated
    figure every command prints (:func:`vecpin.measurement.uncompensated.uncompensated`) and each
    model's residuals."""
    rows, hist, vhist = [], {}, {}
    sets = [("identification", campaign, hist)] + ([("validation", validation, vhist)] if validation is not None else [])
    for name, c, target in sets:
        if name == "validation" and models[0].machine.has_workpiece and len(c.nest_rows):
            rows += _relative_to_table(models, labels, c, target)
            continue
        u = uncompensated(models[0].machine, c, strict=False)
        if u is not None:
            rows += stats_rows(f"{name}: uncompensated", u.distances_mm, u.tool)
            target["nominal"] = u.distances_mm
        c0 = c.primary()
        for lab, mod in zip(labels, models):
            after = norm_mm(mod.residuals(c0))
            rows += stats_rows(f"{name}: model {lab}", after, c0.tool)
            target[lab] = after
    return rows, hist, vhist


def _relative_to_table(models, labels, validation: Campaign, target: dict) -> list[list]:
    """A validation run of a table machine with nest rows, judged as ``evaluate`` and
    ``verify`` judge it: the tool tip relative to the table, each command's table pose
    from its nests (:func:`vecpin.workflows.evaluation.evaluate`); the table rows [mm],
    the distances into ``target``."""
    from vecpin.workflows.evaluation import evaluate
    rows = []
    for k, (lab, mod) in enumerate(zip(labels, models)):
        ev = evaluate(mod, validation)
        if k == 0:
            rows += stats_rows("validation, tip relative to the table: uncompensated", ev.uncompensated, ev.tool)
            rows += stats_rows("validation, tip relative to the table: uncompensated, shape (best rigid motion "
                               "removed)", ev.shape, ev.tool)
            target["nominal"] = ev.uncompensated
        rows += stats_rows(f"validation, tip relative to the table: model {lab}", ev.residual, ev.tool)
        target[lab] = ev.residual
    return rows


def _sweeps(model: ErrorModel, campaign, validation, orders, say):
    out = []
    for k in ("6dof", "ap"):
        say(f"order sweep {MODELS[k].display_name} {orders} ({'validation file' if validation is not None else 'k-fold CV'})")
        out.append(order_sweep(model.machine, campaign, k, orders, validation=validation, noise=model.noise_,
                               progress=say))
    return out


def _solutions(machine, labels, plans: list[TablePlan]) -> dict:
    """The table sets of Fig. 10: each model's, and its full set where a selection dropped tables."""
    out = {f"{lab} tables": plan.tables for lab, plan in zip(labels, plans)}
    for lab, plan in zip(labels, plans):
        if plan.selection is not None:
            out[f"{lab} full set"] = plan.problem.solve(all_table_names(machine)).discretise(512)
    return out


def _compensated(models, labels, plans, judged: Campaign) -> dict[str, np.ndarray]:
    """Distances [mm] at the judged campaign's points: uncompensated, and what each model's tables would leave."""
    u = uncompensated(models[0].machine, judged, strict=False)
    out = {} if u is None else {"uncompensated": u.distances_mm}
    for lab, mod, plan in zip(labels, models, plans):
        out[f"{lab} tables"] = predicted_compensated(mod, plan.tables, judged, plan.reference)
    return out


def predicted_compensated(model: ErrorModel, tables, campaign: Campaign, frame=None) -> np.ndarray:
    """Distances [mm] the tables would leave at the campaign's points: the measured
    residual (what the model does not describe, assumed unchanged by the small command
    changes) plus the model's compensated error in its reference frame (``frame``, default
    found from the model), judged in the part's frame (a translation and a rotation about
    the spindle removed)."""
    from vecpin.compensation.frame import model_reference_frame
    from vecpin.measurement.partframe import part_frame_errors, spindle_axis
    from vecpin.viz.scene import to_machine_frame
    c = campaign.primary()
    feats = None
    if model.effects:
        from vecpin.measurement.features import Features
        feats = Features.from_campaign(c)
    m = model.machine
    residual = to_machine_frame(model, c.xyz) - model.predict_tip(c.q, c.tool, "machine", features=feats)
    nominal = m.tool_tip(c.q, c.tool + tables.gauge_offset_change, frame="base")
    comp = (frame or model_reference_frame(model)).apply(model.predict_tip(tables.apply(c.q), c.tool, "machine", features=feats))
    return norm_mm(part_frame_errors(nominal, residual + comp, spindle_axis(m)))


def _ga(plan: TablePlan, axis_names: list[str], max_tables: int | None, say) -> dict[str, list] | None:
    """Convergence histories of the genetic table selection per mutation rate (None: no selection)."""
    if plan.selection is None:
        return None
    from vecpin.compensation.selection import genetic_search
    say(f"genetic algorithm convergence ({len(GA_RATES) * GA_SEEDS} runs)")
    cons = plan.limits.constraints(max_tables, axis_names=axis_names)
    return {f"mutation {r:.0%}": [genetic_search(plan.problem, cons, mutation=r, seed=s).history
                                  for s in range(GA_SEEDS)] for r in GA_RATES}


def _vectors(model: ErrorModel, plan: TablePlan):
    """The grid plots' axes (the first two linear axes) and the model-predicted errors
    f(q, tool) [m] without and with the tables; None on a machine with fewer linear axes."""
    m = model.machine
    lin = [a.name for a in m.axes if a.kind == "linear"]
    if len(lin) < 2:
        return None
    actual = model_as_actual(model, frame=plan.reference)
    return ((lin[0], lin[1]), lambda q, t: compensated_errors(actual, m, None, q, t),
            lambda q, t: compensated_errors(actual, m, plan.tables, q, t))
