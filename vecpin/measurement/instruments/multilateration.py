"""Multilateration: only the tracker's interferometer range is used, from several
stations (Section 3.4: the limit of the spherical model as the angle variances grow)."""
from __future__ import annotations

import numpy as np

from vecpin.errors import InputError
from vecpin.measurement.instruments.base import register_instrument
from vecpin.measurement.instruments.tracker import TrackerInstrument

MIN_STATIONS = 4  # ranges alone fix a point and the tracker positions only from four or more positions


def check_stations(campaign, option: str = "`multilateration`") -> None:
    """Refuse a range-only fit of a campaign measured from fewer than :data:`MIN_STATIONS`
    tracker positions: with ranges alone the tracker positions are unknowns too, and
    self-calibrating multilateration needs at least four non-coplanar stations; from one
    station a range fit is worse than no model (it cannot see errors across the line of sight)."""
    trk = campaign.tracker_rows
    n = len(np.unique(campaign.station[trk])) if len(trk) else 0
    if n < MIN_STATIONS:
        raise InputError(f"{option}: {campaign.source} was measured from {n} tracker station{'s' if n != 1 else ''}, "
                         f"but a fit to ranges alone needs at least {MIN_STATIONS} (the 'station' column); fit this "
                         "campaign without `multilateration` (spherical noise, or `cartesian`)")


@register_instrument
class RangeOnly(TrackerInstrument):
    name = "range"
    n_equations = 1
    description = "tracker range only, several stations (multilateration)"

    def observe(self, x, y):
        Rm, Ry = np.linalg.norm(x, axis=1), np.linalg.norm(y, axis=1)
        H = (y / Ry[:, None])[:, None, :]
        S = (self.noise.tracker.sigma_range(Rm) ** 2)[:, None, None]
        return (Rm - Ry)[:, None], H, S
