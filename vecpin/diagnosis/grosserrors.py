"""Gross errors at a stated false-alarm rate, told apart from model misfit.

* **The statistic.** A row's held-out whitened residual w is a prediction: its
  covariance is the noise (the identity, at the robust scale) plus the fold model's own
  uncertainty there, J_i (G_-f + I)^-1 J_i^T. A row at the edge of the travel, where the
  fold model extrapolates, has a larger spread than a row in the middle; the statistic
  s = w^T C^-1 w is chi2 with the row's own number of equations wherever the row lies.
* **The limit.** Šidák over the rows: a clean campaign of any size flags a row with
  probability at most :data:`FAMILY_ALPHA` (1 %) in all, not 1 % per thousand rows (with
  three equations a row: about 0.9 % at 300 rows, 0.7 % at 40; nu below is the median's
  asymptotic figure, so the limit is conservative for few rows). The noise level
  is estimated from the same residuals (their median), so it is not known: a row's statistic
  over it is k F(k, nu) (:func:`limit`), nu the level's degrees of freedom (:func:`level_dof`),
  not chi2_k. Treating the level as known flags a clean campaign of 300 rows with about 1.2 %,
  of 40 rows with about 2 % (the false alarm rises as the level's own scatter lowers the limit).
* **Robust before classified.** The fold models are fitted with the rows beyond the
  limit skipped (:func:`vecpin.identification.robust.robust_fit` on the linearised
  problem: an M-estimate with skipped, hard-redescending weights, until the rows skipped
  settle), so gross rows do not pull the models that judge the other rows
  (:func:`robust_heldout`).
* **Misfit, not gross error.** A flagged row read again at the same pose (same command,
  tool, point, target and station) whose readings agree within the noise is a place the
  model does not fit: a re-measurement would read the same. A flagged row whose
  neighbours share its misfit is in a region the model does not fit: along one axis (or in
  measurement order: rows read one after another), a local linear fit of the neighbours'
  residuals (a Gaussian kernel, each of :data:`BANDWIDTHS` of the span, the row itself left out)
  takes up most of its residual (:data:`SHARED`). So is a flagged row whose neighbours in
  joint space (every axis scaled by its measured travel) share it: the same command read at
  another visit (another tool or target, another time: a reading error does not come back),
  else a local linear fit of the other commands' residuals, predicts it within the noise
  (:func:`shared_nearby`). Other targets of the same visit, and other flagged rows of other
  commands (a cluster read while the tracker moved), do not vouch for it. Rows that merely
  crowd one stretch, their neighbours near the model, are gross errors. Both kinds of misfit
  are kept in the fit and reported as regions, not left out.
"""
from __future__ import annotations

import numpy as np
from scipy import linalg, special

from vecpin.identification.crossval import FoldedProblem

from vecpin.identification.linearised import Linearised
from vecpin.identification.robust import FAMILY_ALPHA, equations, robust_fit, row_limit  # noqa: F401 (API too)
from vecpin.identification.robust import median_level as robust_level
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.poses import poses
from vecpin.measurement.repeatability import repeat_groups

BANDWIDTHS = (0.01, 0.04)  # the kernel's sigma along an axis, shares of the span measured: narrow and wide misfit
SHARED = 0.5         # a region's row: its neighbours' local fit leaves at most this share of its residual
NEAR_COMMANDS = 2    # the joint-space kernel's width: the distance to this many commands per fitted coefficient
REGION_MIN = 3       # flagged rows that share their misfit along one axis before that stretch is a region
AGREE_P = 0.01       # repeated readings agree unless their difference is beyond this tail


