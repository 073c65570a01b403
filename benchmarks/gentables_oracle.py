"""What tables estimated from ONE campaign can reach at best (issue 40's *achievable* column).

An oracle that knows everything but the error values: the generator's own prior (every joint's six
error functions are Gaussian-process draws; their kernels, length scales and sizes are read from the
truth), the campaign's noise model (the tracker's spherical noise and the axes' repeatability, per
visit), the true tracker pose, the true tool lengths and the true nests on the table (so their
heights above its face exactly, where vecpin is given them read by a height gauge). From the
campaign's measured points (tool rows and nests, noise and all) it computes the posterior mean of
the error functions (the estimate with the least expected squared error: no method that reads only
the campaign does better on average), the truth linearised in the errors (central differences of
the generator's kinematics). The estimated machine is then given the best table set that exists for
it (the bench's :class:`BestSets`: vecpin's tables and product terms, their values free), judged on
the true machine. vecpin / achievable measures the method; achievable / best what the campaign's
size and noise cost.
"""
from __future__ import annotations

import copy

import numpy as np

from generator.kinematics import table_points, tool_points
from generator.truth import AxisField

GRID = 48          # grid points per error function (linear interpolation between them)
STEP = (1e-6, 1e-6)   # finite-difference steps: errors [m or rad], axis positions [m or rad]


