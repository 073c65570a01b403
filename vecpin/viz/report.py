"""One HTML page about fitted models on a campaign: tables, the seed's figures for every
model at once, and a link to the meshcat scene.

Figures (Paper I numbering): Fig. 9, histograms of the identification errors of the
nominal kinematics and of each model; Fig. 10, the compensation functions of every
model overlaid; Fig. 11, the compensated errors each table set leaves at the measured
points (the measured residual plus the model-predicted compensated error, best-fit
rigid motion removed); the order sweep (Fig. 7-8), errors on a grid (Section 2 Fig. 2.4,
with the axes it holds fixed and an arrow-scale key), repeatability (eq. 22).
"""
from __future__ import annotations

import html
from pathlib import Path
from typing import Callable

import numpy as np

from vecpin.compensation.functions import compensated_errors, model_as_actual
from vecpin.fileio import OutputSet, check_output_dir
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.registration import registered_errors
from vecpin.measurement.stats import distance_stats
from vecpin.models import MODELS, ErrorModel
from vecpin.units import MM_PER_M, norm_mm
from vecpin.viz import figures

CSS = """body{font-family:sans-serif;max-width:1100px;margin:20px auto;color:#222}
table{border-collapse:collapse;margin:8px 0 16px}td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}
th{background:#eef}td:first-child,th:first-child{text-align:left}img{max-width:100%;border:1px solid #ddd;margin:6px 0}
.note{color:#555;font-size:90%}"""


def _table(header: list[str], rows: list[list]) -> str:
    h = "".join(f"<th>{html.escape(str(x))}</th>" for x in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(x if isinstance(x, str) else f'{x:.4f}')}</td>" for x in r)
                   + "</tr>" for r in rows)
    return f"<table><tr>{h}</tr>{body}</table>"


def _stats_rows(label: str, d: np.ndarray, tool: np.ndarray) -> list[list]:
    return [[label, k, s["mean"], s["max"], s["rms"]] for k, s in distance_stats(d, tool).items()]


def model_label(model: ErrorModel) -> str:
    return f"{model.display_name} order {model.order}"


def _labels(models: list[ErrorModel]) -> list[str]:
    labels = [model_label(m) for m in models]
    return [lab if labels.count(lab) == 1 else f"{lab} #{k + 1}" for k, lab in enumerate(labels)]


def predicted_compensated(model: ErrorModel, tables, campaign: Campaign) -> np.ndarray:
    """Distances [mm] the tables would leave at the campaign's points: the measured
    residual (what the model does not describe, assumed unchanged by the small command
    changes) plus the model's compensated error, best-fit rigid motion removed."""
    from vecpin.viz.scene import to_machine_frame
    c = campaign.primary()
    feats = None
    if model.effects:
        from vecpin.measurement.features import Features
        feats = Features.from_campaign(c)
    m = model.machine
    measured = to_machine_frame(model, c.xyz)
    residual = measured - model.predict(c.q, c.tool, "machine", features=feats)
    comp = model.predict(tables.apply(c.q), c.tool, "machine", features=feats) - \
        m.tool_tip(c.q, c.tool + tables.gauge_offset_change, frame="base")
    nominal = m.tool_tip(c.q, c.tool + tables.gauge_offset_change, frame="base")
    return norm_mm(registered_errors(nominal, nominal + residual + comp))


