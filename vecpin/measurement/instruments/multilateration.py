"""Multilateration: only the tracker's interferometer range is used, from several
stations (Section 3.4: the limit of the spherical model as the angle variances grow)."""
from __future__ import annotations

import numpy as np

from vecpin.measurement.instruments.base import register
from vecpin.measurement.instruments.tracker import TrackerInstrument


@register
class RangeOnly(TrackerInstrument):
    name = "range"
    n_equations = 1
    description = "tracker range only, several stations (multilateration)"

    def observe(self, x, y):
        Rm, Ry = np.linalg.norm(x, axis=1), np.linalg.norm(y, axis=1)
        H = (y / Ry[:, None])[:, None, :]
        S = (self.noise.tracker.sigma_range(Rm) ** 2)[:, None, None]
        return (Rm - Ry)[:, None], H, S