class GridField:
    """An error function given on a grid (linear interpolation; periodic per turn if ``period``)."""

    def __init__(self, x: np.ndarray, y: np.ndarray, period: float | None):
        self.x, self.y, self.period = x, y, period

    def __call__(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if self.period is not None:
            return np.interp(np.mod(x, self.period), self.x, self.y, period=self.period)
        return np.interp(x, self.x, self.y)


def _grid(f) -> tuple[np.ndarray, float | None]:
    if f.period is not None:
        return np.linspace(0.0, f.period, GRID, endpoint=False), f.period
    return np.linspace(f.lo, f.hi, GRID), None


def _weights(x: np.ndarray, grid: np.ndarray, period: float | None) -> np.ndarray:
    """(N, GRID) linear-interpolation weights of positions x on the grid."""
    eye = np.eye(len(grid))
    if period is not None:
        return np.stack([np.interp(np.mod(x, period), grid, e, period=period) for e in eye], axis=1)
    return np.stack([np.interp(x, grid, e) for e in eye], axis=1)


def _kernel(f, grid: np.ndarray) -> np.ndarray:
    """The generator's prior covariance of one error function on the grid (its kernel x RMS^2)."""
    d = grid[:, None] - grid[None, :]
    if f.period is not None:
        return f.rms ** 2 * np.exp(-2.0 * np.sin(d / 2.0) ** 2 / f.length ** 2)
    return f.rms ** 2 * np.exp(-0.5 * (d / f.length) ** 2)


def _points(camp, q: dict, errors: dict, qa: dict | None = None) -> np.ndarray:
    """(rows, 3) the campaign's points in the base frame (tools and nests) for given errors [m]."""
    kw = dict(errors=errors, q_actual=qa)
    pts = tool_points(camp.layout, q, camp.rows.tool_m, **kw)
    nest = camp.rows.nest >= 0
    if nest.any():
        local = camp.nests_m[np.clip(camp.rows.nest, 0, None)]
        pts[nest] = table_points(camp.layout, q, local, **kw)[nest]
    return pts


def _const(k: int, h: float):
    return lambda q: np.tile(np.eye(6)[k] * h, (len(next(iter(q.values()))), 1))


def _tracker_cov(camp) -> np.ndarray:
    """(rows, 3, 3) the tracker's noise covariance per row in the base frame [m^2] (spherical noise)."""
    r = camp.tracker[:3, :3]
    trk = camp.to_tracker(_points(camp, camp.row_commands(), {}))
    rng = np.linalg.norm(trk, axis=1)
    az, el = np.arctan2(trk[:, 1], trk[:, 0]), np.arcsin(trk[:, 2] / rng)
    e_r = trk / rng[:, None]
    e_az = np.stack([-np.sin(az), np.cos(az), 0 * az], axis=1)
    e_el = np.cross(e_r, e_az)
    s_r = camp.noise["range_m"] + 1e-6 * rng
    s_t = rng * camp.noise["angle_rad"]
    cov = (s_r[:, None, None] ** 2 * e_r[:, :, None] * e_r[:, None, :]
           + (s_t * np.cos(el))[:, None, None] ** 2 * e_az[:, :, None] * e_az[:, None, :]
           + s_t[:, None, None] ** 2 * e_el[:, :, None] * e_el[:, None, :])
    return np.einsum("ij,njk,lk->nil", r, cov, r)


def _whitener(camp) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per visit (rows, inverse Cholesky factor of their readings' covariance): the tracker's noise plus
    every axis' repeatability, which the rows of one visit share [1/m]."""
    q = camp.row_commands()
    trk = _tracker_cov(camp)
    grads = []
    for name, s in camp.noise["sigma"].items():
        up = {k: v + (STEP[1] if k == name else 0.0) for k, v in q.items()}
        dn = {k: v - (STEP[1] if k == name else 0.0) for k, v in q.items()}
        grads.append(s * (_points(camp, q, {}, up) - _points(camp, q, {}, dn)) / (2 * STEP[1]))
    out = []
    for v in np.unique(camp.rows.visit):
        rows = np.flatnonzero(camp.rows.visit == v)
        cov = np.zeros((3 * len(rows), 3 * len(rows)))
        for i, r in enumerate(rows):
            cov[3 * i:3 * i + 3, 3 * i:3 * i + 3] = trk[r]
        for g in grads:
            cov += np.outer(g[rows].ravel(), g[rows].ravel())
        out.append((rows, np.linalg.inv(np.linalg.cholesky(cov))))
    return out


def estimated_campaign(camp):
    """A copy of the campaign whose error functions are the oracle's posterior means (see module):
    the weights of every function on its grid are L z with L L^T its prior covariance, z standard
    normal a priori; z's posterior mean by whitened least squares with a unit ridge."""
    q = camp.row_commands()
    r, o = camp.tracker[:3, :3], camp.tracker[:3, 3]
    y = (camp.measured @ r.T + o - _points(camp, q, {})).reshape(len(q[next(iter(q))]), 3)
    cols, grids = [], []
    for name, fld in camp.fields.items():
        for k, f in enumerate(fld.parts):
            grid, period = _grid(f)
            up = _points(camp, q, {name: [_const(k, STEP[0])]})
            dn = _points(camp, q, {name: [_const(k, -STEP[0])]})
            g = (up - dn) / (2 * STEP[0])                                   # (rows, 3)
            w, v = np.linalg.eigh(_kernel(f, grid))
            L = v * np.sqrt(np.clip(w, 0.0, None))
            cols.append(np.einsum("nd,ng->ndg", g, _weights(q[name], grid, period) @ L))
            grids.append((name, k, grid, period, L))
    A = np.concatenate(cols, axis=2)                                         # (rows, 3, params)
    Aw, yw = [], []
    for rows, W in _whitener(camp):
        Aw.append(W @ A[rows].reshape(3 * len(rows), -1))
        yw.append(W @ y[rows].ravel())
    Aw, yw = np.vstack(Aw), np.concatenate(yw)
    z = np.linalg.solve(Aw.T @ Aw + np.eye(Aw.shape[1]), Aw.T @ yw)
    est = copy.copy(camp)
    parts: dict[str, list] = {name: [None] * 6 for name in camp.fields}
    size = GRID
    for i, (name, k, grid, period, L) in enumerate(grids):
        parts[name][k] = GridField(grid, L @ z[i * size:(i + 1) * size], period)
    est.fields = {name: AxisField(name, p) for name, p in parts.items()}
    return est