def prediction_statistic(w: np.ndarray, J: np.ndarray, M: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(N,) w_i^T (I + J_i M J_i^T)^-1 w_i over each row's real equations: the squared
    whitened residual of rows the model ``M`` = (G + I)^-1 did not see, scaled by its
    predicted spread (noise plus the model's uncertainty at that row)."""
    JM = (J.reshape(-1, J.shape[-1]) @ M).reshape(J.shape)   # one product, not one per row (4x faster)
    C = np.eye(3) + JM @ J.transpose(0, 2, 1)
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


def robust_heldout(lin: Linearised, folds: np.ndarray, n_rows: int, alpha: float = FAMILY_ALPHA) -> dict:
    """The held-out residuals of every row from fold models fitted without the rows a
    robust fit of all rows skips (module text): {"s": (N,) :func:`prediction_statistic`,
    "heldout_w" (N,3) whitened, "heldout" (N,3) metric [m], "skipped": indices}."""
    rf = robust_fit(lin.J, lin.w, lin.valid, lin.psi0, n_rows=n_rows, alpha=alpha)
    u = np.sqrt(rf.weights)[:, None]
    if rf.weights.all():
        prob = lin.folded(folds)
    else:
        u3 = u[..., None]
        prob = FoldedProblem(lin.J * u3, lin.A, lin.w * u, lin.r, folds, None, lin.psi0)
    psi = prob.fold_estimates()
    eye = np.eye(prob.n_columns)
    held, held_w, s = np.empty_like(lin.r), np.empty_like(lin.w), np.empty(len(lin.w))
    for f in range(prob.k):
        te = folds == f
        held[te] = lin.r[te] - lin.A[te] @ psi[f]
        held_w[te] = lin.w[te] - lin.J[te] @ psi[f]
        s[te] = prediction_statistic(held_w[te], lin.J[te], linalg.inv(prob.G_out[f] + eye), lin.valid[te])
    return {"s": s, "heldout_w": held_w, "heldout": held, "skipped": rf.beyond}


def level_dof(valid: np.ndarray) -> float:
    """The degrees of freedom nu of the median level (:func:`robust_level`) of rows ``valid``
    (N,3): the level's relative variance is 2 / nu. The sample median of x_i = s_i / m_k (m_k
    the median of chi2_k) has variance 1 / (4 N f(1)^2), f(1) = mean of m_k pdf_k(m_k) the
    density of the x_i at their median 1, so nu = 8 N f(1)^2 (1.58 N when every row has three
    equations, 0.37 N with one)."""
    k = equations(valid)
    m = special.chdtri(k, 0.5)
    dens = m * np.exp((k / 2.0 - 1.0) * np.log(m) - m / 2.0 - (k / 2.0) * np.log(2.0) - special.gammaln(k / 2.0))
    return float(8.0 * k.size * np.mean(dens) ** 2)


def limit(valid: np.ndarray, n_rows: int, alpha: float = FAMILY_ALPHA, dof: float = np.inf) -> np.ndarray:
    """(N,) each row's limit on s / level (Šidák over ``n_rows`` rows at the family-wise rate
    ``alpha``): k F^-1(k, ``dof``) at the row's share of the rate, k its equations and ``dof`` the
    level's degrees of freedom (:func:`level_dof`); chi2_k (:func:`row_limit`) for a level known
    exactly (``dof`` infinite). F(k, nu) from s ~ level chi2_k and the estimate ~ level chi2_nu / nu."""
    if not np.isfinite(dof):
        return row_limit(valid, n_rows, alpha)
    k = equations(valid)
    keep = np.exp(np.log1p(-alpha) / max(n_rows, 1))    # each row's chance to pass, (1 - alpha)^(1/n)
    return k * special.fdtri(k, max(dof, 1.0), keep)


def beyond(s: np.ndarray, valid: np.ndarray, level: float, n_rows: int, alpha: float = FAMILY_ALPHA,
           dof: float = np.inf) -> np.ndarray:
    """(N,) rows whose statistic no noise explains at ``level`` estimated with ``dof`` degrees of
    freedom (:func:`limit`; a statistic that is not a number is beyond)."""
    return ~(s / level <= limit(valid, n_rows, alpha, dof))


def pose_keys(campaign: Campaign) -> np.ndarray:
    """(N,) one integer per pose read: command and tool (:func:`repeat_groups`), tool point,
    target, station, instrument."""
    cols = np.c_[repeat_groups(campaign)[0], _target_kind(campaign)]   # the kind ranks its fields in order
    return np.asarray(np.unique(cols, axis=0, return_inverse=True)[1]).ravel()


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
            if (float(d @ d) / (2 * level) <= special.chdtri(max(int(both.sum()), 1), AGREE_P)
                    or np.linalg.norm(d) < shared):
                out.append(int(i))
                break
    return np.array(out, int)


def _local_fit(x: np.ndarray, r: np.ndarray, at: np.ndarray, h: float) -> np.ndarray:
    """(len(at), 3) the local linear fit at rows ``at`` of the residuals ``r`` (N,3) of the
    other rows along ``x`` (N,), Gaussian kernel of sigma ``h`` (the row itself left out;
    rows without a residual, nan, carry no weight); a kernel mean where the neighbours
    stand at one position (an axis measured at a few positions)."""
    ok = np.isfinite(r).all(axis=1)
    out = np.full((len(at), 3), np.nan)
    for n, i in enumerate(at):
        dx = x - x[i]
        k = np.exp(-0.5 * (dx / h) ** 2) * ok
        k[i] = 0.0
        if k.sum() <= 1e-12:
            continue
        s0, s1, s2 = k.sum(), k @ dx, k @ dx**2
        var = s2 / s0 - (s1 / s0) ** 2
        rk = np.where(ok[:, None], r, 0.0) * k[:, None]
        m0, m1 = rk.sum(axis=0), (rk * dx[:, None]).sum(axis=0)
        out[n] = m0 / s0 if var < (0.1 * h) ** 2 else (s2 * m0 - s1 * m1) / (s0 * s2 - s1**2)
    return out


def _coordinates(machine: Machine, campaign: Campaign) -> list[tuple[str, str, np.ndarray, np.ndarray]]:
    """(name, unit, user position, position as a share of its span) of every axis, and the
    measurement order (the rows' file lines)."""
    out = []
    for a in machine.axes:
        x = np.asarray(a.to_user(campaign.q[:, a.index]), float)
        out.append((a.name, a.unit, x, (x - x.min()) / max(float(np.ptp(x)), 1e-300)))
    lines = np.asarray(campaign.lines, float)
    order = np.arange(len(campaign), dtype=float)
    out.append(("file lines", "", lines, order / max(len(campaign) - 1, 1)))
    return out


def spread(n: int, rows: np.ndarray, values: np.ndarray) -> np.ndarray:
    """(n, 3) ``values`` of ``rows`` in their places, nan elsewhere (residuals of the rows a model saw)."""
    out = np.full((n, 3), np.nan)
    out[rows] = values
    return out


def crowded_regions(machine: Machine, campaign: Campaign, flagged: np.ndarray, r: np.ndarray,
                    excess: np.ndarray | None = None) -> list[dict]:
    """Regions the model does not fit: flagged rows whose neighbours share their misfit
    along one axis or in measurement order (module text; ``r`` (N,3) every row's residual
    [m], nan where there is none), at least :data:`REGION_MIN` along the same coordinate:
    [{"axis", "from", "to", "unit", "rows", "rows_there"}], the coordinate explaining
    most rows first; the rows a coordinate explains are not offered to the next. Then the
    rows whose neighbours in joint space share their misfit (:func:`shared_nearby`, ``excess``
    (N,) each row's statistic over its limit) as one region more ("near": True)."""
    left = np.asarray(flagged, int)
    r = np.asarray(r, float)
    size = np.linalg.norm(np.where(np.isfinite(r), r, 0.0), axis=1)
    coords = _coordinates(machine, campaign)
    out = _crowded_along(coords, left, r, size)
    left = np.setdiff1d(left, [v for g in out for v in g["rows"]])
    near = left[shared_nearby(campaign, left, flagged, r, excess)] if left.size else left
    if near.size:
        out.append(_near_region(machine, campaign, near))
    return out


def _crowded_along(coords: list, left: np.ndarray, r: np.ndarray, size: np.ndarray) -> list[dict]:
    """:func:`crowded_regions` along one coordinate at a time (``coords`` of :func:`_coordinates`)."""
    out = []
    while left.size >= REGION_MIN:
        best = None
        for name, unit, x, u in coords:
            shared = np.zeros(left.size, bool)
            for h in BANDWIDTHS:
                shared |= np.linalg.norm(r[left] - _local_fit(u, r, left, h), axis=1) <= SHARED * size[left]
            if best is None or shared.sum() > best[0].sum():
                best = (shared, name, unit, x)
        shared, name, unit, x = best
        if shared.sum() < REGION_MIN:
            break
        rows = left[shared]
        lo, hi = float(x[rows].min()), float(x[rows].max())
        out.append({"axis": name, "from": lo, "to": hi, "unit": unit, "rows": [int(v) for v in rows],
                    "rows_there": int(((x >= lo) & (x <= hi)).sum())})
        left = left[~shared]
    return out


def shared_nearby(campaign: Campaign, rows: np.ndarray, flagged: np.ndarray, r: np.ndarray,
                  excess: np.ndarray | None = None) -> np.ndarray:
    """(len(rows),) bool: the rows whose neighbours in joint space share their misfit, each axis
    scaled by its measured travel. The nearest neighbours are readings of the same command at
    another visit (another tool or target read at another time: a reading error does not come
    back), their mean residual the correction there; other targets of the same visit are not
    independent of the row (a tracker that moved moves them all). Without those, a local linear
    fit of the residuals ``r`` (N,3) [m] of other commands that are not ``flagged`` themselves (a
    cluster of gross errors does not vouch for its own rows), Gaussian kernel, its width the
    distance to the :data:`NEAR_COMMANDS` x (axes + 1)-th nearest command, the prediction no larger
    than the largest residual among the neighbours within it. Shared: what the correction
    leaves of the row's statistic is within its limit (``excess`` (N,), the statistic over the
    limit: the share left at most 1 / sqrt(excess)), or, where no statistic is given, at most
    :data:`SHARED` of the residual."""
    q = np.asarray(campaign.q, float)
    span = np.ptp(q, axis=0)
    u = q[:, span > 0] / span[span > 0]
    cmd = poses(campaign)[0]
    visit = np.cumsum(np.r_[0, cmd[1:] != cmd[:-1]])
    kind = _target_kind(campaign)
    finite = np.isfinite(r).all(axis=1)
    ok = finite.copy()
    ok[np.asarray(flagged, int)] = False
    size = np.linalg.norm(np.where(finite[:, None], r, 0.0), axis=1)
    out = np.zeros(len(rows), bool)
    k = NEAR_COMMANDS * (u.shape[1] + 1)
    for n, i in enumerate(rows):
        again = np.flatnonzero(finite & (cmd == cmd[i]) & (visit != visit[i]))
        again = again[kind[again] == kind[i]] if np.any(kind[again] == kind[i]) else again
        pred = r[again].mean(axis=0) if again.size else _local_linear(u, r, i, np.flatnonzero(ok & (cmd != cmd[i])),
                                                                     cmd, k, size)
        if pred is None or size[i] <= 0:
            continue
        left = float(np.linalg.norm(r[i] - pred)) / size[i]
        e = np.nan if excess is None else float(excess[i])
        out[n] = left <= (1.0 / np.sqrt(e) if np.isfinite(e) and e > 0 else SHARED)
    return out


def _target_kind(campaign: Campaign) -> np.ndarray:
    """(N,) one integer per kind of reading: tool point, target, station and instrument (the
    pose's key without its command and tool): a tool reading is compared with tool readings."""
    _, tgt = np.unique(campaign.target.astype(str), return_inverse=True)
    _, ins = np.unique(campaign.instrument.astype(str), return_inverse=True)
    cols = np.c_[campaign.point, np.asarray(tgt).ravel(), campaign.station, np.asarray(ins).ravel()].astype(float)
    return np.asarray(np.unique(cols, axis=0, return_inverse=True)[1]).ravel()


def _local_linear(u: np.ndarray, r: np.ndarray, i: int, nb: np.ndarray, cmd: np.ndarray, k: int,
                  size: np.ndarray) -> np.ndarray | None:
    """The local linear fit at row ``i`` of the residuals ``r`` of rows ``nb`` in the scaled joint
    space ``u`` (:func:`shared_nearby`); None with fewer than ``k`` commands."""
    if nb.size == 0:
        return None
    dx = u[nb] - u[i]
    d = np.linalg.norm(dx, axis=1)
    per_cmd = np.full(cmd.max() + 1, np.inf)
    np.minimum.at(per_cmd, cmd[nb], d)
    near = np.sort(per_cmd[np.isfinite(per_cmd)])
    if near.size < k:
        return None
    h = float(near[k - 1])
    sw = np.sqrt(np.exp(-0.5 * (d / h) ** 2))
    X = np.hstack([np.ones((nb.size, 1)), dx])
    pred = np.linalg.lstsq(X * sw[:, None], r[nb] * sw[:, None], rcond=None)[0][0]
    cap = float(size[nb][d <= h].max())
    return pred * min(1.0, cap / max(float(np.linalg.norm(pred)), 1e-300))


def _near_region(machine: Machine, campaign: Campaign, rows: np.ndarray) -> dict:
    """The region of ``rows`` whose neighbours in joint space share their misfit: the axis
    along which they lie closest (share of its measured travel) and, in "span", every axis."""
    coords = _coordinates(machine, campaign)[:-1]
    spans = [(float(np.ptp(u[rows])), name, unit, x) for name, unit, x, u in coords]
    _, name, unit, x = min(spans, key=lambda v: v[0])
    lo, hi = float(x[rows].min()), float(x[rows].max())
    every = ", ".join(_span(nm, un, float(xx[rows].min()), float(xx[rows].max())) for nm, un, xx, _ in coords)
    return {"axis": name, "from": lo, "to": hi, "unit": unit, "rows": [int(v) for v in rows],
            "rows_there": int(((x >= lo) & (x <= hi)).sum()), "near": True, "span": every}


def judge(machine: Machine, campaign: Campaign, s: np.ndarray, w: np.ndarray, valid: np.ndarray,
          n_rows: int | None = None, alpha: float = FAMILY_ALPHA,
          r: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """(gross errors, misfit rows, regions): rows beyond the noise (``s`` the
    statistics, ``w`` the whitened residuals of ``campaign``'s rows, ``r`` their metric
    residuals [m], default ``w``), less those a repeat reading agrees with and those whose
    neighbours share their misfit (both misfit)."""
    level, dof = robust_level(s, valid), level_dof(valid)
    flagged = np.flatnonzero(beyond(s, valid, level, n_rows or len(s), alpha, dof))
    if flagged.size == 0:
        return flagged, flagged, []
    repeat = agreeing_repeats(campaign, flagged, w, valid, level)
    rest = np.setdiff1d(flagged, repeat)
    excess = s / (level * limit(valid, n_rows or len(s), alpha, dof))
    regions = crowded_regions(machine, campaign, flagged, w if r is None else r, excess)
    in_region = np.array(sorted({v for g in regions for v in g["rows"]}), int)
    alone = np.setdiff1d(repeat, in_region)
    if alone.size:
        regions.append({"axis": "", "from": np.nan, "to": np.nan, "unit": "", "rows": [int(v) for v in alone],
                        "rows_there": int(alone.size)})
    gross = np.setdiff1d(rest, in_region)
    return gross, np.setdiff1d(flagged, gross), regions


def _span(name: str, unit: str, lo: float, hi: float) -> str:
    """'X = 10 mm' or 'X 10 to 20 mm'."""
    return (f"{name} = {lo:.6g} {unit}" if lo == hi else f"{name} {lo:.6g} to {hi:.6g} {unit}").rstrip()


def describe_region(g: dict, campaign: Campaign) -> tuple[str, str]:
    """('Z 800 to 1000 mm', 'Z 800 to 1000 mm (12 of the 40 rows there are beyond the
    noise; file lines ...)') for one misfit region: where, and the full account."""
    lines = campaign.lines[np.asarray(g["rows"], int)]
    shown = ", ".join(map(str, lines[:12])) + (" ..." if lines.size > 12 else "")
    if g.get("near"):
        span = f"near {g['span']}"
        return span, (f"{span} ({len(g['rows'])} rows beyond the noise whose neighbours in joint space share their "
                      f"misfit: a local smooth correction fitted without them predicts them; file lines {shown})")
    if not g["axis"]:
        return (f"{len(g['rows'])} repeatedly read rows",
                f"{len(g['rows'])} rows whose repeated readings agree with each other (file lines {shown})")
    span = _span(g["axis"], g["unit"], g["from"], g["to"])
    return span, f"{span} ({len(g['rows'])} of the {g['rows_there']} rows there are beyond the noise; file lines {shown})"
