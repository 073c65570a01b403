"""One HTML page about fitted models on a campaign: tables, the seed's figures for every
model at once, and a link to the meshcat scene. This module draws a :class:`ReportData`
it is handed; :func:`vecpin.workflows.reporting.report` computes it.

Figures (Paper I numbering): Fig. 9, histograms of the identification errors of the
nominal kinematics and of each model; Fig. 10, the compensation functions of every
model overlaid; Fig. 11, the compensated errors each table set leaves at the measured
points (the measured residual plus the model-predicted compensated error, best-fit
rigid motion removed); the order sweep (Fig. 7-8), errors on a grid (Section 2 Fig. 2.4,
with the axes it holds fixed and an arrow-scale key), repeatability (eq. 22).
"""
from __future__ import annotations

import html
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vecpin.compensation.plan import TablePlan
from vecpin.compensation.tables import TableSet
from vecpin.errors import VecpinWarning
from vecpin.fileio import OutputSet
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.stats import distance_stats
from vecpin.models import ErrorModel
from vecpin.selection.orders import OrderSweep
from vecpin.units import MM_PER_M
from vecpin.viz import figures
from vecpin.viz.scales import ColourScale, tip_error_scale

CSS = """body{font-family:sans-serif;max-width:1100px;margin:20px auto;color:#222}
table{border-collapse:collapse;margin:8px 0 16px}td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}
th{background:#eef}td:first-child,th:first-child{text-align:left}img{max-width:100%;border:1px solid #ddd;margin:6px 0}
.note{color:#555;font-size:90%}"""


def _table(header: list[str], rows: list[list]) -> str:
    h = "".join(f"<th>{html.escape(str(x))}</th>" for x in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(x if isinstance(x, str) else f'{x:.4f}')}</td>" for x in r)
                   + "</tr>" for r in rows)
    return f"<table><tr>{h}</tr>{body}</table>"


def stats_rows(label: str, d: np.ndarray, tool: np.ndarray) -> list[list]:
    return [[label, k, s["mean"], s["max"], s["rms"]] for k, s in distance_stats(d, tool).items()]


def model_label(model: ErrorModel) -> str:
    """'6-DoF order 6' when every axis has the series of that order (Chebyshev, or Fourier
    on a rotary axis), else the kind and each axis' basis in the model choice's short form,
    '6-DoF cheb4/cheb4/cheb6/cheb3/fourier4' (axes in the machine's order)."""
    short = [B.short_label() for B in model.bases]
    if all(s in (f"cheb{model.order}", f"fourier{model.order}") for s in short):
        return f"{model.display_name} order {model.order}"
    return f"{model.display_name} {'/'.join(short)}"


def labels(models: list[ErrorModel]) -> list[str]:
    labels = [model_label(m) for m in models]
    return [lab if labels.count(lab) == 1 else f"{lab} #{k + 1}" for k, lab in enumerate(labels)]


@dataclass
class ReportData:
    """Everything the report page shows, computed by :func:`vecpin.workflows.reporting.report`;
    this module only draws it. Distances in mm; ``labels`` one per model."""

    models: list[ErrorModel]
    labels: list[str]
    campaign: Campaign                       # the identification campaign's primary rows (scene, repeatability)
    residual_rows: list[list]                # [set, tools, mean, max, RMS] of the before/after table
    hist: dict[str, np.ndarray]              # identification distances per label (Fig. 9)
    vhist: dict[str, np.ndarray]             # validation distances per label (empty: no validation campaign)
    plans: list[TablePlan]                   # one table plan per model
    controller: str
    solutions: dict[str, TableSet]           # the table sets overlaid in Fig. 10
    compensated: dict[str, np.ndarray]       # distances the tables would leave at the judged points (Fig. 11 form)
    judged: str                              # "identification" or "validation"
    sweeps: list[OrderSweep] = field(default_factory=list)
    ga: dict[str, list] | None = None        # mutation rate label -> convergence histories (Paper II Fig. 4)
    vectors: tuple | None = None             # (axes, uncompensated f(q, t), compensated f(q, t)) [m] on a grid


def write_report(data: ReportData, out_dir) -> Path:
    """Write ``index.html``, ``figures/*.png`` and ``scene.html`` into ``out_dir`` from
    ``data``; returns the page's path (the folder is checked by the workflow, before any work)."""
    with OutputSet(out_dir) as out:
        fig = lambda name: out.path(f"figures/{name}")  # noqa: E731
        scale = tip_scale(data)
        parts = _header(data) + _residual_part(data, fig) + _orders_part(data, fig) + _tables_part(data, fig) \
            + _compensated_part(data, fig) + _vectors_part(data, fig, scale)
        from vecpin.viz.scene import write_html
        facts = write_html(out.path("scene.html"), data.models[0], data.campaign, None, None, data.plans[0].tables,
                           scale=scale)
        parts += [f'<p class="note">One colour scale for the tip error in every figure of this report and its 3D '
                  f'scene: {html.escape(scale.caption())}.</p>']
        parts += [f'<p class="note">3D scene: {html.escape(n)}</p>' for n in facts.get("notes", [])]
        for n in facts.get("notes", []):   # meshes left out are said on the console too, not only in the page
            warnings.warn(VecpinWarning(f"the report's 3D scene: {n}"), stacklevel=2)
        name = html.escape(data.models[0].machine.name)
        page = out.write_text("index.html", f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>vecpin report "
                              f"{name}</title><style>{CSS}</style></head><body>" + "\n".join(parts)
                              + "</body></html>")
    return page


