"""Gross errors at a stated false-alarm rate, told apart from model misfit.

* **The statistic.** A row's held-out whitened residual w is a prediction: its
  covariance is the noise (the identity, at the robust scale) plus the fold model's own
  uncertainty there, J_i (G_-f + I)^-1 J_i^T. A row at the edge of the travel, where the
  fold model extrapolates, has a larger spread than a row in the middle; the statistic
  s = w^T C^-1 w is chi2 with the row's own number of equations wherever the row lies.
* **The limit.** Šidák over the rows: a clean campaign of any size flags a row with
  probability :data:`FAMILY_ALPHA` (1 %) in all, not 1 % per thousand rows.
* **Misfit, not gross error.** A flagged row read again at the same pose (same command,
  tool, point, target and station) whose readings agree within the noise is a place the
  model does not fit: a re-measurement would read the same. Flagged rows crowded into one
  stretch of an axis' travel (more than chance puts there) are a region the model does not
  fit. Both are kept in the fit and reported as regions, not left out.
"""
from __future__ import annotations

import numpy as np
from scipy import linalg, stats

from vecpin.identification.crossval import Linearised
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.repeatability import repeat_groups

FAMILY_ALPHA = 0.01  # chance that a clean campaign flags any row at all
REGION_ALPHA = 0.01  # family-wise false-alarm rate of the region (cluster) test
AGREE_P = 0.01       # repeated readings agree unless their difference is beyond this tail


def _equations(valid: np.ndarray) -> np.ndarray:
    return np.maximum(np.asarray(valid).sum(axis=1), 1)


