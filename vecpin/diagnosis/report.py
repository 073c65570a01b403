"""The human report of a diagnosis: three plain sentences, the effects with their
evidence and advice, where the residual lies; and the plain data of its figures, which
:mod:`vecpin.viz.diagnosis` draws."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vecpin.units import MM_PER_M

# the report's figures: what each shows -> its file in the output folder
FIGURES = {"breakdowns": "figures/breakdowns.png", "effects": "figures/effects.png", "rows": "figures/rows.png"}


WHICH = ("An effect is *significant* when the F-test within the fit and the paired test on held-out rows both pass "
         "their Bonferroni threshold and it shrinks the held-out mean enough; the most economical significant effect "
         "of each round is *accepted* into the model. Every other effect is judged given the accepted ones (its "
         "figures below are with them in the model; diagnosis.json keeps its figures before them).")
SIZE = ("*Size*: how much the effect, fitted beside the model, moves its prediction of the measured points, RMS over "
        "the rows (an estimate: the part of the effect the model does not already hold).")


@dataclass
class EffectBar:
    """One effect of the effects figure: its label, held-out shrink [%] and verdict."""

    label: str
    shrink_pct: float
    accepted: bool
    significant: bool


@dataclass
class DiagnosisFigures:
    """What the report's figures show, as plain data: ``breakdowns`` as the diagnosis'
    ``localization["breakdowns"]`` (bins with mean residuals [mm], F and p, per
    coordinate), the first twelve effects, the held-out residual norm of every row [mm]
    and the number of outlier rows left out."""

    breakdowns: dict
    effects: list[EffectBar]
    heldout_mm: np.ndarray
    outliers: int


def figure_data(diag) -> DiagnosisFigures:
    """The data of the report's figures of the diagnosis ``diag``."""
    return DiagnosisFigures(diag.localization["breakdowns"],
                            [EffectBar(e.label, e.shrink_pct, e.accepted, e.significant) for e in diag.effects[:12]],
                            np.linalg.norm(diag.heldout_base, axis=1) * MM_PER_M, len(diag.outlier_rows))


def _next_section(diag) -> list[str]:
    """'What to measure next': per ambiguity group or dropped effect, the discriminating
    points, their files and the expected outcome under each candidate."""
    todo = diag.to_settle()
    if not todo:
        return []
    lines = ["", "## What to measure next", "",
             "Commands chosen where the candidates' predicted readings differ most relative to the noise of a "
             "reading there. Measure them with the same tracker set-up, right after the campaign, append the rows to "
             "the campaign file and diagnose again: the readings follow one candidate's expected values."]
    for k, e in enumerate(todo, 1):
        p = e.next_plan
        progs = ", ".join(f"`{v}`" for d, v in p.files.items() if d not in ("plan", "expected")
                          and not v.startswith("not written"))
        lines += ["", f"**{' or '.join(p.labels)}**: {p.outcome()}.", "",
                  f"- plan template: `{p.files.get('plan', '')}`; expected readings under each candidate (mm, "
                  f"tracker frame): `{p.files.get('expected', '')}`",
                  f"- NC programs: {progs or 'none (see the notes below)'}"]
        lines += [f"- {d}: {v}" for d, v in p.files.items() if v.startswith("not written")]
    return lines


def _sight_section(diag) -> list[str]:
    """'What this campaign could have seen': per effect family the smallest size it would detect."""
    if not diag.detection:
        return []
    from vecpin.diagnosis.detection import POWER, um_text
    lines = ["", "## What this campaign could have seen", "",
             f"Per family, the smallest effect (RMS of its displacement of the measured points) this campaign's "
             f"{diag.base['rows']} rows would name {POWER:.0%} of the time, given the final model: the F-test's "
             "power at its threshold, the paired held-out test's and the held-out shrink an effect must earn, the "
             "largest of the three. An effect left unnamed is below this size here.", "",
             "| effect | detectable from | its most visible candidate | limited by | hardest candidate |",
             "|---|---|---|---|---|"]
    for f in diag.detection:
        lines.append(f"| {f['effect']} | {um_text(f['detectable_rms_um'])} | {f['candidate']} | {f['limited_by']} | "
                     f"{f['hardest_candidate']} ({um_text(f['hardest_rms_um'])}) |")
    return lines


def write_report(diag, out, figures: bool) -> Path:
    """report.md into ``out`` (a :class:`vecpin.fileio.OutputSet`), naming the figures
    (:data:`FIGURES`) when ``figures`` (they are drawn beside it); returns where it lands."""
    loc = diag.localization["breakdowns"]
    keys = list(loc)
    b = diag.base
    lines = [f"# Diagnosis of {diag.machine.name}", ""] + [s + "  " for s in diag.headline()] + ["",
             f"Base model: {b['label']} (chosen by held-out data unless fixed), {b['rows']} rows, "
             f"{b['folds']}-fold cross-validation grouped by command. Held-out mean {b['heldout_mean_mm']:.4f} mm, "
             f"max {b['heldout_max_mm']:.4f} mm; chi2/expected {b['chi2_per_expected']:.2f}.", ""]
    if diag.base_finding:
        lines += [diag.base_finding, ""]
    lines += ["## Which effect", "", WHICH, "", SIZE, "",
              "| rank | effect | significant | accepted | held-out mean before (mm) | after (mm) | shrink | size (mm) "
              "| p (fit) | p (held-out) |", "|---|---|---|---|---|---|---|---|---|---|"]
    for k, e in enumerate(diag.effects, 1):
        lines.append(f"| {k} | {e.label} | {'yes' if e.significant else 'no'} | {'yes' if e.accepted else 'no'} | "
                     f"{e.heldout_mean_mm_before:.4f} | {e.heldout_mean_mm_after:.4f} | {e.shrink_pct:.1f}% | "
                     f"{e.size_text} | {e.p_value:.1e} | {e.p_heldout:.1e} |")
    for e in diag.accepted:
        lines += ["", f"**{e.headword}**: {e.evidence}"] + [f"- {a}" for a in e.advice]
    lines += _sight_section(diag)
    lines += _next_section(diag)
    m, x = diag.best_heldout()
    lines += ["", f"Best model (base + accepted effects): held-out mean {m:.4f} mm, max {x:.4f} mm.", "",
              *_image("effects", figures), "## Where the residual lies", "",
              "| breakdown | F (bins) | p (bins) | F (trend) | p (trend) | structured |", "|---|---|---|---|---|---|"]
    for k in keys:
        v = loc[k]
        lines.append(f"| {k} | {v['F_bins']:.2f} | {v['p_bins']:.1e} | {v['F_trend']:.2f} | {v['p_trend']:.1e} | "
                     f"{'yes' if v['structured'] else 'no'} |")
    if diag.unexplained:
        lines += ["", "Still structured after the accepted effects (unexplained): "
                  + ", ".join(diag.unexplained) + "."]
    lines += ["", *_image("breakdowns", figures), *_image("rows", figures)]
    for g in diag.misfit_regions:
        lines += [f"Not fitted (model misfit, kept in the fit, not gross errors): {g['text']}.", ""]
    if diag.outlier_lines:
        lines += [f"Outliers left out: file lines {', '.join(map(str, diag.outlier_lines))} of {diag.campaign.source}",
                  ""]
    return out.write_text("report.md", "\n".join(lines))


def _image(name: str, drawn: bool) -> list[str]:
    """The markdown lines of the figure ``name`` (nothing when the figures are not drawn)."""
    return [f"![{name}]({FIGURES[name]})", ""] if drawn else []
