"""Where the residual lies: held-out residuals broken down along every coordinate a
cause could follow (each axis, each axis' approach direction, time, temperature, row
order, tool, space), each with tests of structure beyond the scatter.

A breakdown bins the rows by one coordinate. Its structure tests are one-way analyses
of variance of the whitened held-out residuals (three components pooled): the
between-bin mean square over the within-bin mean square (an F ratio, so an error
that inflates every row's scatter does not hide the structure), and a linear trend
along the coordinate over the scatter about the trend. A breakdown is *structured*
when either p-value is below alpha / (number of breakdowns)."""
from __future__ import annotations

import numpy as np
from scipy import special

from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.features import Features
from vecpin.units import MM_PER_M


def _breakdown(values: np.ndarray, held_m: np.ndarray, held_w: np.ndarray, n_bins: int, label: str, unit: str,
               categorical: bool = False, valid: np.ndarray | None = None) -> dict:
    """Bins of one coordinate: per bin the rows, the mean distance [mm] and mean vector
    [mm] of the held-out residuals ``held_m`` (N,3) [m]; the F tests on the whitened
    residuals ``held_w`` (N,3), whose rows carry the real equations ``valid`` (N,3) (all
    three for a tracker point, the first for a range or a ball bar radius; the rest is
    padding and is not counted). Each equation (component) has its own grand mean, bin
    means and trend; sums of squares and degrees of freedom are pooled over the
    components (a one-way analysis of variance and a regression on the coordinate of the
    stacked equations, with a mean per component)."""
    values = np.asarray(values, float)
    N = len(values)
    valid = np.ones((N, 3), bool) if valid is None else np.asarray(valid, bool)
    if categorical:
        keys = np.unique(values)
        idx = np.searchsorted(keys, values)
        edges = None
    else:
        lo, hi = float(values.min()), float(values.max())
        edges = np.linspace(lo, hi, n_bins + 1)
        idx = np.clip(np.searchsorted(edges, values, side="right") - 1, 0, n_bins - 1)
        keys = np.arange(n_bins)
    held_mm = held_m * MM_PER_M
    bins = []
    for k in range(len(keys)):
        sel = idx == k
        n = int(sel.sum())
        if n == 0:
            continue
        entry = {"n": n, "mean_mm": float(np.linalg.norm(held_mm[sel], axis=1).mean()),
                 "mean_vector_mm": [float(v) for v in held_mm[sel].mean(axis=0)]}
        if categorical:
            entry["value"] = float(keys[k])
        else:
            entry["from"], entry["to"] = float(edges[k]), float(edges[k + 1])
        bins.append(entry)
    between = within = ss_trend = ss_rest = 0.0
    df_b = df_w = df_t = df_r = 0.0
    for c in range(3):
        rc = valid[:, c]
        n_c = int(rc.sum())
        if n_c < 3:
            continue
        w, ix, v = held_w[rc, c], idx[rc], values[rc]
        count = np.bincount(ix, minlength=len(keys))
        total = np.bincount(ix, weights=w, minlength=len(keys))
        used = count > 0
        mean = np.where(used, total / np.maximum(count, 1), 0.0)
        grand = w.mean()
        between += float(np.sum(count[used] * (mean[used] - grand) ** 2))
        within += float(np.sum((w - mean[ix]) ** 2))
        df_b += int(used.sum()) - 1
        df_w += n_c - int(used.sum())
        x = v - v.mean()
        xx = float(x @ x)
        if xx > 0:
            slope = float(x @ (w - grand)) / xx
            ss_trend += slope**2 * xx
            ss_rest += float(np.sum((w - grand - slope * x) ** 2))
            df_t += 1
            df_r += n_c - 2
    df_b, df_w, df_t, df_r = max(df_b, 1.0), max(df_w, 1.0), max(df_t, 1.0), max(df_r, 1.0)
    F_bins = (between / df_b) / max(within / df_w, 1e-300)
    F_trend = (ss_trend / df_t) / max(ss_rest / df_r, 1e-300)
    return {"coordinate": label, "unit": unit, "bins": bins,
            "F_bins": float(F_bins), "p_bins": float(special.fdtrc(df_b, df_w, F_bins)),
            "F_trend": float(F_trend), "p_trend": float(special.fdtrc(df_t, df_r, F_trend)),
            "scatter": float(within / df_w)}


def localise(machine: Machine, campaign: Campaign, held_m: np.ndarray, held_w: np.ndarray, tips: np.ndarray,
             n_bins: int = 8, alpha: float = 0.01, feats: Features | None = None,
             valid: np.ndarray | None = None) -> dict:
    """Every breakdown of the held-out residuals ``held_m`` [m] / ``held_w`` (whitened);
    ``tips`` (N,3) [m] the modelled points the rows measure (tool tips, targets, nests),
    machine frame; ``valid`` (N,3) the real equations of each row (default: three)."""
    out = {}
    feats = feats or Features.from_campaign(campaign)

    def breakdown(*args, **kw):
        return _breakdown(*args, valid=valid, **kw)
    for a in machine.axes:
        out[f"axis:{a.name}"] = breakdown(a.to_user(campaign.q[:, a.index]), held_m, held_w, n_bins, a.name, a.unit)
    for a in machine.axes:
        d = feats.direction[:, a.index]
        if len(np.unique(d)) > 1:
            out[f"direction:{a.name}"] = breakdown(d, held_m, held_w, 0, f"approach direction of {a.name}", "",
                                                   categorical=True)
    if feats.has_time:
        out["time"] = breakdown(feats.time, held_m, held_w, n_bins, "time", "s")
    if feats.temperature is not None:
        out["temperature"] = breakdown(feats.temperature, held_m, held_w, n_bins, "temperature", "degC")
    if len(np.unique(np.round(campaign.tool, 9))) > 1:
        out["tool"] = breakdown(campaign.tool * MM_PER_M, held_m, held_w, 0, "tool", "mm", categorical=True)
    out["row order"] = breakdown(np.arange(len(campaign), dtype=float), held_m, held_w, n_bins, "row", "")
    for k, c in enumerate("xyz"):
        out[f"space:{c}"] = breakdown(tips[:, k] * MM_PER_M, held_m, held_w, n_bins, f"measured point {c} (machine frame)",
                                      "mm")
    limit = alpha / len(out)
    for v in out.values():
        v["p"] = min(v["p_bins"], v["p_trend"])
        v["structured"] = bool(v["p"] < limit)
    ranked = sorted(out, key=lambda k: out[k]["p"])
    return {"breakdowns": out, "most_structured": [k for k in ranked if out[k]["structured"]][:5],
            "limit": limit,
            "note": "held-out (k-fold CV) residuals; one-way analysis of variance of the whitened residuals per "
                    "coordinate (bin means and a linear trend over the scatter within); 'structured' when a p-value "
                    "is below alpha / number of breakdowns"}


def explained(before: dict, after: dict) -> list[str]:
    """Breakdowns structured before and not after (what an added effect explains)."""
    b, a = before["breakdowns"], after["breakdowns"]
    return [k for k in b if b[k]["structured"] and k in a and not a[k]["structured"]]


def describe_structure(loc: dict, keys: list[str]) -> str:
    """'X (p = 1e-9), time (p = 3e-5)' for the given breakdowns."""
    b = loc["breakdowns"]
    return ", ".join(f"{b[k]['coordinate']} (p = {b[k]['p']:.1e})" for k in keys)
