"""Per-row features of a campaign that unmodelled effects depend on.

Rows are in measurement order, so the approach direction of every axis (the sign
of its last move) and the elapsed time come from the file itself; temperature
comes from its column. The approach direction of a row is the sign of the last
nonzero move of that axis before the row (+1, -1, or 0 before any move). The
tracker station that read each row (``station``; -1 for ball bar rows, which no
tracker read) says in whose frame a tracker-frame effect acts.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.measurement.campaign import Campaign
from vecpin.errors import VecpinError


@dataclass
class Features:
    """time [s] (row index when the file has no time), temperature [°C] or None,
    direction (N, n) approach sign per axis, row (N,) index in measurement order,
    station (N,) the tracker station that read the row (-1: no tracker, a ball bar row)."""

    time: np.ndarray
    temperature: np.ndarray | None
    direction: np.ndarray
    row: np.ndarray
    has_time: bool
    station: np.ndarray | None = None

    def __post_init__(self):
        if self.station is None:
            self.station = np.zeros(len(self.row), int)

    @classmethod
    def from_campaign(cls, campaign: Campaign) -> "Features":
        N = len(campaign.q)
        has_time = campaign.time is not None
        time = campaign.time if has_time else np.arange(N, dtype=float)
        station = np.where(campaign.instrument == "ballbar", -1, campaign.station).astype(int)
        return cls(np.asarray(time, float), campaign.temperature, approach_directions(campaign.q), np.arange(N),
                   has_time, station)

    def subset(self, rows) -> "Features":
        rows = np.asarray(rows)
        return Features(self.time[rows], None if self.temperature is None else self.temperature[rows],
                        self.direction[rows], self.row[rows], self.has_time, self.station[rows])

    def require_temperature(self, who: str) -> np.ndarray:
        if self.temperature is None:
            raise VecpinError(f"{who} needs a 'temperature' column in the campaign")
        return self.temperature


def approach_directions(q: np.ndarray) -> np.ndarray:
    """(N, n) the sign of each axis' last nonzero move before each row (0 before any):
    the signs of the steps between rows, forward-filled over the rows where the axis
    did not move."""
    q = np.asarray(q, float)
    N, n = q.shape
    step = np.zeros((N, n))
    step[1:] = np.sign(np.diff(q, axis=0))
    # index of the last row at or before each row whose step is nonzero (0: none yet)
    last = np.maximum.accumulate(np.where(step != 0, np.arange(N)[:, None], 0), axis=0)
    return np.take_along_axis(step, last, axis=0)
