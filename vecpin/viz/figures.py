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

from vecpin.measurement.campaign import Campaign  # noqa: E402
from vecpin.kinematics.machine import Machine  # noqa: E402

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
                name = (ao.name + ai.name).lower()
                if name not in tables.names():
                    continue
                y = tables.table(name)(x)
                y = y * 1e3 * 1e3 if ao.kind == "linear" else np.degrees(y)
                ax.plot(ai.to_user(x), y, color=COLORS[j % len(COLORS)], lw=1.2, label=label)
                drawn = True
            if not drawn:
                ax.set_facecolor("0.95")
            ax.tick_params(labelsize=6)
            if r == k - 1:
                ax.set_xlabel(f"{ai.name} [{ai.unit}]", fontsize=8)
            if c == 0:
                ax.set_ylabel(f"{ao.name} [{'µm' if ao.kind == 'linear' else 'deg'}]", fontsize=8)
            ax.set_title(f"t_{ao.name.lower()}{ai.name.lower()}", fontsize=7)
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


def residual_histograms(errors_mm: dict, path, bins: int = 40) -> Path:
    """Histograms of volumetric errors |e| [mm], one per label (e.g. nominal, 6-DoF, AP)."""
    fig, ax = plt.subplots(figsize=(7, 3.6))
    hi = max(float(np.max(v)) for v in errors_mm.values())
    edges = np.linspace(0, hi, bins + 1)
    for j, (label, d) in enumerate(errors_mm.items()):
        d = np.asarray(d)
        ax.hist(d, bins=edges, alpha=0.55, color=COLORS[j % len(COLORS)],
                label=f"{label}: mean {d.mean():.3f}, max {d.max():.3f} mm")
    ax.set_xlabel("volumetric error [mm]")
    ax.set_ylabel("measurements")
    ax.legend(fontsize=8)
    return _save(fig, path)


def order_sweep_figure(sweeps: list, path) -> Path:
    """Mean residual [mm] against series order, identification and held-out, per model."""
    fig, ax = plt.subplots(figsize=(6.5, 3.8))
    for j, s in enumerate(sweeps):
        o = [r.order for r in s.rows]
        name = {"6dof": "6-DoF", "ap": "AP"}[s.kind]
        ax.plot(o, [r.ident_mean for r in s.rows], "o-", color=COLORS[j], label=f"{name} identification")
        ax.plot(o, [r.heldout_mean for r in s.rows], "s--", color=COLORS[j], label=f"{name} {s.method}")
    ax.set_xlabel("series order")
    ax.set_ylabel("mean residual [mm]")
    ax.set_yscale("log")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, path)


def error_vector_plot(machine: Machine, errors_fn, path, plane: tuple[str, str] = ("X", "Y"), n: int = 12,
                      fixed: dict | None = None, tool: float = 0.25, title: str = "") -> Path:
    """Errors on a grid of two linear axes (others at ``fixed`` or mid-travel) as vectors
    in that plane, coloured by the full 3D size. ``errors_fn(q, tool) -> (N,3) [m]``."""
    a, b = machine.axis(plane[0]), machine.axis(plane[1])
    q0 = np.array([(ax.lower + ax.upper) / 2 if ax.kind == "linear" else 0.0 for ax in machine.axes])
    for k, v in (fixed or {}).items():
        q0[machine.axis(k).index] = machine.axis(k).to_si(v)
    u = np.linspace(a.lower, a.upper, n)
    v = np.linspace(b.lower, b.upper, n)
    U, V = np.meshgrid(u, v)
    q = np.tile(q0, (U.size, 1))
    q[:, a.index], q[:, b.index] = U.ravel(), V.ravel()
    e = errors_fn(q, np.full(len(q), tool)) * 1e3
    size = np.linalg.norm(e, axis=1)
    fig, ax = plt.subplots(figsize=(7, 4.8))
    qv = ax.quiver(a.to_user(U.ravel()), b.to_user(V.ravel()), e[:, 0], e[:, 1], size, cmap="turbo", angles="xy")
    fig.colorbar(qv, ax=ax, label="volumetric error [mm]")
    ax.set_xlabel(f"{a.name} [{a.unit}]")
    ax.set_ylabel(f"{b.name} [{b.unit}]")
    ax.set_title(title or f"errors in the {a.name}{b.name} plane (arrows: in-plane components)", fontsize=9)
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
    r = repeatability(campaign) * 1e3
    if r.size == 0:
        return None
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.hist(r * 1e3, bins=bins, color="tab:blue", alpha=0.8)
    ax.set_xlabel("distance from the mean of its repeats [µm] (eq. 22)")
    ax.set_ylabel("measurements")
    ax.set_title(f"repeatability: mean {r.mean() * 1e3:.1f} µm, std {r.std() * 1e3:.1f} µm, max {r.max() * 1e3:.1f} µm",
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
