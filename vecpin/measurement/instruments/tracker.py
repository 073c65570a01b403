"""What the three ways of reading a laser tracker share: stations and their poses.

A tracker row measures the target in the frame of one tracker station
(:func:`vecpin.measurement.setup.to_station`); station 0 anchors the machine frame and
its pose correction is the seed's ``E_0``; every other station's pose is estimated
with the model. The subclasses (:mod:`.cartesian`, :mod:`.spherical`,
:mod:`.multilateration`) differ only in how the reading is compared (:meth:`observe`).
"""
from __future__ import annotations

import numpy as np

from vecpin.measurement.instruments.base import Equations, Instrument
from vecpin.measurement.registration import register as rigid_registration
from vecpin.measurement.setup import POSE_NAMES, to_station

E0_NAMES = tuple(f"E0.{c}" for c in POSE_NAMES)
POSE_PRIOR = 1e-2  # m, rad: weak prior on every station pose correction


class TrackerInstrument(Instrument):
    """Tracker rows, grouped by station. Subclasses implement :meth:`observe`."""

    row_kind = "tracker"

    def groups(self, campaign, rows):
        st = campaign.station[rows]
        return {int(s): rows[st == s] for s in np.unique(st)}

    def unknowns(self, campaign, rows, nominal, setup) -> list[str]:
        s = int(campaign.station[rows[0]])
        if s == 0:
            return list(E0_NAMES)
        if s not in setup.stations:
            R, t = rigid_registration(nominal, campaign.xyz[rows])
            setup.stations[s] = (R, t, np.zeros(6))
        return [f"station{s}.{c}" for c in POSE_NAMES]

    def priors(self, names: list[str]) -> np.ndarray:
        """Pose corrections: POSE_PRIOR; target offsets and nest positions: POINT_PRIOR."""
        from vecpin.measurement.instruments.points import POINT_PRIOR
        return np.array([POINT_PRIOR if n.startswith(("target", "nest")) else POSE_PRIOR for n in names])

    def observe(self, x: np.ndarray, y: np.ndarray):
        """(r (n,k), H = dr/dy sign-free d h/d y (n,k,3), S (n,k,k)) for readings x and
        predicted points y (n,3) in the station frame; r = h(x) - h(y)."""
        raise NotImplementedError

    def equations(self, campaign, rows, p, setup, u, tracker_terms=None) -> Equations:
        s = int(campaign.station[rows[0]])
        R, t, _ = setup.pose(s)
        y, RR, de = to_station(p, R, t, u, jacobian=True)
        n = len(rows)
        M = np.broadcast_to(np.eye(3), (n, 3, 3))
        if tracker_terms is not None:  # tracker-frame effects move the point in this station's frame (the
            # effect says which stations' rows it moves: models.effects.instrument_shift)
            shift, grad = tracker_terms(y, rows)
            y = y + shift
            M = np.eye(3) + grad
        x = campaign.xyz[rows]
        r, H, S = self.observe(x, y)
        k = r.shape[1]
        out = self.pad(n)
        dy_dp = M @ RR
        out["r"][:, :k] = r
        out["dr_dp"][:, :k] = -H @ dy_dp
        out["S"][:, :k, :k] = S
        dr_dy = np.zeros((n, 3, 3))
        dr_dy[:, :k] = -H
        du = np.zeros((n, 3, 6))
        du[:, :k] = -H @ (M @ de)
        if k == 3:
            out["metric"] = x - y
            out["dmetric_dp"] = -dy_dp
            dm_du = -(M @ de)
        else:
            out["metric"][:, :k] = r
            out["dmetric_dp"][:, :k] = out["dr_dp"][:, :k]
            dm_du = du
        return Equations(out["r"], out["dr_dp"], du, out["S"], self.valid, out["metric"], out["dmetric_dp"], dr_dy,
                         dm_du, y)
