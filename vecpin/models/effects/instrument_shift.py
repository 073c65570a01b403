"""The tracker disturbed during the campaign: a rigid step of the measured points from
one row on (the step time is scanned by the diagnosis).

A step concerns the rows of *one* tracker station, in that station's frame: a knocked
tracker moves its own readings and no other station's. This is the one place that
says which rows a tracker-frame effect moves; the likelihood and the diagnosis apply
tracker-frame terms to every tracker-read row of every station and take the effect's
word for which rows it moves (zero elsewhere)."""
from __future__ import annotations

import numpy as np

from vecpin.errors import VecpinError
from vecpin.kinematics.so3 import exp3, skew
from vecpin.models.effects.base import Effect, Key, register_effect
from vecpin.units import MM_PER_M


@register_effect
class InstrumentShift(Effect):
    """A rigid step of the tracker of station ``station`` from time ``t0`` on:
    ``dy = delta + eps x y`` in that station's frame, on its rows only.

    Simulated as a real change of the tracker pose (0.1 mm and 20 µrad before scaling)
    at the fraction ``at`` of the campaign's time, on the rows of station ``station``."""

    name = "instrument_shift"
    summary = "the tracker knocked: a rigid step of the measured points at an unknown time"
    kinds = ("tracker",)
    scanned = True
    in_time = True
    keys = (Key("at", 0.5, "fraction", "when the simulated step happens, as a fraction of the campaign's time",
                lo=0.0, hi=1.0),
            Key("station", 0, "", "the tracker station that is knocked (its rows move)", int, lo=0))

    def __init__(self, machine, axes=(), t0: float = 0.0, station: int = 0, **kw):
        super().__init__(machine, axes, t0=t0, station=int(station), **kw)
        self.t0, self.station = float(t0), int(station)

    @property
    def label(self) -> str:
        where = f"station {self.station}, " if self.station else ""
        return f"{self.name}[{where}t>={self.t0:g}]"

    def parameters(self):
        return [self._p(c, "length", 1e-2) for c in ("dx", "dy", "dz")] + \
               [self._p(c, "angle", 1e-2) for c in ("ex", "ey", "ez")]

    def _on(self, feats) -> np.ndarray:
        """1 on the rows the step moves: this station's rows from t0 on; else 0."""
        if not feats.has_time:
            raise VecpinError("the instrument shift needs the 'time' column to know which rows follow the step")
        return ((feats.time >= self.t0) & (feats.station == self.station)).astype(float)

    def tracker(self, y, feats):
        on = self._on(feats)
        D = np.zeros((len(y), 3, 6))
        D[:, :, :3] = np.eye(3)[None] * on[:, None, None]
        # eps x y = -[y]x eps
        D[:, :, 3:] = -skew(y) * on[:, None, None]
        return D

    def tracker_gradient(self, y, feats, theta):
        return skew(theta[3:6])[None] * self._on(feats)[:, None, None]

    @classmethod
    def candidates(cls, machine, feats):
        """Per tracker station with at least 40 rows: steps at every few of its rows
        between 5% and 95% of them (one scanned family over every station)."""
        if not feats.has_time:
            return []
        out = []
        for s in np.unique(feats.station[feats.station >= 0]):
            t = np.sort(feats.time[feats.station == s])
            n = len(t)
            if n < 40:
                continue
            idx = np.unique(np.linspace(int(0.05 * n), int(0.95 * n), min(120, n // 4)).astype(int))
            out += [cls(machine, t0=float(t[i]), station=int(s)) for i in idx]
        return out

    def simulate_tracker(self, y, feats):
        rng = self._rng()
        if self.options.get("_sim_t0") is None:
            # fixed on the first (identification) campaign it meets
            self.options["_sim_t0"] = float(np.quantile(feats.time, self.options.get("at", 0.5)))
        on = (feats.time >= self.options["_sim_t0"]) & (feats.station == self.station)
        w = rng.normal(size=3)
        w = w / np.linalg.norm(w) * 2e-5 * self.scale
        d = rng.normal(size=3)
        d = d / np.linalg.norm(d) * 1e-4 * self.scale
        out = y.copy()
        out[on] = y[on] @ exp3(w).T + d
        return out

    def advice(self, values, std):
        who = f"the tracker of station {self.station}" if self.station else "the tracker"
        return [f"{self.label}: {who} moved by {np.linalg.norm(values[:3]) * MM_PER_M:.4f} mm and "
                f"{np.linalg.norm(values[3:]) * 1e6:.1f} µrad at t = {self.t0:g} s: fix the stand and re-register "
                "on the reference nests, or re-measure the rows after the step; not in the tables"]
