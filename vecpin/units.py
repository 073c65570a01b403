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
