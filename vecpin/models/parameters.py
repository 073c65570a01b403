"""Model parameters: names, physical quantity, prior standard deviation, priority."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Parameter:
    """One model parameter: ``quantity`` is "length" [m], "angle" [rad] or "ratio";
    ``prior`` is the prior standard deviation (Σ_b of eq. 11), SI; ``order`` is the
    basis order (-1 for offsets, 99 for effects); ``group`` names the function it
    belongs to; ``axis`` and ``label``: the axis whose basis column it multiplies and
    that column's label ("" for offsets and effects)."""

    name: str
    quantity: str
    prior: float
    order: int
    group: str
    axis: str = ""
    label: str = ""


DEFAULT_PRIORS = {"length": 1e-3, "angle": 1e-3, "offset": 5e-3}
