"""Laser tracker read in its native spherical coordinates (range, zenith, azimuth) with
range-dependent variances (Section 3, eq. 33-36, 41)."""
from __future__ import annotations

import numpy as np

from vecpin.measurement.instruments.base import register_instrument
from vecpin.measurement.instruments.tracker import TrackerInstrument
from vecpin.measurement.tracker import cartesian_to_spherical, spherical_jacobian, wrap_angle


@register_instrument
class SphericalTracker(TrackerInstrument):
    name = "spherical"
    n_equations = 3
    description = "tracker range and two angles, noise growing with distance (Section 3)"

    def observe(self, x, y):
        sm, sy = cartesian_to_spherical(x), cartesian_to_spherical(y)
        r = sm - sy
        r[:, 2] = wrap_angle(r[:, 2])
        sig = self.noise.tracker.sigma_spherical(sm[:, 0])
        S = np.zeros((len(y), 3, 3))
        S[:, [0, 1, 2], [0, 1, 2]] = sig**2
        return r, spherical_jacobian(y), S