def prediction_statistic(w: np.ndarray, J: np.ndarray, M: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(N,) w_i^T (I + J_i M J_i^T)^-1 w_i over each row's real equations: the squared
    whitened residual of rows the model ``M`` = (G + I)^-1 did not see, scaled by its
    predicted spread (noise plus the model's uncertainty at that row)."""
    C = np.eye(3) + (J @ M) @ J.transpose(0, 2, 1)
    pad = ~np.asarray(valid, bool)
    C[pad, :] = 0.0
    C.transpose(0, 2, 1)[pad, :] = 0.0
    C[:, [0, 1, 2], [0, 1, 2]] = np.where(pad, 1.0, C[:, [0, 1, 2], [0, 1, 2]])
    wv = np.where(pad, 0.0, w)
    x = np.linalg.solve(C, wv[..., None])[..., 0]
    return np.einsum("pi,pi->p", wv, x)


def heldout_statistic(lin: Linearised, folds: np.ndarray, held_w: np.ndarray) -> np.ndarray:
    """:func:`prediction_statistic` of the held-out residuals of every fold."""
    prob = lin.folded(folds)
    eye = np.eye(prob.n_columns)
    s = np.empty(len(held_w))
    for f in np.unique(folds):
        te = folds == f
        M = linalg.inv(prob.G_out[f] + eye)
        s[te] = prediction_statistic(held_w[te], lin.J[te], M, lin.valid[te])
    return s


def robust_level(s: np.ndarray, valid: np.ndarray) -> float:
    """The noise level of statistics s: median of s / median chi2(k) (1 when the noise
    model is right; gross errors do not move a median)."""
    return float(max(np.median(s / stats.chi2.median(_equations(valid))), 1e-300))


def row_limit(valid: np.ndarray, n_rows: int, alpha: float = FAMILY_ALPHA) -> np.ndarray:
    """(N,) the chi2 limit of each row so that ``n_rows`` clean rows pass together with
    probability 1 - alpha (Šidák)."""
    p = -np.expm1(np.log1p(-alpha) / max(n_rows, 1))
    return stats.chi2.isf(p, _equations(valid))


def beyond(s: np.ndarray, valid: np.ndarray, level: float, n_rows: int, alpha: float = FAMILY_ALPHA) -> np.ndarray:
    """(N,) rows whose statistic no noise explains (a statistic that is not a number is beyond)."""
    return ~(s / level <= row_limit(valid, n_rows, alpha))


def pose_keys(campaign: Campaign) -> np.ndarray:
    """(N,) one integer per pose read: command and tool (:func:`repeat_groups`), tool point,
    target, station, instrument."""
    cols = [repeat_groups(campaign)[0][:, None].astype(float), campaign.point[:, None].astype(float)]
    _, tgt = np.unique(campaign.target.astype(str), return_inverse=True)
    _, ins = np.unique(campaign.instrument.astype(str), return_inverse=True)
    cols += [np.asarray(tgt, float).reshape(-1, 1), np.asarray(campaign.station, float)[:, None],
             np.asarray(ins, float).reshape(-1, 1)]
    _, key = np.unique(np.hstack(cols), axis=0, return_inverse=True)
    return np.asarray(key).ravel()


def agreeing_repeats(campaign: Campaign, flagged: np.ndarray, w: np.ndarray, valid: np.ndarray,
                     level: float) -> np.ndarray:
    """The flagged rows (indices) that another reading of the same pose agrees with: the
    difference of their whitened residuals (the model's prediction cancels) is within the
    noise of two readings, or smaller than half of either residual (most of the residual
    is shared by the readings: the machine at that pose, not the reading; independent
    gross errors differ by about as much as they are large)."""
    key = pose_keys(campaign)
    out = []
    for i in flagged:
        for j in np.flatnonzero(key == key[i]):
            if j == i:
                continue
            both = valid[i] & valid[j]
            d = np.where(both, w[i] - w[j], 0.0)
            shared = 0.5 * min(np.linalg.norm(np.where(both, w[i], 0.0)), np.linalg.norm(np.where(both, w[j], 0.0)))
            if (float(d @ d) / (2 * level) <= stats.chi2.isf(AGREE_P, max(int(both.sum()), 1))
                    or np.linalg.norm(d) < shared):
                out.append(int(i))
                break
    return np.array(out, int)


def _bins(x: np.ndarray) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """Bin index per row along one axis: its distinct positions when there are at most
    eight, eight equal stretches of the travel otherwise; and each bin's span."""
    u = np.unique(np.round(x, 9))
    if len(u) <= 8:
        idx = np.searchsorted(u, np.round(x, 9))
        return idx, [(float(v), float(v)) for v in u]
    edges = np.linspace(x.min(), x.max(), 9)
    idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, 7)
    return idx, [(float(edges[k]), float(edges[k + 1])) for k in range(8)]


def crowded_regions(machine: Machine, campaign: Campaign, flagged: np.ndarray,
                    alpha: float = REGION_ALPHA) -> list[dict]:
    """Stretches of one axis' travel (one or two neighbouring bins) holding more of the
    flagged rows than chance puts there (hypergeometric tail, Bonferroni over every
    stretch tried), at least three and at least half of the flagged rows left:
    [{"axis", "from", "to", "unit", "rows", "rows_there"}], most crowded first."""
    left = np.asarray(flagged, int)
    N = len(campaign)
    out = []
    while left.size >= 3:
        trials = []
        for a in machine.axes:
            x = a.to_user(campaign.q[:, a.index])
            idx, spans = _bins(x)
            nb = len(spans)
            for lo in range(nb):
                for hi in (lo, lo + 1):
                    if hi >= nb or (lo == 0 and hi == nb - 1):
                        continue
                    there = (idx >= lo) & (idx <= hi)
                    c = int(there[left].sum())
                    trials.append((stats.hypergeom.sf(c - 1, N, left.size, int(there.sum())), c, a, spans[lo][0],
                                   spans[hi][1], there))
        if not trials:
            break
        p, c, a, x0, x1, there = min(trials, key=lambda t: t[0])
        if not (p * len(trials) < alpha and c >= 3 and 2 * c >= left.size):
            break
        rows = left[there[left]]
        out.append({"axis": a.name, "from": x0, "to": x1, "unit": a.unit, "rows": [int(r) for r in rows],
                    "rows_there": int(there.sum()), "p": float(p * len(trials))})
        left = left[~there[left]]
    return out


def judge(machine: Machine, campaign: Campaign, s: np.ndarray, w: np.ndarray, valid: np.ndarray,
          n_rows: int | None = None, alpha: float = FAMILY_ALPHA) -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """(gross errors, misfit rows, regions): rows beyond the noise (``s`` the
    statistics, ``w`` the whitened residuals of ``campaign``'s rows), less those a repeat
    reading agrees with and those crowded into one stretch of an axis (both misfit)."""
    level = robust_level(s, valid)
    flagged = np.flatnonzero(beyond(s, valid, level, n_rows or len(s), alpha))
    if flagged.size == 0:
        return flagged, flagged, []
    repeat = agreeing_repeats(campaign, flagged, w, valid, level)
    rest = np.setdiff1d(flagged, repeat)
    regions = crowded_regions(machine, campaign, flagged)
    in_region = np.array(sorted({r for g in regions for r in g["rows"]}), int)
    alone = np.setdiff1d(repeat, in_region)
    if alone.size:
        regions.append({"axis": "", "from": np.nan, "to": np.nan, "unit": "", "rows": [int(r) for r in alone],
                        "rows_there": int(alone.size), "p": np.nan})
    gross = np.setdiff1d(rest, in_region)
    return gross, np.setdiff1d(flagged, gross), regions


def describe_region(g: dict, campaign: Campaign) -> tuple[str, str]:
    """('Z 800 to 1000 mm', 'Z 800 to 1000 mm (12 of the 40 rows there are beyond the
    noise; file lines ...)') for one misfit region: where, and the full account."""
    lines = campaign.lines[np.asarray(g["rows"], int)]
    shown = ", ".join(map(str, lines[:12])) + (" ..." if lines.size > 12 else "")
    if not g["axis"]:
        return (f"{len(g['rows'])} repeatedly read rows",
                f"{len(g['rows'])} rows whose repeated readings agree with each other (file lines {shown})")
    span = (f"{g['axis']} = {g['from']:.6g} {g['unit']}" if g["from"] == g["to"]
            else f"{g['axis']} {g['from']:.6g} to {g['to']:.6g} {g['unit']}")
    return span, f"{span} ({len(g['rows'])} of the {g['rows_there']} rows there are beyond the noise; file lines {shown})"
