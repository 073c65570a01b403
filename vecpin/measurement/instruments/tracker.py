"""What the three ways of reading a laser tracker share: stations and their poses.

A tracker row measures the target in the frame of one tracker station
(:func:`vecpin.measurement.setup.station_reading`); station 0 anchors the machine frame and
its pose correction is the seed's ``E_0``; every other station's pose is estimated
with the model. The subclasses (:mod:`.cartesian`, :mod:`.spherical`,
:mod:`.multilateration`) differ only in how the reading is compared (:meth:`observe`).
"""
from __future__ import annotations

import numpy as np

from vecpin.errors import IdentifiabilityError, VecpinError
from vecpin.measurement.instruments.base import Equations, Instrument
from vecpin.measurement.registration import rigid_registration
from vecpin.measurement.setup import POSE_NAMES, station_reading

E0_NAMES = tuple(f"E0.{c}" for c in POSE_NAMES)
POSE_PRIOR = 1e-2  # m, rad: weak prior on every station pose correction
STATION_ADVICE = ("Read from it at least three points that station 0 also reads, not on a line and spread over the "
                  "travel: the tool tip at a dozen of station 0's commands, or the table nests at several table "
                  "positions")  # what determines a further station's pose


class TrackerInstrument(Instrument):
    """Tracker rows, grouped by station. Subclasses implement :meth:`observe`."""

    row_kind = "tracker"
    group_by = "station"

    def unknowns(self, campaign, rows, nominal, setup) -> list[str]:
        s = int(campaign.station[rows[0]])
        if s == 0:
            return list(E0_NAMES)
        if s not in setup.stations:
            try:
                R, t = rigid_registration(nominal, campaign.xyz[rows])
            except VecpinError:
                lines = ", ".join(str(k) for k in campaign.lines[rows][:6])
                raise IdentifiabilityError(
                    f"{campaign.source}: tracker station {s} reads {len(rows)} points on a line (rows {lines}): its pose "
                    f"cannot be found. {STATION_ADVICE}") from None
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
        # tracker-frame effects move the point in this station's frame (the effect says which
        # stations' rows it moves: models.effects.instrument_shift)
        terms = None if tracker_terms is None else (lambda y: tracker_terms(y, rows))
        y, dy_dp, dy_du = station_reading(p, R, t, u, terms)
        n = len(rows)
        dy_dp = np.broadcast_to(dy_dp, (n, 3, 3))
        x = campaign.xyz[rows]
        r, H, S = self.observe(x, y)
        k = r.shape[1]
        out = self.pad(n)
        out["r"][:, :k] = r
        out["dr_dp"][:, :k] = -H @ dy_dp
        out["S"][:, :k, :k] = S
        dr_dy = np.zeros((n, 3, 3))
        dr_dy[:, :k] = -H
        du = np.zeros((n, 3, 6))
        du[:, :k] = -H @ dy_du
        if k == 3:
            out["metric"] = x - y
            out["dmetric_dp"] = -dy_dp
            dm_du = -dy_du
        else:
            out["metric"][:, :k] = r
            out["dmetric_dp"][:, :k] = out["dr_dp"][:, :k]
            dm_du = du
        return Equations(out["r"], out["dr_dp"], du, out["S"], self.valid, out["metric"], out["dmetric_dp"], dr_dy,
                         dm_du, y)
