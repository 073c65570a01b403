"""Units: SI inside (m, rad), millimetres and degrees in every file a user touches.

One place for the conversions, so a reader sees ``to_mm(err)`` rather than ``err * 1e3``.
"""
from __future__ import annotations

import math

import numpy as np

M_PER_MM = 1e-3
MM_PER_M = 1e3
UM_PER_M = 1e6
RAD_PER_DEG = math.pi / 180.0
DEG_PER_RAD = 180.0 / math.pi


def to_mm(value_m):
    """Metres -> millimetres (scalars or arrays)."""
    return np.multiply(value_m, MM_PER_M)


def from_mm(value_mm):
    """Millimetres -> metres (scalars or arrays)."""
    return np.multiply(value_mm, M_PER_MM)




def norm_mm(err_m: np.ndarray) -> np.ndarray:
    """Row lengths [mm] of (N,3) vectors in metres (a distance per measured point)."""
    return np.linalg.norm(np.asarray(err_m, float), axis=-1) * MM_PER_M


# user unit and SI per user unit, for each physical quantity of a model parameter
QUANTITY_UNITS = {"length": ("mm", M_PER_MM), "angle": ("deg", RAD_PER_DEG), "ratio": ("ratio", 1.0)}
SI_PER_UNIT = {"mm": M_PER_MM, "deg": RAD_PER_DEG, "ratio": 1.0}



def unit_slip(value_mm: float, scale_mm: float, factor: float = 3.0) -> bool:
    """True when a length ``value_mm`` [mm] was likely typed in metres, judged against a length
    of the same kind ``scale_mm`` [mm] (the model's tools, an axis' travel): the value is far
    below the scale (1/20 of it or less) but the value times 1000 lies within ``factor`` of it.
    False for 0 and for every value plausible in mm."""
    v, s = abs(float(value_mm)), abs(float(scale_mm))
    if not (np.isfinite(v) and np.isfinite(s)) or v == 0.0 or s == 0.0 or v > s / 20.0:
        return False
    return s / factor <= v * MM_PER_M <= s * factor


def slip_text(value_mm: float, scale_mm: float, what: str) -> str | None:
    """``"0.21488 mm is about 1/1000 of <what> 214.9 mm: metres? ..."`` when :func:`unit_slip`
    says so, else None."""
    if not unit_slip(value_mm, scale_mm):
        return None
    return (f"{value_mm:g} mm is about 1/1000 of {what} {scale_mm:.1f} mm: metres? Give it in mm "
            f"({value_mm * MM_PER_M:g} mm if it was in metres)")
