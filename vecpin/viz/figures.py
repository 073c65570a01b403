"""The seed's figures for any campaign and model, as image files (matplotlib).

==================================== =====================================================
:func:`compensation_grid`            Paper I Fig. 10 / Paper II Fig. 9: table functions,
                                     input axis across, output axis down, solutions overlaid
:func:`residual_histograms`          Paper I Fig. 9 and 11: volumetric errors before/after
:func:`order_sweep_figure`           Paper I Fig. 7 and 8: mean residual against order
:func:`error_vector_plot`            Section 2 Fig. 2.4: errors on a grid, as vectors
:func:`repeatability_figure`         Section 2 Fig. 2.10-2.11: repeatability (eq. 22)
:func:`ga_convergence_figure`        Paper II Fig. 4-5: GA best score per generation
==================================== =====================================================

Linear quantities in µm (or mm where large), angles in degrees.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from vecpin.compensation.tables import table_name  # noqa: E402
from vecpin.measurement.campaign import Campaign  # noqa: E402
from vecpin.kinematics.machine import Machine  # noqa: E402
from vecpin.models import MODELS  # noqa: E402
from vecpin.units import MM_PER_M
from vecpin.viz.scales import ColourScale, tip_error_scale

COLORS = ["tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown"]


def _save(fig, path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def compensation_grid(machine: Machine, solutions: dict, path, n: int = 200) -> Path:
    """Table functions of several solutions (label -> TableSet): one panel per (output,
    input) pair; linear outputs in µm, rotary outputs in degrees; missing tables blank."""
    axes = machine.axes
    k = len(axes)
    fig, grid = plt.subplots(k, k, figsize=(2.3 * k, 1.9 * k), squeeze=False)
    for r, ao in enumerate(axes):
        for c, ai in enumerate(axes):
            ax = grid[r, c]
            x = np.linspace(ai.lower, ai.upper, n)
            drawn = False
            for j, (label, tables) in enumerate(solutions.items()):
                name = table_name(ao.name, ai.name)
                if name not in tables.names():
                    continue
                y = tables.table(name)(x)
                y = y * MM_PER_M * MM_PER_M if ao.kind == "linear" else np.degrees(y)
                ax.plot(ai.to_user(x), y, color=COLORS[j % len(COLORS)], lw=1.2, label=label)
                drawn = True
            if not drawn:
                ax.set_facecolor("0.95")
            ax.tick_params(labelsize=6)
            if r == k - 1:
                ax.set_xlabel(f"{ai.name} [{ai.unit}]", fontsize=8)
            if c == 0:
                ax.set_ylabel(f"{ao.name} [{'µm' if ao.kind == 'linear' else 'deg'}]", fontsize=8)
            ax.set_title(f"t_{table_name(ao.name, ai.name)}", fontsize=7)
    handles, labels = grid[0, 0].get_legend_handles_labels()
    fig.suptitle("Compensation functions: input axis across, output axis down", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    if handles:
        fig.legend(handles, labels, loc="upper right", ncol=len(labels), fontsize=8, bbox_to_anchor=(1.0, 0.985))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def histogram_layout(errors_mm: dict, max_bins: int = 40, ratio: float = 4.0) -> list[tuple[list[str], np.ndarray]]:
    """Panels and bin edges for histograms of series of very different size: series whose
    largest value is within ``ratio`` of a panel's largest share that panel; each panel
    has its own bins from 0 to its largest value (about 2 sqrt(n) bins, 8 .. ``max_bins``),
    so a model residual ten times smaller than the uncompensated error is not squeezed
    into one or two bars. Returns [(labels, edges)] from the largest series down."""
    items = sorted(errors_mm.items(), key=lambda kv: -float(np.max(kv[1])))
    panels: list[list[str]] = []
    tops: list[float] = []
    for label, d in items:
        top = float(np.max(d))
        if panels and top * ratio >= tops[-1]:
            panels[-1].append(label)
        else:
            panels.append([label])
            tops.append(top)
    out = []
    for labels, top in zip(panels, tops):
        n = max(len(errors_mm[k]) for k in labels)
        bins = int(np.clip(2 * np.sqrt(n), 8, max_bins))
        out.append((labels, np.linspace(0.0, top * 1.02 if top > 0 else 1.0, bins + 1)))
    return out


def residual_histograms(errors_mm: dict, path, bins: int = 40, title: str = "", predicted: dict | None = None) -> Path:
    """Histograms of volumetric errors |e| [mm], one series per label (Paper I Fig. 9:
    nominal, 6-DoF, AP; Fig. 11: compensated). Series of very different size get panels
    of their own with their own bins (:func:`histogram_layout`). ``predicted``: label ->
    predicted distances [mm], drawn as a dashed line at their mean."""
    layout = histogram_layout(errors_mm, bins)
    fig, axs = plt.subplots(len(layout), 1, figsize=(7, 2.5 + 1.7 * len(layout)), squeeze=False)
    names = list(errors_mm)
    for ax, (labels, edges) in zip(axs[:, 0], layout):
        for label in labels:
            j = names.index(label)
            d = np.asarray(errors_mm[label])
            ax.hist(d, bins=edges, alpha=0.55, color=COLORS[j % len(COLORS)],
                    label=f"{label}: mean {d.mean():.3f}, max {d.max():.3f} mm (n={d.size})")
            if predicted and label in predicted:
                pm = float(np.mean(predicted[label]))
                ax.axvline(pm, color=COLORS[j % len(COLORS)], ls="--", lw=1.2,
                           label=f"{label}: model-predicted mean {pm:.3f} mm")
        ax.set_xlabel(f"volumetric error [mm] (bin width {(edges[1] - edges[0]) * MM_PER_M:.1f} µm)")
        ax.set_ylabel("measurements")
        ax.legend(fontsize=7)
    if title:
        fig.suptitle(title, fontsize=9)
    return _save(fig, path)


def before_after_histograms(measured_mm: dict, predicted_mm: dict, path, title: str = "") -> Path:
    """Paper I Fig. 11: measured validation errors of runs before and after compensation,
    each with the model-predicted mean beside it when given."""
    return residual_histograms(measured_mm, path, title=title, predicted=predicted_mm or None)


def order_sweep_figure(sweeps: list, path) -> Path:
    """Mean residual [mm] against series order, identification and held-out, per model."""
    fig, ax = plt.subplots(figsize=(6.5, 3.8))
    for j, s in enumerate(sweeps):
        o = [r.order for r in s.rows]
        name = MODELS[s.kind].display_name
        ax.plot(o, [r.ident_mean for r in s.rows], "o-", color=COLORS[j], label=f"{name} identification")
        ax.plot(o, [r.heldout_mean for r in s.rows], "s--", color=COLORS[j], label=f"{name} {s.method}")
    ax.set_xlabel("series order")
    ax.set_ylabel("mean residual [mm]")
    ax.set_yscale("log")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, path)


def _nice(x: float) -> float:
    """A round number (1, 2 or 5 times a power of ten) near x > 0."""
    e = 10 ** np.floor(np.log10(x))
    return float(min((1, 2, 5, 10), key=lambda m: abs(m * e - x)) * e)


def _grid(machine: Machine, errors_fn, plane: tuple[str, str], n: int, fixed: dict | None, tool: float):
    """(axis a, axis b, U, V (n, n) [m], q0 (the held axes' values), errors (n*n, 3) [mm]) on
    a grid of two linear axes (others at ``fixed`` or mid-travel, rotary axes at 0)."""
    a, b = machine.axis(plane[0]), machine.axis(plane[1])
    q0 = np.array([(ax.lower + ax.upper) / 2 if ax.kind == "linear" else min(max(0.0, ax.lower), ax.upper)
                   for ax in machine.axes])
    for k, v in (fixed or {}).items():
        q0[machine.axis(k).index] = machine.axis(k).to_si(v)
    U, V = np.meshgrid(np.linspace(a.lower, a.upper, n), np.linspace(b.lower, b.upper, n))
    q = np.tile(q0, (U.size, 1))
    q[:, a.index], q[:, b.index] = U.ravel(), V.ravel()
    return a, b, U, V, q0, errors_fn(q, np.full(len(q), tool)) * MM_PER_M


def grid_error_sizes(machine: Machine, errors_fn, plane: tuple[str, str] = ("X", "Y"), n: int = 12,
                     fixed: dict | None = None, tool: float = 0.25) -> np.ndarray:
    """(n*n,) the 3D sizes [mm] :func:`error_vector_plot` colours, for a run's colour scale."""
    return np.linalg.norm(_grid(machine, errors_fn, plane, n, fixed, tool)[5], axis=1)


def error_vector_plot(machine: Machine, errors_fn, path, plane: tuple[str, str] = ("X", "Y"), n: int = 12,
                      fixed: dict | None = None, tool: float = 0.25, title: str = "",
                      scale: ColourScale | None = None) -> Path:
    """Errors on a grid of two linear axes (others at ``fixed`` or mid-travel, rotary axes
    at 0) as vectors in that plane, coloured by the full 3D size [mm] on ``scale`` (the
    run's tip-error scale; None: this figure's own, 0 .. its largest), with an arrow-scale
    key; the title says which axes and tool length [m] the grid holds fixed.
    ``errors_fn(q, tool) -> (N,3) [m]``."""
    a, b, U, V, q0, e = _grid(machine, errors_fn, plane, n, fixed, tool)
    size = np.linalg.norm(e, axis=1)
    scale = scale or tip_error_scale(size)
    fig, ax = plt.subplots(figsize=(7, 5.0))
    qv = ax.quiver(a.to_user(U.ravel()), b.to_user(V.ravel()), e[:, 0], e[:, 1], size, cmap=scale.cmap,
                   clim=scale.limits, angles="xy")
    fig.colorbar(qv, ax=ax, label="volumetric error [mm] (3D length; one scale in every figure of the run)",
                 shrink=0.75, extend="max" if size.max() > scale.top else "neither")
    key = _nice(float(np.percentile(np.hypot(e[:, 0], e[:, 1]), 90)) or 1e-3)
    ax.quiverkey(qv, X=0.03, Y=1.03, U=key, label=f"arrow key: {key:g} mm (in-plane component)",
                 labelpos="E", coordinates="axes", fontproperties={"size": 7})
    held = ", ".join(f"{ax_.name} = {ax_.to_user(q0[ax_.index]):.1f} {ax_.unit}" for ax_ in machine.axes
                     if ax_.name not in (a.name, b.name))
    held = (held + ", " if held else "") + f"tool {tool * MM_PER_M:.1f} mm"
    ax.set_xlabel(f"{a.name} [{a.unit}]")
    ax.set_ylabel(f"{b.name} [{b.unit}]")
    ax.set_title((title or f"errors in the {a.name}{b.name} plane") + f"\nheld fixed: {held}", fontsize=8, loc="left",
                 pad=16)
    ax.set_aspect("equal", adjustable="box")
    return _save(fig, path)


def repeatability(campaign: Campaign) -> np.ndarray:
    """eq. 22: distances [m] of repeated measurements of one command and tool from their
    mean; empty when the campaign repeats nothing."""
    keys = np.round(np.c_[campaign.q, campaign.tool], 9)
    _, group, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    group = np.asarray(group).ravel()
    out = []
    for gi in np.flatnonzero(counts > 1):
        p = campaign.xyz[group == gi]
        out.append(np.linalg.norm(p - p.mean(axis=0), axis=1))
    return np.concatenate(out) if out else np.zeros(0)


def repeatability_figure(campaign: Campaign, path, bins: int = 25) -> Path | None:
    """Histogram of eq. 22 over the repeated commands of the campaign (None if none)."""
    r = repeatability(campaign) * MM_PER_M
    if r.size == 0:
        return None
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.hist(r * MM_PER_M, bins=bins, color="tab:blue", alpha=0.8)
    ax.set_xlabel("distance from the mean of its repeats [µm] (eq. 22)")
    ax.set_ylabel("measurements")
    ax.set_title(f"repeatability: mean {r.mean() * MM_PER_M:.1f} µm, std {r.std() * MM_PER_M:.1f} µm, max {r.max() * MM_PER_M:.1f} µm",
                 fontsize=9)
    return _save(fig, path)


def ga_convergence_figure(histories: dict, path) -> Path:
    """Best score [mm] per generation, averaged over runs, per setting (label -> runs)."""
    fig, ax = plt.subplots(figsize=(6.5, 3.8))
    for j, (label, runs) in enumerate(histories.items()):
        L = max(len(h) for h in runs)
        padded = np.array([np.r_[h, [h[-1]] * (L - len(h))] for h in runs])
        ax.plot(np.arange(1, L + 1), padded.mean(axis=0), color=COLORS[j % len(COLORS)], label=label)
    ax.set_xlabel("generation")
    ax.set_ylabel("best linearised RMS error [mm], mean of runs")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, path)


def _pairs(machine: Machine) -> list[tuple[int, int]]:
    n = machine.n_axes
    if n == 1:
        return [(0, 0)]
    pairs = [(0, 1)]
    if n >= 3:
        pairs.append((0, 2) if n == 3 else (1, 2))
    if n >= 4:
        pairs.append((n - 2, n - 1))
    return pairs


def plan_figure(plan, path, max_removed: int = 1500) -> Path:
    """Paper I Fig. 6: where the planned commands lie in axis space, and where candidates
    were removed for collision avoidance (exclusion zones, "CA"), because the holder
    runs into the machine's geometry, and for line of sight ("LoS"); last panel: the tool tips seen from above with the tracker position and,
    on a plan with table nests, every nest reading where the table carries it."""
    m = plan.machine
    pairs = _pairs(m)
    cols = len(pairs) + 1
    fig, axs = plt.subplots(1, cols, figsize=(4.2 * cols, 4.0), squeeze=False)
    axs = axs[0]
    rng = np.random.default_rng(0)
    ca = np.flatnonzero(plan.removed == "exclusion")
    los = np.flatnonzero(plan.removed == "sight")
    hit = np.flatnonzero(plan.removed == "collision")
    hit = hit if len(hit) <= max_removed else np.sort(rng.choice(hit, max_removed, replace=False))
    ca = ca if len(ca) <= max_removed else np.sort(rng.choice(ca, max_removed, replace=False))
    los = los if len(los) <= max_removed else np.sort(rng.choice(los, max_removed, replace=False))
    qu = m.to_user(plan.candidates)
    cu = m.to_user(plan.commands)
    for ax, (i, j) in zip(axs, pairs):
        ai, aj = m.axes[i], m.axes[j]
        ax.scatter(qu[ca, i], qu[ca, j], s=9, marker="x", color="tab:orange", lw=0.7, alpha=0.7,
                   label=f"removed: collision avoidance ({(plan.removed == 'exclusion').sum()})")
        ax.scatter(qu[hit, i], qu[hit, j], s=9, marker="1", color="tab:purple", lw=0.7, alpha=0.7,
                   label=f"removed: holder in the machine ({(plan.removed == 'collision').sum()})")
        ax.scatter(qu[los, i], qu[los, j], s=9, marker="+", color="tab:red", lw=0.7, alpha=0.7,
                   label=f"removed: line of sight ({(plan.removed == 'sight').sum()})")
        ax.scatter(cu[:, i], cu[:, j], s=14, color="tab:blue", edgecolor="k", lw=0.3,
                   label=f"planned ({len(cu)} commands)")
        ax.set_xlabel(f"{ai.name} [{ai.unit}]")
        ax.set_ylabel(f"{aj.name} [{aj.unit}]")
        ax.set_xlim(ai.lower_user, ai.upper_user)
        ax.set_ylim(aj.lower_user, aj.upper_user)
        ax.grid(alpha=0.3)
    handles, labels = axs[0].get_legend_handles_labels()
    ax = axs[-1]
    L = float(plan.tools[0])
    tips = m.tool_tip(plan.commands, L, frame="base") * MM_PER_M
    lt = m.tool_tip(plan.candidates[los], L, frame="base") * MM_PER_M if len(los) else np.zeros((0, 3))
    ax.scatter(lt[:, 0], lt[:, 1], s=9, marker="+", color="tab:red", lw=0.7, alpha=0.6)
    ax.scatter(tips[:, 0], tips[:, 1], s=12, color="tab:blue", edgecolor="k", lw=0.3)
    nest_handle = None
    tpl = plan.template
    if tpl.has_nests:  # each nest reading where the table carries the nest at that row's command
        rows = np.flatnonzero(tpl.instrument == "nest")
        pts = m.workpiece_points(tpl.q[rows], tpl.nest[rows], jacobian=False).xyz * MM_PER_M
        nest_handle = ax.scatter(pts[:, 0], pts[:, 1], s=10, marker="D", color="tab:green", edgecolor="k", lw=0.2,
                                 alpha=0.6)
    tr = plan.tracker * MM_PER_M
    ax.scatter([tr[0]], [tr[1]], s=160, marker="^", color="k", label="tracker")
    tr_label = np.round(tr) + 0.0  # no "-0"
    ax.annotate(f"tracker\n({tr_label[0]:.0f}, {tr_label[1]:.0f}, {tr_label[2]:.0f}) mm", tr[:2],
                textcoords="offset points",
                xytext=(8, 6), fontsize=7)
    ax.set_xlabel("tool tip x [mm] (machine frame)")
    ax.set_ylabel("tool tip y [mm]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(f"tool tips from above, holder {L * MM_PER_M:.2f} mm", fontsize=8)
    ax.grid(alpha=0.3)
    c = plan.counts()
    fig.suptitle(f"Measurement plan for {m.name}: {len(cu)} commands from {c['candidates']} candidates "
                 f"({c['exclusion']} in exclusion zones, {c['sight']} out of sight)  (Paper I Fig. 6)", fontsize=9)
    handles.append(ax.collections[-1])
    labels.append("tracker position")
    if nest_handle is not None:
        handles.append(nest_handle)
        labels.append(f"table nest readings ({int((tpl.instrument == 'nest').sum())} at {len(plan.nests)} nests, "
                      "last panel)")
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.07, 1, 0.95))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)
    return path
