"""Laser tracker read in Cartesian coordinates with a static isotropic noise
(``tracker_sigma_mm``; the seed's Paper I treatment)."""
from __future__ import annotations

import numpy as np

from vecpin.measurement.instruments.base import register_instrument
from vecpin.measurement.instruments.tracker import TrackerInstrument


@register_instrument
class CartesianTracker(TrackerInstrument):
    name = "cartesian"
    n_equations = 3
    description = "tracker x, y, z with one static standard deviation (Paper I)"

    def observe(self, x, y):
        n = len(y)
        H = np.broadcast_to(np.eye(3), (n, 3, 3))
        S = np.broadcast_to(np.eye(3) * self.noise.cartesian_sigma**2, (n, 3, 3))
        return x - y, H, S
