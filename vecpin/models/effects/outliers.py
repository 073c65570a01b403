"""Gross errors: rows whose residual no noise explains (a broken beam, a mistyped row)."""
from __future__ import annotations

import numpy as np

from vecpin.models.effects.base import Effect, Key, register_effect
from vecpin.units import M_PER_MM


@register_effect
class Outliers(Effect):
    """No model term: the diagnosis flags the rows and leaves them out.

    Simulated as a fraction of rows with gross errors of 1-2 x ``strength``."""

    name = "outliers"
    summary = "gross errors on a few rows (flagged and left out, not a model term)"
    flags_rows = True
    keys = (Key("fraction", 0.01, "fraction", "share of rows with a gross error", lo=1e-6, hi=0.5),)

    def __init__(self, machine, axes=(), **kw):
        super().__init__(machine, axes, **kw)
        self.outlier_rows: np.ndarray | None = None

    def simulate_gross(self, y):
        rng = self._rng()
        n = len(y)
        k = max(1, int(round(self.options.get("fraction", 0.01) * n)))
        rows = np.sort(rng.choice(n, k, replace=False))
        self.outlier_rows = rows
        v = rng.normal(size=(k, 3))
        v = v / np.linalg.norm(v, axis=1)[:, None] * self.strength_mm * M_PER_MM * rng.uniform(1.0, 2.0, (k, 1))
        out = y.copy()
        out[rows] += v
        return out

    def simulation_dict(self) -> dict:
        d = super().simulation_dict()
        if self.outlier_rows is not None:
            d["outlier_rows"] = [int(r) for r in self.outlier_rows]
        return d

    def advice(self, values, std):
        return ["outliers: re-measure the flagged rows (or check the tracker log for a broken beam); they are left "
                "out of the fit"]