def _header(data: ReportData) -> list[str]:
    parts = [f"<h1>vecpin report: {html.escape(data.models[0].machine.name)}</h1>"]
    for lab, mod in zip(data.labels, data.models):
        rep = mod.report_
        parts.append(f"<p><b>{html.escape(lab)}</b> ({html.escape(mod.label())}): {rep.n_rows} rows, "
                     f"{rep.instrument} instrument noise; chi2 = {rep.chi2:.1f}, expected {rep.chi2_expected:.1f} ± "
                     f"{rep.chi2_sigma:.1f} ({'in' if rep.chi2_in_band else 'outside'} its 3σ band); "
                     f"{len(rep.removed)} redundant terms removed; condition number {rep.condition_number:.3g}.</p>")
    return parts + ['<p><a href="scene.html">3D scene of measured vs modelled tool tips (meshcat)</a></p>']


def _residual_part(data: ReportData, fig) -> list[str]:
    parts = ["<h2>Volumetric errors before and after (mm)</h2>",
             _table(["set", "tools", "mean", "max", "RMS"], data.residual_rows)]
    figures.residual_histograms(data.hist, fig("histogram.png"),
                                title="Identification measurements: nominal and model residuals (Paper I Fig. 9)")
    parts.append('<img src="figures/histogram.png" alt="residual histogram (Fig. 9)">')
    if data.vhist:
        figures.residual_histograms(data.vhist, fig("histogram_validation.png"), title="Validation measurements")
        parts.append('<img src="figures/histogram_validation.png" alt="validation histogram">')
    return parts


def _orders_part(data: ReportData, fig) -> list[str]:
    if not data.sweeps:
        return []
    parts = ["<h2>Order selection (Paper I Table 2)</h2>"] + ["<pre>" + html.escape(s.table()) + "</pre>"
                                                             for s in data.sweeps]
    figures.order_sweep_figure(data.sweeps, fig("orders.png"))
    return parts + ['<img src="figures/orders.png" alt="order sweep">']


def _tables_part(data: ReportData, fig) -> list[str]:
    parts = ["<h2>Compensation tables</h2>"]
    for lab, plan in zip(data.labels, data.plans):
        parts += [f"<p><b>{html.escape(lab)}</b>: controller {html.escape(data.controller)}; tables "
                  f"{html.escape(' '.join(plan.tables.names()))}; gauge-line change "
                  f"{plan.tables.gauge_offset_change * MM_PER_M:+.4f} mm.</p>",
                  _table(["compensation (model-predicted)", "tables", "mean mm", "max mm"],
                         [[r[0], str(r[3] or ""), r[1], r[2]] for r in plan.report.rows])]
    figures.compensation_grid(data.models[0].machine, data.solutions, fig("tables.png"))
    return parts + ['<p class="note">Compensation functions of every model overlaid (Paper I Fig. 10): input axis '
                    'across, output axis down.</p><img src="figures/tables.png" alt="compensation functions (Fig. 10)">']


def _compensated_part(data: ReportData, fig) -> list[str]:
    where = data.judged
    figures.residual_histograms(data.compensated, fig("histogram_compensated.png"),
                                title=f"Compensated errors predicted at the {where} points (Paper I Fig. 11 form)")
    parts = ["<h2>Compensated errors (Paper I Fig. 11 form)</h2>",
             f'<p class="note">At the {where} points: the measured residual plus the model-predicted error the '
             "tables leave, best-fit rigid motion removed. Measure a compensated run and use <code>vecpin verify"
             "</code> for the real figures.</p>",
             '<img src="figures/histogram_compensated.png" alt="compensated histogram (Fig. 11)">']
    if data.ga:
        figures.ga_convergence_figure(data.ga, fig("ga.png"))
        parts += ["<h3>Genetic algorithm convergence (Paper II Fig. 4)</h3>", '<img src="figures/ga.png" alt="GA">']
    return parts


def tip_scale(data: ReportData) -> ColourScale:
    """The tip error's one colour scale of the report: 0 .. the largest tip error any of its
    colour-mapped figures draws (the grid plots before and after the tables, the scene's
    groups), so that a colour is one size in all of them."""
    from vecpin.viz.scene import scene_vectors
    _, _, vectors = scene_vectors(data.models[0], data.campaign, data.plans[0].tables)
    sizes = [np.linalg.norm(v, axis=1) * MM_PER_M for v in vectors.values()]
    if data.vectors is not None:
        axes, before, after = data.vectors
        m = data.models[0].machine
        sizes += [figures.grid_error_sizes(m, before, axes), figures.grid_error_sizes(m, after, axes)]
    return tip_error_scale(*sizes)


def _vectors_part(data: ReportData, fig, scale: ColourScale | None = None) -> list[str]:
    parts = []
    m = data.models[0].machine
    if data.vectors is not None:
        axes, before, after = data.vectors
        figures.error_vector_plot(m, before, fig("vectors.png"), axes, scale=scale,
                                  title=f"{data.labels[0]}: model-predicted errors, uncompensated")
        figures.error_vector_plot(m, after, fig("vectors_comp.png"), axes, scale=scale,
                                  title=f"{data.labels[0]}: model-predicted errors with its tables (Section 2 Fig. 2.4)")
        parts += ["<h2>Errors on a grid</h2>", '<img src="figures/vectors.png" alt="errors">',
                  '<img src="figures/vectors_comp.png" alt="errors compensated">']
    if figures.repeatability_figure(data.campaign, fig("repeatability.png")):
        parts += ["<h2>Repeatability (eq. 22)</h2>", '<img src="figures/repeatability.png" alt="repeatability">']
    return parts
