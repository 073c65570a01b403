"""The figures of a diagnosis report (matplotlib): where the residual lies (the
breakdowns), which effects shrink it, the held-out residual of every row.

Drawn from plain data (:class:`~vecpin.diagnosis.report.DiagnosisFigures`, made by
:func:`vecpin.diagnosis.report.figure_data`); the report's text is
:mod:`vecpin.diagnosis.report`'s, which names the files written here.
"""
from __future__ import annotations

import io
import pickle
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from vecpin.diagnosis.report import FIGURES, DiagnosisFigures  # noqa: E402
from vecpin.units import MM_PER_M  # noqa: E402


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
    # y=1: where matplotlib puts it anyway (nothing drawn above the axes), without measuring every tick label for it
    ax.set_title(title, fontsize=9, color="tab:red" if b["structured"] else "black", y=1.0)
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


def _png(fig) -> bytes:
    """The figure as PNG bytes (90 dpi), closed."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    plt.close(fig)
    return buf.getvalue()


def draw_base(data: DiagnosisFigures) -> dict[str, bytes]:
    """The base model's figures of ``data`` (the breakdowns, the held-out residual of every
    row; ``data.effects`` unused): PNG bytes by :data:`~vecpin.diagnosis.report.FIGURES` key."""
    keys = list(data.breakdowns)
    ncol = 4
    nrow = (len(keys) + ncol - 1) // ncol
    fig = plt.figure(figsize=(4 * ncol, 3 * nrow))
    axes = [fig.add_subplot(nrow, ncol, k + 1) for k in range(len(keys))]   # no Axes for the empty cells
    for ax, k in zip(axes, keys):
        _breakdown_figure(ax, data.breakdowns[k])
    axes[0].legend(fontsize=6)
    fig.suptitle("Where the residual lies: held-out residuals of the base model (µm)", fontsize=11)
    _margins(fig, 0.6, 0.2, 0.5, 0.8, wspace=0.3, hspace=0.45)
    pngs = {"breakdowns": _png(fig)}
    fig, ax = plt.subplots(figsize=(8, 3))
    ax.plot(np.arange(len(data.heldout_mm)), data.heldout_mm, ".", ms=3)
    if data.outliers:
        ax.set_title(f"{data.outliers} outlier rows left out (not shown)", fontsize=9, y=1.0)
    ax.set_xlabel("row (measurement order)")
    ax.set_ylabel("held-out |residual| [mm]")
    _margins(fig, 0.8, 0.2, 0.55, 0.35)
    pngs["rows"] = _png(fig)
    return pngs


def draw_effects(data: DiagnosisFigures) -> dict[str, bytes]:
    """The effects figure of ``data`` (held-out shrink of each effect): PNG bytes by key."""
    eff = data.effects
    fig, ax = plt.subplots(figsize=(8, 0.35 * max(len(eff), 1) + 1.2))
    y = np.arange(len(eff))[::-1]
    ax.barh(y, [e.shrink_pct for e in eff],
            color=["tab:green" if e.accepted else ("tab:olive" if e.significant else "0.7") for e in eff])
    ax.set_yticks(y, [e.label for e in eff], fontsize=7)
    ax.set_xlabel("held-out mean residual shrink [%] (green: accepted; olive: significant, not taken)")
    ax.axvline(0, color="k", lw=0.8)
    _margins(fig, 0.3 + 0.065 * max([len(e.label) for e in eff] + [10]), 0.2, 0.5, 0.15)  # 7 pt labels
    return {"effects": _png(fig)}


def same_base(a: DiagnosisFigures, b: DiagnosisFigures) -> bool:
    """Whether ``a`` and ``b`` draw the same base model's figures (:func:`draw_base`)."""
    return (a.outliers == b.outliers and np.array_equal(a.heldout_mm, b.heldout_mm)
            and pickle.dumps(a.breakdowns) == pickle.dumps(b.breakdowns))


def draw_diagnosis(data: DiagnosisFigures, out) -> dict[str, Path]:
    """The report's figures into ``out`` (a :class:`vecpin.fileio.OutputSet`), under the
    names :data:`vecpin.diagnosis.report.FIGURES` gives; returns where each lands."""
    pngs = draw_base(data) | draw_effects(data)
    return {k: out.write_bytes(FIGURES[k], pngs[k]) for k in FIGURES}