def write_report(models: ErrorModel | list[ErrorModel], campaign: Campaign, out_dir, validation: Campaign | None = None,
                 orders: list[int] | None = None, controller: str = "generic", max_tables: int | None = None,
                 progress: Callable[[str], None] | None = None) -> Path:
    """Write ``index.html``, ``figures/*.png`` and ``scene.html`` into ``out_dir`` for one
    or several fitted models of the same machine; returns the page's path."""
    models = [models] if isinstance(models, ErrorModel) else list(models)
    say = progress or (lambda s: None)
    check_output_dir(out_dir)
    m = models[0].machine
    from vecpin.measurement.registration import check_same_pose, station0
    from vecpin.models.modelfile import check_same_machine
    for k, mod in enumerate(models[1:], 2):
        check_same_machine(m, mod.machine, "model 1", f"model {k}")
    if orders:
        from vecpin.selection.orders import check_orders
        check_orders(m, campaign, ("6dof", "ap"), orders, folds=None if validation is not None else 5,
                     noise=models[0].noise_)
    for c in (campaign, validation) if validation is not None else (campaign,):
        c0 = station0(c)  # measured with the tracker pose the models were fitted with
        for k, mod in enumerate(models, 1):
            check_same_pose(m.tool_tip(c0.q, c0.tool, frame="base"), mod.predict_nominal(c0.q, c0.tool), c0.xyz, c.source,
                            f"model {k}", c0.lines)
    labels = _labels(models)
    out_set = OutputSet(out_dir)
    with out_set as out:
        fig = lambda name: out.path(f"figures/{name}")  # noqa: E731
        parts = [f"<h1>vecpin report: {html.escape(m.name)}</h1>"]
        for lab, mod in zip(labels, models):
            rep = mod.report_
            parts.append(f"<p><b>{html.escape(lab)}</b> ({html.escape(mod.basis_kind)} basis): {rep.n_rows} rows, "
                         f"{rep.instrument} instrument noise; chi2 = {rep.chi2:.1f}, expected {rep.chi2_expected:.1f} ± "
                         f"{rep.chi2_sigma:.1f} ({'in' if rep.chi2_in_band else 'outside'} its 3σ band); "
                         f"{len(rep.removed)} redundant terms removed; condition number {rep.condition_number:.3g}.</p>")
        parts.append('<p><a href="scene.html">3D scene of measured vs modelled tool tips (meshcat)</a></p>')

        say("residual tables")
        rows, hist, vhist = [], {}, {}
        sets = [("identification", campaign.primary())] + \
            ([("validation", validation.primary())] if validation is not None else [])
        for name, c in sets:
            before = norm_mm(c.xyz - models[0].predict_nominal(c.q, c.tool))
            rows += _stats_rows(f"{name}: uncompensated", before, c.tool)
            target = hist if name == "identification" else vhist
            target["nominal"] = before
            for lab, mod in zip(labels, models):
                after = norm_mm(mod.residuals(c))
                rows += _stats_rows(f"{name}: model {lab}", after, c.tool)
                target[lab] = after
        parts += ["<h2>Volumetric errors before and after (mm)</h2>",
                  _table(["set", "tools", "mean", "max", "RMS"], rows)]
        figures.residual_histograms(hist, fig("histogram.png"),
                                    title="Identification measurements: nominal and model residuals (Paper I Fig. 9)")
        parts.append('<img src="figures/histogram.png" alt="residual histogram (Fig. 9)">')
        if vhist:
            figures.residual_histograms(vhist, fig("histogram_validation.png"), title="Validation measurements")
            parts.append('<img src="figures/histogram_validation.png" alt="validation histogram">')

        if orders:
            from vecpin.selection.orders import order_sweep
            sweeps = []
            for k in ("6dof", "ap"):
                say(f"order sweep {MODELS[k].display_name} {orders} ({'validation file' if validation is not None else 'k-fold CV'})")
                sweeps.append(order_sweep(m, campaign, k, orders, validation=validation, noise=models[0].noise_,
                                          progress=say))
            parts.append("<h2>Order selection (Paper I Table 2)</h2>")
            for s in sweeps:
                parts.append("<pre>" + html.escape(s.table()) + "</pre>")
            figures.order_sweep_figure(sweeps, fig("orders.png"))
            parts.append('<img src="figures/orders.png" alt="order sweep">')

        from vecpin.compensation.plan import plan_tables
        from vecpin.export.registry import get_format
        plans = []
        for lab, mod in zip(labels, models):
            say(f"compensation tables of {lab}")
            plans.append(plan_tables(mod, get_format(controller).limits, max_tables=max_tables))
        parts.append("<h2>Compensation tables</h2>")
        for lab, plan in zip(labels, plans):
            parts += [f"<p><b>{html.escape(lab)}</b>: controller {html.escape(controller)}; tables "
                      f"{html.escape(' '.join(plan.tables.names()))}; gauge-line change "
                      f"{plan.tables.gauge_offset_change * MM_PER_M:+.4f} mm.</p>",
                      _table(["compensation (model-predicted)", "tables", "mean mm", "max mm"],
                             [[r[0], str(r[3] or ""), r[1], r[2]] for r in plan.report.rows])]
        solutions = {f"{lab} tables": plan.tables for lab, plan in zip(labels, plans)}
        for lab, plan in zip(labels, plans):
            if plan.selection is not None:
                from vecpin.compensation.functions import all_table_names
                solutions[f"{lab} full set"] = plan.problem.solve(all_table_names(m)).discretise(512)
        figures.compensation_grid(m, solutions, fig("tables.png"))
        parts.append('<p class="note">Compensation functions of every model overlaid (Paper I Fig. 10): input axis '
                     'across, output axis down.</p><img src="figures/tables.png" alt="compensation functions (Fig. 10)">')

        say("compensated errors at the measured points")
        judged = validation.primary() if validation is not None else campaign.primary()
        where = "validation" if validation is not None else "identification"
        comp = {"uncompensated": norm_mm(registered_errors(m.tool_tip(judged.q, judged.tool, frame="base"), judged.xyz))}
        for lab, mod, plan in zip(labels, models, plans):
            comp[f"{lab} tables"] = predicted_compensated(mod, plan.tables, judged)
        figures.residual_histograms(comp, fig("histogram_compensated.png"),
                                    title=f"Compensated errors predicted at the {where} points (Paper I Fig. 11 form)")
        parts += ["<h2>Compensated errors (Paper I Fig. 11 form)</h2>",
                  f'<p class="note">At the {where} points: the measured residual plus the model-predicted error the '
                  "tables leave, best-fit rigid motion removed. Measure a compensated run and use <code>vecpin verify"
                  "</code> for the real figures.</p>",
                  '<img src="figures/histogram_compensated.png" alt="compensated histogram (Fig. 11)">']
        if plans[0].selection is not None:
            from vecpin.compensation.selection import genetic_search
            say("genetic algorithm convergence (15 runs)")
            cons = plans[0].limits.constraints(max_tables, axis_names=m.axis_names)
            ga = {f"mutation {r:.0%}": [genetic_search(plans[0].problem, cons, mutation=r, seed=s).history
                                        for s in range(5)] for r in (0.0, 0.2, 0.85)}
            figures.ga_convergence_figure(ga, fig("ga.png"))
            parts += ["<h3>Genetic algorithm convergence (Paper II Fig. 4)</h3>", '<img src="figures/ga.png" alt="GA">']

        say("error vector plots")
        lin = [a.name for a in m.axes if a.kind == "linear"]
        if len(lin) >= 2:
            mod, plan = models[0], plans[0]
            actual = model_as_actual(mod)
            figures.error_vector_plot(m, lambda q, t: compensated_errors(actual, m, None, q, t), fig("vectors.png"),
                                      (lin[0], lin[1]), title=f"{labels[0]}: model-predicted errors, uncompensated")
            figures.error_vector_plot(m, lambda q, t: compensated_errors(actual, m, plan.tables, q, t),
                                      fig("vectors_comp.png"), (lin[0], lin[1]),
                                      title=f"{labels[0]}: model-predicted errors with its tables (Section 2 Fig. 2.4)")
            parts += ["<h2>Errors on a grid</h2>", '<img src="figures/vectors.png" alt="errors">',
                      '<img src="figures/vectors_comp.png" alt="errors compensated">']
        if figures.repeatability_figure(campaign.primary(), fig("repeatability.png")):
            parts += ["<h2>Repeatability (eq. 22)</h2>", '<img src="figures/repeatability.png" alt="repeatability">']

        say("3D scene")
        from vecpin.viz.scene import write_html
        facts = write_html(out.path("scene.html"), models[0], campaign.primary(), 0, None, plans[0].tables)
        parts += [f'<p class="note">3D scene: {html.escape(n)}</p>' for n in facts.get("notes", [])]
        page = out.write_text("index.html", f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>vecpin report "
                              f"{html.escape(m.name)}</title><style>{CSS}</style></head><body>" + "\n".join(parts)
                              + "</body></html>")
    return page
