"""Per-row features of a campaign that unmodelled effects depend on.

Rows are in measurement order, so the approach direction of every axis (the sign
of its last move) and the elapsed time come from the file itself; temperature
comes from its column. The approach direction of a row is the sign of the last
nonzero move of that axis before the row (+1, -1, or 0 before any move).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.measurement.campaign import Campaign
from vecpin.errors import VecpinError


@dataclass
class Features:
    """time [s] (row index when the file has no time), temperature [°C] or None,
    direction (N, n) approach sign per axis, row (N,) index in measurement order."""

    time: np.ndarray
    temperature: np.ndarray | None
    direction: np.ndarray
    row: np.ndarray
    has_time: bool

    @classmethod
    def from_campaign(cls, campaign: Campaign) -> "Features":
        q = campaign.q
        N = len(q)
        direction = np.zeros_like(q)
        last = np.zeros(q.shape[1])
        for i in range(1, N):  # O(N n): a running state, cheap
            step = np.sign(q[i] - q[i - 1])
            last = np.where(step != 0, step, last)
            direction[i] = last
        has_time = campaign.time is not None
        time = campaign.time if has_time else np.arange(N, dtype=float)
        return cls(np.asarray(time, float), campaign.temperature, direction, np.arange(N), has_time)

    def subset(self, rows) -> "Features":
        rows = np.asarray(rows)
        return Features(self.time[rows], None if self.temperature is None else self.temperature[rows],
                        self.direction[rows], self.row[rows], self.has_time)

    def require_temperature(self, who: str) -> np.ndarray:
        if self.temperature is None:
            raise VecpinError(f"{who} needs a 'temperature' column in the campaign")
        return self.temperature
