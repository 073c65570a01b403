"""Repeatability of a machine from repeated measurements (Paper I eq. 22; Section 2.4,
Table 2.8).

A command measured several times with the same tool is a repeated point. Its
repeatability readings are the distances of each measurement from the mean of its
repeats (eq. 22): ``r_ij = |mean_k p_ik - p_ij|``. Table 2.8 reports the mean, max and
standard deviation of these readings over two horizons:

* short term: repeats close together in time (the seed: nine points four times in 19
  minutes, 0.7 thou mean) - repeats of a point are split into sessions wherever more
  than ``session_gap`` passes between two of them, and eq. 22 is taken within each
  session;
* long term: all repeats of a point over the whole campaign (the seed: 287 points
  over 5.8 hours, 2.1 thou mean, with 4 °F of temperature change), for points measured
  in at least two sessions.

Also here: the drift of repeated points with time and temperature (pooled linear
trend of each point's deviations), and the repeatability the instrument alone would
show at the campaign's range.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.measurement.campaign import Campaign
from vecpin.measurement.poses import unique_rows
from vecpin.measurement.tracker import TrackerNoise

SESSION_GAP_S = 1800.0  # s: repeats further apart than this belong to different sessions


READING_RAD = 3.5e-4   # rad (0.02°): a robot's joint readings of one pose read twice differ by up to 0.013° (UR10)
READING_M = 1e-6       # m: a linear axis' readings of one position
EXACT = 1e-9           # m, rad: commands compared exactly (a file of commands repeats them to the digit)


def reading_groups(q: np.ndarray, tool: np.ndarray | None = None, rotary: np.ndarray | None = None,
                   rad: float = READING_RAD) -> np.ndarray:
    """(N,) one label per pose read: rows whose axis values ``q`` (N, n) [m, rad] agree
    on every axis and whose ``tool`` lengths [m] agree to 1 nm share a label. ``rotary``
    (n,) True on the rotary axes: the values are readings (a robot's joint readings
    repeat to the encoders' resolution and the servo's settling), compared within
    :data:`READING_RAD` (``rad``) on a rotary axis and :data:`READING_M` on a linear one, chained
    (a row joins the group of any row that close); None: commands, compared to 1 nm /
    1 nrad (:attr:`Campaign.rotary` says which a campaign holds)."""
    q = np.asarray(q, float)
    if not len(q):
        return np.zeros(0, int)
    tol = np.full(q.shape[1], EXACT) if rotary is None else np.where(np.asarray(rotary, bool), rad, READING_M)
    t = np.zeros(len(q)) if tool is None else np.asarray(tool, float)
    # rows read again to the digit (commands, a pose read many times) are one point before the search
    rows, back = unique_rows(np.c_[q, t])
    pairs = close_pairs(rows[:, :-1] / tol)
    pairs = pairs[np.abs(rows[pairs[:, 0], -1] - rows[pairs[:, 1], -1]) <= EXACT]
    n = len(rows)
    if len(pairs):
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components
        graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        comp = connected_components(graph, directed=False)[1][np.asarray(back).ravel()]
    else:   # every pose its own (a campaign of distinct commands: no graph, no scipy.sparse to import)
        comp = np.asarray(back).ravel()
    _, first, label = np.unique(comp, return_index=True, return_inverse=True)
    rank = np.empty(len(first), int)
    rank[np.argsort(first)] = np.arange(len(first))
    return rank[np.asarray(label).ravel()]   # numbered in the order the poses are first read


def close_pairs(x: np.ndarray) -> np.ndarray:
    """(M, 2) the pairs i < j of rows of ``x`` (n, d) within 1 of each other on every
    coordinate (what ``scipy.spatial.cKDTree(x).query_pairs(1.0, p=inf)`` gives, in some
    order): the rows sorted along the coordinate of widest spread, each compared with the
    rows after it within 1 on that one; a k-d tree only when that leaves many to compare."""
    n = len(x)
    if n < 2:
        return np.zeros((0, 2), int)
    key = x[:, int(np.argmax(np.ptp(x, axis=0)))] if x.shape[1] else np.zeros(n)
    order = np.argsort(key, kind="stable")
    xs, key = x[order], key[order]
    count = np.searchsorted(key, key + 1.0, side="right") - np.arange(n) - 1
    total = int(count.sum())
    if total > 8 * n + 1000:
        from scipy.spatial import cKDTree
        return cKDTree(x).query_pairs(1.0, p=np.inf, output_type="ndarray")
    i = np.repeat(np.arange(n), count)
    j = i + 1 + np.arange(total) - np.repeat(np.cumsum(count) - count, count)
    near = np.all(np.abs(xs[i] - xs[j]) <= 1.0, axis=1)
    a, b = order[i[near]], order[j[near]]
    return np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)


def repeat_groups(campaign: Campaign) -> tuple[np.ndarray, np.ndarray]:
    """(group id per row, rows per group): rows of one pose read again with the same tool
    share a group (:func:`reading_groups`)."""
    group = reading_groups(campaign.q, campaign.tool, campaign.rotary)
    return group, np.bincount(group)


def eq22(p: np.ndarray) -> np.ndarray:
    """eq. 22 for one point: distances [same unit] of its measurements p (Nt,3) from their mean."""
    return np.linalg.norm(p - p.mean(axis=0), axis=1)


@dataclass
class RepeatabilityStats:
    """One row of Table 2.8: over ``points`` repeated points and ``readings`` eq. 22
    readings, ``mean``, ``max``, ``std`` [m], over ``hours`` [h] (the longest time
    span of the repeats used); ``sessions``: the repeat sessions used."""

    kind: str
    points: int
    readings: int
    mean: float
    max: float
    std: float
    hours: float
    readings_m: np.ndarray

    def row(self, unit: str = "mm") -> str:
        s = 1e3 if unit == "mm" else 1e3 / 0.0254
        return (f"  {self.kind:<12s} {self.mean * s:9.4f} {self.max * s:9.4f} {self.std * s:9.4f} {self.hours:8.2f} "
                f"{self.points:7d} {self.readings:8d}")


def _times(campaign: Campaign) -> tuple[np.ndarray, bool]:
    t = campaign.time
    return (np.asarray(t, float), True) if t is not None else (np.arange(len(campaign), dtype=float), False)


def sessions(campaign: Campaign, session_gap: float = SESSION_GAP_S) -> np.ndarray:
    """Session number per row within its repeat group (time gaps > ``session_gap`` [s]
    start a new session); without a time column every group is one session."""
    group, _ = repeat_groups(campaign)
    t, has_time = _times(campaign)
    out = np.zeros(len(campaign), int)
    if not has_time:
        return out
    for g in np.unique(group):
        rows = np.flatnonzero(group == g)
        rows = rows[np.argsort(t[rows], kind="stable")]
        out[rows] = np.r_[0, np.cumsum(np.diff(t[rows]) > session_gap)]
    return out


def repeatability(campaign: Campaign, session_gap: float = SESSION_GAP_S) -> dict[str, RepeatabilityStats | None]:
    """{'short': ..., 'long': ...} Table 2.8 rows of the campaign's repeated points
    (tracker rows of station 0); None where the campaign has no such repeats."""
    c = campaign.primary()
    group, counts = repeat_groups(c)
    sess = sessions(c, session_gap)
    t, _ = _times(c)
    short_r, long_r, short_h, long_h = [], [], 0.0, 0.0
    n_short = n_long = 0
    for g in np.flatnonzero(counts > 1):
        rows = np.flatnonzero(group == g)
        used = False
        for s in np.unique(sess[rows]):
            r = rows[sess[rows] == s]
            if len(r) > 1:
                short_r.append(eq22(c.xyz[r]))
                short_h = max(short_h, float(np.ptp(t[r])) / 3600)
                used = True
        n_short += used
        if len(np.unique(sess[rows])) > 1:
            long_r.append(eq22(c.xyz[rows]))
            long_h = max(long_h, float(np.ptp(t[rows])) / 3600)
            n_long += 1

    def stats(kind, parts, n, hours):
        if not parts:
            return None
        r = np.concatenate(parts)
        return RepeatabilityStats(kind, n, r.size, float(r.mean()), float(r.max()), float(r.std()), hours, r)
    return {"short": stats("short term", short_r, n_short, short_h), "long": stats("long term", long_r, n_long, long_h)}


@dataclass
class Drift:
    """Pooled linear drift of repeated points: ``per_hour`` [m/h] (length of the 3D
    trend), ``per_kelvin`` [m/K] or None, ``hours`` and ``temperature_range`` [K] of the
    campaign (None without a temperature column)."""

    per_hour: float
    per_kelvin: float | None
    hours: float
    temperature_range: float | None


def drift(campaign: Campaign) -> Drift | None:
    """Drift of the repeated points with time (and temperature): each point's readings
    minus their mean, regressed on time (temperature) minus its mean, pooled."""
    c = campaign.primary()
    if c.time is None:
        return None
    group, counts = repeat_groups(c)
    t = np.asarray(c.time, float)
    T = None if c.temperature is None else np.asarray(c.temperature, float)
    dp, dt, dT = [], [], []
    for g in np.flatnonzero(counts > 1):
        r = np.flatnonzero(group == g)
        dp.append(c.xyz[r] - c.xyz[r].mean(axis=0))
        dt.append(t[r] - t[r].mean())
        if T is not None:
            dT.append(T[r] - T[r].mean())
    hours = float(np.ptp(t)) / 3600
    Trange = None if T is None else float(np.ptp(T))
    if not dp:
        return Drift(float("nan"), None, hours, Trange)
    P, tt = np.vstack(dp), np.concatenate(dt) / 3600
    rate = (tt @ P) / max(tt @ tt, 1e-30)
    per_k = None
    if T is not None:
        TT = np.concatenate(dT)
        if TT @ TT > 1e-12:
            per_k = float(np.linalg.norm((TT @ P) / (TT @ TT)))
    return Drift(float(np.linalg.norm(rate)), per_k, hours, Trange)


def instrument_repeatability(campaign: Campaign, noise: TrackerNoise | None = None, repeats: int = 4) -> float:
    """Mean eq. 22 reading [m] the tracker alone would give for the campaign's points
    measured ``repeats`` times: per point the noise is Gaussian with the range sigma and
    the two angle sigmas times the range (the azimuth one times sin(zenith)), in the
    tracker's own frame; eq. 22 scales its covariance by (1 - 1/Nt). E|r| is taken over a
    fixed set of 4000 standard normal draws (seed 0), averaged over the points."""
    from vecpin.measurement.tracker import cartesian_to_spherical
    noise = noise or TrackerNoise()
    s = cartesian_to_spherical(campaign.primary().xyz)
    sig = noise.sigma_spherical(s[:, 0]) * np.c_[np.ones(len(s)), s[:, 0], s[:, 0] * np.sin(s[:, 1])]
    z = np.random.default_rng(0).standard_normal((4000, 3))
    r = np.linalg.norm(sig[:, None, :] * z[None, :, :], axis=2).mean(axis=1)
    return float(np.sqrt(1 - 1 / repeats) * r.mean())
