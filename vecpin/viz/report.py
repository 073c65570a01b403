"""One HTML page about a fitted model on a campaign: tables, the seed's figures, and
a link to the meshcat scene."""
from __future__ import annotations

import html
from pathlib import Path
from typing import Callable

import numpy as np

from vecpin.viz import figures
from vecpin.measurement.campaign import Campaign
from vecpin.compensation.functions import compensated_errors, model_as_actual
from vecpin.measurement.stats import distance_stats
from vecpin.models import ErrorModel

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


def write_report(model: ErrorModel, campaign: Campaign, out_dir, validation: Campaign | None = None,
                 orders: list[int] | None = None, controller: str = "generic", max_tables: int | None = None,
                 progress: Callable[[str], None] | None = None) -> Path:
    say = progress or (lambda s: None)
    out = Path(out_dir)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    m = model.machine
    rep = model.report_
    parts = [f"<h1>vecpin report: {html.escape(m.name)}</h1>",
             f"<p>{html.escape(model.kind)} model, order {model.order} ({html.escape(model.basis_kind)} basis), "
             f"{rep.n_rows} rows, {rep.instrument} instrument noise. "
             f"chi2 = {rep.chi2:.1f}, expected {rep.chi2_expected:.1f} ± {rep.chi2_sigma:.1f} "
             f"({'in' if rep.chi2_in_band else 'outside'} its 3σ band); {len(rep.removed)} redundant terms removed; "
             f"condition number {rep.condition_number:.3g}.</p>",
             '<p><a href="scene.html">3D scene of measured vs modelled tool tips (meshcat)</a></p>']

    say("residual tables")
    rows, hist = [], {}
    for label, c in [("identification", campaign.primary())] + \
            ([("validation", validation.primary())] if validation is not None else []):
        before = np.linalg.norm(c.xyz - model.predict_nominal(c.q, c.tool), axis=1) * 1e3
        after = np.linalg.norm(model.residuals(c), axis=1) * 1e3
        rows += _stats_rows(f"{label}: uncompensated", before, c.tool) + _stats_rows(f"{label}: model", after, c.tool)
        if label == "identification":
            hist = {"nominal": before, f"{model.kind} model": after}
    parts += ["<h2>Volumetric errors before and after (mm)</h2>",
              _table(["set", "tools", "mean", "max", "RMS"], rows)]
    figures.residual_histograms(hist, out / "figures" / "histogram.png")
    parts.append('<img src="figures/histogram.png" alt="residual histogram">')

    if orders:
        say(f"order sweep {orders}")
        from vecpin.selection.orders import order_sweep
        sweeps = [order_sweep(m, campaign, k, orders, validation=validation, noise=model.noise_) for k in ("6dof", "ap")]
        parts.append("<h2>Order selection (Paper I Table 2)</h2>")
        for s in sweeps:
            parts.append("<pre>" + html.escape(s.table()) + "</pre>")
        figures.order_sweep_figure(sweeps, out / "figures" / "orders.png")
        parts.append('<img src="figures/orders.png" alt="order sweep">')

    say("compensation tables")
    from vecpin.compensation.plan import plan_tables
    from vecpin.export.registry import get_format
    plan = plan_tables(model, get_format(controller).limits, max_tables=max_tables)
    parts += ["<h2>Compensation tables</h2>",
              f"<p>Controller {html.escape(controller)}; tables {html.escape(' '.join(plan.tables.names()))}; "
              f"gauge-line change {plan.tables.gauge_offset_change * 1e3:+.4f} mm.</p>",
              _table(["compensation", "tables", "mean mm", "max mm"], [[r[0], str(r[3] or ""), r[1], r[2]]
                                                                          for r in plan.report.rows])]
    from vecpin.compensation.functions import all_table_names
    solutions = {"full tables": plan.problem.solve(all_table_names(m)).discretise(512)}
    if plan.selection is not None:
        solutions[f"chosen ({plan.selection.method})"] = plan.tables
    figures.compensation_grid(m, solutions, out / "figures" / "tables.png")
    parts.append('<img src="figures/tables.png" alt="compensation functions">')
    if plan.selection is not None:
        from vecpin.compensation.selection import genetic_search
        cons = plan.limits.constraints(max_tables, axis_names=m.axis_names)
        hist = {f"mutation {r:.0%}": [genetic_search(plan.problem, cons, mutation=r, seed=s).history for s in range(5)]
                for r in (0.0, 0.2, 0.85)}
        figures.ga_convergence_figure(hist, out / "figures" / "ga.png")
        parts += ["<h3>Genetic algorithm convergence (Paper II Fig. 4)</h3>", '<img src="figures/ga.png" alt="GA">']

    say("error vector plots")
    actual = model_as_actual(model)
    lin = [a.name for a in m.axes if a.kind == "linear"]
    if len(lin) >= 2:
        figures.error_vector_plot(m, lambda q, t: compensated_errors(actual, m, None, q, t), out / "figures" / "vectors.png",
                                  (lin[0], lin[1]), title="model-predicted errors, uncompensated")
        figures.error_vector_plot(m, lambda q, t: compensated_errors(actual, m, plan.tables, q, t),
                                  out / "figures" / "vectors_comp.png", (lin[0], lin[1]),
                                  title="model-predicted errors with the tables (Section 2 Fig. 2.4)")
        parts += ["<h2>Errors on a grid</h2>", '<img src="figures/vectors.png" alt="errors">',
                  '<img src="figures/vectors_comp.png" alt="errors compensated">']
    if figures.repeatability_figure(campaign.primary(), out / "figures" / "repeatability.png"):
        parts += ["<h2>Repeatability (eq. 22)</h2>", '<img src="figures/repeatability.png" alt="repeatability">']

    say("3D scene")
    from vecpin.viz.scene import write_html
    write_html(out / "scene.html", model, campaign.primary(), 0, None, plan.tables)
    page = out / "index.html"
    page.write_text(f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>vecpin report {html.escape(m.name)}</title>"
                    f"<style>{CSS}</style></head><body>" + "\n".join(parts) + "</body></html>")
    return page
