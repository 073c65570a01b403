"""Distance statistics of measured points, overall and per tool length."""
from __future__ import annotations

import numpy as np

from vecpin.units import MM_PER_M, norm_mm


def distance_stats(d: np.ndarray, tool: np.ndarray) -> dict:
    """n/mean/max/RMS of distances d (any unit), overall and per tool length [m]."""
    out = {"all": _stats(d)}
    for L in np.unique(np.round(tool, 9)):
        out[f"tool {L * MM_PER_M:.3f} mm"] = _stats(d[np.isclose(tool, L, atol=1e-7)])
    return out


def residual_stats(err: np.ndarray, tool: np.ndarray) -> dict:
    """Mean/max/RMS of |err| [mm] overall and per tool length; err (N,3) in m."""
    return distance_stats(norm_mm(err), tool)


def _stats(d: np.ndarray) -> dict:
    d = np.asarray(d, float)
    if d.size == 0:
        return {"n": 0, "mean": float("nan"), "max": float("nan"), "rms": float("nan")}
    return {"n": int(d.size), "mean": float(d.mean()), "max": float(d.max()), "rms": float(np.sqrt((d**2).mean()))}
