"""The tracker disturbed during the campaign: a rigid step of the measured points from
one row on (the step time is scanned by the diagnosis)."""
from __future__ import annotations

import numpy as np

from vecpin.errors import VecpinError
from vecpin.kinematics.so3 import exp3, skew
from vecpin.models.effects.base import Effect, Key, register
from vecpin.units import MM_PER_M


@register
class InstrumentShift(Effect):
    """A rigid step of the tracker from time ``t0`` on: ``dy = delta + eps x y``.

    Simulated as a real change of the tracker pose (0.1 mm and 20 µrad before scaling)
    at the fraction ``at`` of the campaign's time."""

    name = "instrument_shift"
    summary = "the tracker knocked: a rigid step of the measured points at an unknown time"
    kinds = ("tracker",)
    scanned = True
    keys = (Key("at", 0.5, "fraction", "when the simulated step happens, as a fraction of the campaign's time",
                lo=0.0, hi=1.0),)

    def __init__(self, machine, axes=(), t0: float = 0.0, **kw):
        super().__init__(machine, axes, t0=t0, **kw)
        self.t0 = float(t0)

    @property
    def label(self) -> str:
        return f"{self.name}[t>={self.t0:g}]"

    def parameters(self):
        return [self._p(c, "length", 1e-2) for c in ("dx", "dy", "dz")] + \
               [self._p(c, "angle", 1e-2) for c in ("ex", "ey", "ez")]

    def _on(self, feats) -> np.ndarray:
        if not feats.has_time:
            raise VecpinError("the instrument shift needs the 'time' column to know which rows follow the step")
        return (feats.time >= self.t0).astype(float)

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
        """Steps at every few rows between 5% and 95% of the campaign (scanned)."""
        if not feats.has_time or len(feats.time) < 40:
            return []
        n = len(feats.time)
        idx = np.unique(np.linspace(int(0.05 * n), int(0.95 * n), min(120, n // 4)).astype(int))
        return [cls(machine, t0=float(feats.time[i])) for i in idx]

    def simulate_tracker(self, y, feats):
        rng = self._rng()
        if self.options.get("_sim_t0") is None:
            # fixed on the first (identification) campaign it meets
            self.options["_sim_t0"] = float(np.quantile(feats.time, self.options.get("at", 0.5)))
        on = feats.time >= self.options["_sim_t0"]
        w = rng.normal(size=3)
        w = w / np.linalg.norm(w) * 2e-5 * self.scale
        d = rng.normal(size=3)
        d = d / np.linalg.norm(d) * 1e-4 * self.scale
        out = y.copy()
        out[on] = y[on] @ exp3(w).T + d
        return out

    def advice(self, values, std):
        return [f"{self.label}: the tracker moved by {np.linalg.norm(values[:3]) * MM_PER_M:.4f} mm and "
                f"{np.linalg.norm(values[3:]) * 1e6:.1f} µrad at t = {self.t0:g} s: fix the stand and re-register "
                "on the reference nests, or re-measure the rows after the step; not in the tables"]
