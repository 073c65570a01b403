"""Measurement order and approach direction.

The order keeps axis travel short: the time of a move is that of the slowest axis,
``max_k |dq_k| / v_k`` (axes move together; ``v_k`` the rapid speed of axis k [m/s or
rad/s], so rotary and linear axes are weighed by the time they take). A nearest-neighbour
tour is improved by 2-opt moves (reversing a stretch of the tour) until none shortens it.

Every point is approached from the same side on every axis (``below``: from the
negative side, the usual way to take backlash out of the reading), or ``above``, or
``both`` (each point twice, from below then from above, to measure backlash), or
``none`` (straight from the previous point).
"""
from __future__ import annotations

import numpy as np

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.units import M_PER_MM

APPROACHES = ("below", "above", "both", "none")


def axis_speeds(machine: Machine, rapid_mm_min: float | None = None, rapid_deg_min: float | None = None) -> np.ndarray:
    """(n,) rapid speeds [m/s, rad/s]: the URDF velocity limits unless given (mm/min, deg/min)."""
    v = np.asarray(machine.model.velocityLimit, float)[[a.idx_q for a in machine.axes]].copy()
    for k, a in enumerate(machine.axes):
        if a.kind == "linear" and rapid_mm_min is not None:
            v[k] = rapid_mm_min * M_PER_MM / 60.0
        if a.kind == "rotary" and rapid_deg_min is not None:
            v[k] = np.radians(rapid_deg_min) / 60.0
    bad = [a.name for a, s in zip(machine.axes, v) if not np.isfinite(s) or s <= 0]
    if bad:
        raise InputError(f"axes {', '.join(bad)} have no positive velocity limit in the URDF: give `rapid_mm_min` "
                         "and `rapid_deg_min`")
    return v


def move_times(a: np.ndarray, b: np.ndarray, speed: np.ndarray) -> np.ndarray:
    """Time [s] of moves a -> b ((..., n) commands [m, rad]): the slowest axis."""
    return np.max(np.abs(np.asarray(b) - np.asarray(a)) / speed, axis=-1)


def travel_time(q: np.ndarray, speed: np.ndarray) -> float:
    """Total move time [s] visiting the commands q (N,n) in order."""
    q = np.asarray(q, float)
    return float(move_times(q[:-1], q[1:], speed).sum()) if len(q) > 1 else 0.0


WINDOW = 400  # points: a longer tour is improved by 2-opt on windows of this many consecutive points


def order_points(q: np.ndarray, speed: np.ndarray, start: np.ndarray | None = None,
                 max_passes: int | None = None, window: int = WINDOW) -> np.ndarray:
    """A short open tour through the commands q (N,n): nearest neighbour from the point
    closest to ``start`` (default: the middle of their span), then 2-opt; a tour longer
    than ``window`` points is improved window by window (each with its ends fixed, in two
    half-overlapping sweeps), so ordering 10,000 commands takes seconds and no N x N
    matrix."""
    q = np.asarray(q, float)
    n = len(q)
    if n <= 2:
        return np.arange(n)
    s0 = q.min(axis=0) * 0.5 + q.max(axis=0) * 0.5 if start is None else np.asarray(start, float)
    cur = int(np.argmin(move_times(q, s0, speed)))
    seen = np.zeros(n, bool)
    tour = [cur]
    seen[cur] = True
    for _ in range(n - 1):
        d = np.where(seen, np.inf, move_times(q, q[cur], speed))
        cur = int(np.argmin(d))
        tour.append(cur)
        seen[cur] = True
    tour = np.array(tour)
    if n <= window:
        return two_opt(tour, move_times(q[:, None, :], q[None, :, :], speed), max_passes)
    for offset in (0, window // 2):
        for a in range(offset, n - 3, window):
            w = tour[a:a + window + 1]  # the first point stays (2-opt keeps it), the last too unless it ends the tour
            D = move_times(q[w][:, None, :], q[w][None, :, :], speed)
            tour[a:a + len(w)] = w[two_opt(np.arange(len(w)), D, max_passes, fixed_end=a + len(w) < n)]
    return tour


def two_opt(tour: np.ndarray, D: np.ndarray, max_passes: int | None = None, fixed_end: bool = False) -> np.ndarray:
    """Improve an open tour by reversing stretches tour[i..j] (1 <= i < j) while that
    shortens it; each pass takes the best reversal (vectorised over all i, j).
    ``fixed_end``: the last point stays last (a window of a longer tour)."""
    p = np.array(tour)
    n = len(p)
    if n < 4:
        return p
    max_passes = max_passes or 20 * n
    I = np.arange(1, n)[:, None]  # noqa: E741 (the 2-opt grid: I, J index the two edges)
    J = np.arange(n)[None, :]
    upper = (J > I) & (J < n - 1) if fixed_end else J > I
    for _ in range(max_passes):
        P = D[np.ix_(p, p)]
        Pz = np.concatenate([P, np.zeros((n, 1))], axis=1)
        e = np.r_[P[np.arange(n - 1), np.arange(1, n)], 0.0]  # edge k -> k+1 (none after the last)
        delta = P[I - 1, J] + Pz[I, np.minimum(J + 1, n)] - e[I - 1] - e[J]
        delta = np.where(upper, delta, np.inf)
        k = int(np.argmin(delta))
        i, j = divmod(k, n)
        if delta.flat[k] >= -1e-12:
            break
        i += 1
        p[i:j + 1] = p[i:j + 1][::-1]
    return p


def approach_steps(machine: Machine, approach_mm: float, approach_deg: float) -> np.ndarray:
    """(n,) approach distance per axis [m, rad]."""
    if not (approach_mm >= 0 and approach_deg >= 0):
        raise InputError(f"`approach_mm` {approach_mm:g}, `approach_deg` {approach_deg:g}: distances >= 0")
    return np.array([approach_mm * M_PER_MM if a.kind == "linear" else np.radians(approach_deg) for a in machine.axes])


def approach_rows(q: np.ndarray, mode: str) -> tuple[np.ndarray, np.ndarray]:
    """Rows of a pass through commands q (N,n) in order: (row -> command index,
    approach sign per row (+1 from below, -1 from above, 0 none)). ``both`` measures
    each command from below, then from above."""
    if mode not in APPROACHES:
        raise InputError(f"`approach` '{mode}': one of {', '.join(APPROACHES)}")
    N = len(q)
    if mode == "both":
        return np.repeat(np.arange(N), 2), np.tile([1, -1], N)
    sign = {"below": 1, "above": -1, "none": 0}[mode]
    return np.arange(N), np.full(N, sign)


def approach_margin(machine: Machine, mode: str, step: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) [m, rad]: the axis space whose approach positions stay inside the limits."""
    lo, hi = machine.lower.copy(), machine.upper.copy()
    if mode in ("below", "both"):
        lo = lo + step
    if mode in ("above", "both"):
        hi = hi - step
    return lo, hi
