"""One colour scale per quantity across the figures of one run.

A quantity (the volumetric error at the tool tip, in mm) is drawn in one colormap with
one set of limits in every figure of a run: the report's grid plots before and after the
tables, its 3D scene's groups (uncompensated errors, residuals, the error the tables
leave) and the scene ``vecpin view`` writes. A reader compares colours across figures,
so a colour must mean the same size everywhere; the limits span the largest value any
figure of the run draws (the uncompensated error, as a rule), never a figure's own.
"""
from __future__ import annotations

from dataclasses import dataclass

import matplotlib
import numpy as np

TIP_ERROR = "tip error"      # the volumetric error at the tool tip (3D length), mm
TIP_ERROR_CMAP = "turbo"     # blue 0 .. red at the top


@dataclass(frozen=True)
class ColourScale:
    """The colour scale of ``quantity``: ``cmap`` from 0 (its first colour) to ``top``
    [``unit``] (its last); values above ``top`` take the last colour."""

    quantity: str
    unit: str
    top: float
    cmap: str = TIP_ERROR_CMAP

    @property
    def limits(self) -> tuple[float, float]:
        return 0.0, self.top

    def rgb(self, values: np.ndarray) -> np.ndarray:
        """(3, N) RGB in [0, 1] of ``values`` [unit]."""
        cmap = matplotlib.colormaps[self.cmap]
        return np.asarray(cmap(np.clip(np.asarray(values, float) / max(self.top, 1e-12), 0, 1)))[:, :3].T

    def caption(self) -> str:
        return f"colour: {self.quantity} 0 .. {self.top:.3f} {self.unit} ({self.cmap} colormap)"

    def as_dict(self) -> dict:
        return {"quantity": self.quantity, "unit": self.unit, "cmap": self.cmap, "limits": list(self.limits)}


def tip_error_scale(*sizes_mm: np.ndarray) -> ColourScale:
    """The tip error's scale spanning every array of sizes [mm] a run draws."""
    top = max((float(np.max(s)) for s in sizes_mm if np.size(s)), default=0.0)
    return ColourScale(TIP_ERROR, "mm", top if top > 0 else 1e-6)


__all__ = ["ColourScale", "tip_error_scale", "TIP_ERROR", "TIP_ERROR_CMAP"]
