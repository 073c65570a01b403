"""Per-tool distance tables: the before/after lines every command prints (the one
uncompensated figure of a campaign is :mod:`vecpin.measurement.uncompensated`)."""
from __future__ import annotations

import numpy as np

from vecpin.measurement.stats import distance_stats
from vecpin.units import MM_PER_M


MAX_TOOLS_LISTED = 6  # tool lengths given a line each


def per_tool_table(rows: list[tuple], tool: np.ndarray) -> list[str]:
    """Lines of n/mean/max/RMS [mm] for each labelled set of distances [mm], per tool
    when there are several tools. A row is (label, distances) with ``tool`` [m] the
    rows' tool lengths, or (label, distances, its own tool lengths)."""
    lines = [f"  {'':<40s} {'n':>5s} {'mean mm':>9s} {'max mm':>9s} {'RMS mm':>9s}"]
    for label, d, *own in rows:
        st = distance_stats(d, own[0] if own else tool)
        keys = list(st) if 2 < len(st) <= MAX_TOOLS_LISTED + 1 else ["all"]
        for k in keys:
            s = st[k]
            name = label if k == "all" else f"    {k}"
            lines.append(f"  {name:<40s} {s['n']:5d} {s['mean']:9.4f} {s['max']:9.4f} {s['rms']:9.4f}")
    n_tools = len(np.unique(np.round(np.asarray(tool, float), 9)))
    if n_tools > MAX_TOOLS_LISTED:
        lines.append(f"  ({n_tools} different tool lengths, {np.min(tool) * MM_PER_M:.3f} .. {np.max(tool) * MM_PER_M:.3f} mm: "
                     "not listed one by one; is the tool column a measured length that varies row to row?)")
    return lines


def error_summary(label: str, err_mm: np.ndarray) -> str:
    """One line: mean/max/RMS of the lengths of (N,3) error vectors [mm]."""
    d = np.linalg.norm(err_mm, axis=1)
    return f"  {label:<42s} mean {d.mean():8.4f} mm   max {d.max():8.4f} mm   RMS {np.sqrt((d**2).mean()):8.4f} mm"
