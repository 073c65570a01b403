"""The human report of a diagnosis: three plain sentences, the effects with their
evidence and advice, where the residual lies (figures of the breakdowns)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from vecpin.units import MM_PER_M  # noqa: E402


WHICH = ("An effect is *significant* when the F-test within the fit and the paired test on held-out rows both pass "
         "their Bonferroni threshold and it shrinks the held-out mean enough; the most economical significant effect "
         "of each round is *accepted* into the model. Every other effect is judged given the accepted ones (its "
         "figures below are with them in the model; diagnosis.json keeps its figures before them).")
SIZE = ("*Size*: how much the effect, fitted beside the model, moves its prediction of the measured points, RMS over "
        "the rows (an estimate: the part of the effect the model does not already hold).")


def _breakdown_figure(ax, b: dict) -> None:
    bins = b["bins"]
    x = [(e["from"] + e["to"]) / 2 for e in bins] if "from" in bins[0] else [e["value"] for e in bins]
    mean = np.array([e["mean_mm"] for e in bins]) * MM_PER_M          # mm -> µm
    vec = np.array([e["mean_vector_mm"] for e in bins]) * MM_PER_M
    ax.plot(x, mean, "ko-", label="|residual| mean")
    for k, (c, col) in enumerate(zip("xyz", ("tab:red", "tab:green", "tab:blue"))):
        ax.plot(x, vec[:, k], "s--", color=col, ms=3, lw=1, label=f"mean {c}")
    ax.axhline(0, color="0.7", lw=0.8)
    title = b["coordinate"] + (f" - structured (p = {b['p']:.0e})" if b["structured"] else "")
    ax.set_title(title, fontsize=9, color="tab:red" if b["structured"] else "black")
    ax.set_xlabel(f"{b['coordinate']} [{b['unit']}]" if b["unit"] else b["coordinate"], fontsize=8)
    ax.set_ylabel("held-out residual [µm]", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.xaxis.set_major_locator(MaxNLocator(5))  # a few ticks: each one is an object matplotlib builds and draws
    ax.yaxis.set_major_locator(MaxNLocator(4))


def _margins(fig, left: float, right: float, bottom: float, top: float, wspace: float = 0.2,
             hspace: float = 0.2) -> None:
    """Fixed margins in inches (a layout engine would draw the figure twice to find them)."""
    w, h = fig.get_size_inches()
    fig.subplots_adjust(left=left / w, right=1 - right / w, bottom=bottom / h, top=1 - top / h, wspace=wspace,
                        hspace=hspace)


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


def write_report(diag, out) -> Path:
    """report.md and its figures into ``out`` (a :class:`vecpin.fileio.OutputSet`);
    returns where report.md lands."""
    loc = diag.localization["breakdowns"]
    keys = list(loc)
    ncol = 4
    nrow = (len(keys) + ncol - 1) // ncol
    fig, axes = plt.subplots(nrow, ncol, figsize=(4 * ncol, 3 * nrow), squeeze=False)
    for ax, k in zip(axes.ravel(), keys):
        _breakdown_figure(ax, loc[k])
    for ax in axes.ravel()[len(keys):]:
        ax.axis("off")
    axes[0, 0].legend(fontsize=6)
    fig.suptitle("Where the residual lies: held-out residuals of the base model (µm)", fontsize=11)
    _margins(fig, 0.6, 0.2, 0.5, 0.8, wspace=0.3, hspace=0.45)
    fig.savefig(out.path("figures/breakdowns.png"), dpi=90)
    plt.close(fig)
    eff = diag.effects[:12]
    fig, ax = plt.subplots(figsize=(8, 0.35 * max(len(eff), 1) + 1.2))
    y = np.arange(len(eff))[::-1]
    ax.barh(y, [e.shrink_pct for e in eff],
            color=["tab:green" if e.accepted else ("tab:olive" if e.significant else "0.7") for e in eff])
    ax.set_yticks(y, [e.label for e in eff], fontsize=7)
    ax.set_xlabel("held-out mean residual shrink [%] (green: accepted; olive: significant, not taken)")
    ax.axvline(0, color="k", lw=0.8)
    _margins(fig, 0.3 + 0.065 * max([len(e.label) for e in eff] + [10]), 0.2, 0.5, 0.15)  # 7 pt labels
    fig.savefig(out.path("figures/effects.png"), dpi=90)
    plt.close(fig)
    held = np.linalg.norm(diag.heldout_base, axis=1) * MM_PER_M
    fig, ax = plt.subplots(figsize=(8, 3))
    ax.plot(np.arange(len(held)), held, ".", ms=3)
    if diag.outlier_rows:
        ax.set_title(f"{len(diag.outlier_rows)} outlier rows left out (not shown)", fontsize=9)
    ax.set_xlabel("row (measurement order)")
    ax.set_ylabel("held-out |residual| [mm]")
    _margins(fig, 0.8, 0.2, 0.55, 0.35)
    fig.savefig(out.path("figures/rows.png"), dpi=90)
    plt.close(fig)

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
              "![effects](figures/effects.png)", "", "## Where the residual lies", "",
              "| breakdown | F (bins) | p (bins) | F (trend) | p (trend) | structured |", "|---|---|---|---|---|---|"]
    for k in keys:
        v = loc[k]
        lines.append(f"| {k} | {v['F_bins']:.2f} | {v['p_bins']:.1e} | {v['F_trend']:.2f} | {v['p_trend']:.1e} | "
                     f"{'yes' if v['structured'] else 'no'} |")
    if diag.unexplained:
        lines += ["", "Still structured after the accepted effects (unexplained): "
                  + ", ".join(diag.unexplained) + "."]
    lines += ["", "![breakdowns](figures/breakdowns.png)", "", "![rows](figures/rows.png)", ""]
    for g in diag.misfit_regions:
        lines += [f"Not fitted (model misfit, kept in the fit, not gross errors): {g['text']}.", ""]
    if diag.outlier_lines:
        lines += [f"Outliers left out: file lines {', '.join(map(str, diag.outlier_lines))} of {diag.campaign.source}",
                  ""]
    return out.write_text("report.md", "\n".join(lines))
