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
from scipy import stats

from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.features import Features
from vecpin.units import MM_PER_M


def _breakdown(values: np.ndarray, held_m: np.ndarray, held_w: np.ndarray, n_bins: int, label: str, unit: str,
              categorical: bool = False, equations: np.ndarray | None = None) -> dict:
    """Bins of one coordinate: per bin the rows, the mean distance [mm] and mean vector
    [mm] of the held-out residuals ``held_m`` (N,3) [m]; the F tests on the whitened
    residuals ``held_w`` (N,3), whose rows carry ``equations`` (N,) real equations (3 for a
    tracker point, 1 for a range or a ball-bar radius; the rest is padding)."""
    values = np.asarray(values, float)
    N = len(values)
    eqs = np.full(N, 3) if equations is None else np.asarray(equations)
    per_row = float(eqs.mean())
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
    bins, between, within, k_used = [], 0.0, 0.0, 0
    for k in range(len(keys)):
        sel = idx == k
        n = int(sel.sum())
        if n == 0:
            continue
        wbar = held_w[sel].mean(axis=0)
        between += n * float(wbar @ wbar)
        within += float(np.sum((held_w[sel] - wbar) ** 2))
        k_used += 1
        entry = {"n": n, "mean_mm": float(np.linalg.norm(held_mm[sel], axis=1).mean()),
                 "mean_vector_mm": [float(v) for v in held_mm[sel].mean(axis=0)]}
        if categorical:
            entry["value"] = float(keys[k])
        else:
            entry["from"], entry["to"] = float(edges[k]), float(edges[k + 1])
        bins.append(entry)
    grand = held_w.mean(axis=0)
    between -= N * float(grand @ grand)  # structure beyond a common offset
    df_b, df_w = per_row * max(k_used - 1, 1), max(float(eqs.sum()) - per_row * k_used, 1.0)
    F_bins = (between / df_b) / max(within / df_w, 1e-300)
    x = (values - values.mean()) / (values.std() + 1e-300)
    centred = held_w - grand
    slope = (x @ centred) / (x @ x) if x @ x > 0 else np.zeros(3)
    ss_trend = float(slope @ slope * (x @ x))
    ss_rest = float(np.sum((centred - np.outer(x, slope)) ** 2))
    df_t, df_r = per_row, max(float(eqs.sum()) - 2 * per_row, 1.0)
    F_trend = (ss_trend / df_t) / max(ss_rest / df_r, 1e-300)
    return {"coordinate": label, "unit": unit, "bins": bins,
            "F_bins": float(F_bins), "p_bins": float(stats.f.sf(F_bins, df_b, df_w)),
            "F_trend": float(F_trend), "p_trend": float(stats.f.sf(F_trend, df_t, df_r)),
            "scatter": float(within / df_w)}


def localise(machine: Machine, campaign: Campaign, held_m: np.ndarray, held_w: np.ndarray, tips: np.ndarray,
             n_bins: int = 8, alpha: float = 0.01, feats: Features | None = None,
             valid: np.ndarray | None = None) -> dict:
    """Every breakdown of the held-out residuals ``held_m`` [m] / ``held_w`` (whitened);
    ``tips`` (N,3) [m] the modelled tool tips, machine frame; ``valid`` (N,3) the real
    equations of each row (default: three)."""
    out = {}
    feats = feats or Features.from_campaign(campaign)
    eqs = None if valid is None else np.asarray(valid).sum(axis=1)

    def breakdown(*args, **kw):
        return _breakdown(*args, equations=eqs, **kw)
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
        out[f"space:{c}"] = breakdown(tips[:, k] * MM_PER_M, held_m, held_w, n_bins, f"tool tip {c} (machine frame)",
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
