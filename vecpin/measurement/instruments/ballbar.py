"""Telescoping ball bar: the distance of the tool tip from a pivot socket whose centre
is unknown (Section 3.4.2, eq. 45-47)."""
from __future__ import annotations

import numpy as np

from vecpin.measurement.instruments.base import Equations, Instrument, register_instrument

PIVOT_PRIOR = 1e-2  # m


def sphere_centre(p: np.ndarray) -> np.ndarray:
    """Least-squares centre of points on a sphere (algebraic fit, |p|^2 = 2 p.o + c)."""
    A = np.c_[2 * p, np.ones(len(p))]
    return np.linalg.lstsq(A, np.sum(p * p, axis=1), rcond=None)[0][:3]


@register_instrument
class BallBar(Instrument):
    name = "ballbar"
    row_kind = "ballbar"
    n_equations = 1
    description = "ball bar radius about an unknown pivot (eq. 45-47)"
    group_by = "pivot"

    def unknowns(self, campaign, rows, nominal, setup) -> list[str]:
        k = int(campaign.pivot[rows[0]])
        if k not in setup.pivots:
            setup.pivots[k] = sphere_centre(nominal)
        return [f"pivot{k}.{c}" for c in "xyz"]

    def priors(self, names: list[str]) -> np.ndarray:
        from vecpin.measurement.instruments.points import POINT_PRIOR
        return np.array([POINT_PRIOR if n.startswith("target") else PIVOT_PRIOR for n in names])

    def equations(self, campaign, rows, p, setup, u, tracker_terms=None) -> Equations:
        k = int(campaign.pivot[rows[0]])
        d = p - (setup.pivots[k] + u)
        dist = np.linalg.norm(d, axis=1)
        unit = d / dist[:, None]
        n = len(rows)
        out = self.pad(n)
        r = campaign.radius[rows] - dist
        out["r"][:, 0] = r
        out["dr_dp"][:, 0] = -unit
        out["S"][:, 0, 0] = self.noise.ballbar_sigma**2
        du = np.zeros((n, 3, 3))
        du[:, 0] = unit
        out["metric"][:, 0] = r
        out["dmetric_dp"][:, 0] = -unit
        return Equations(out["r"], out["dr_dp"], du, out["S"], self.valid, out["metric"], out["dmetric_dp"], None, du)
