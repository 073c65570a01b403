"""Backlash: an axis lags by a constant against its last move (lost motion)."""
from __future__ import annotations

import numpy as np

from vecpin.models.effects.base import Effect, register_effect, tip_unit


@register_effect
class Backlash(Effect):
    """``dq_k = beta * d_k`` with d the sign of axis k's last move (row order).

    Simulated as the axis lagging by half a reversal error (of about 1 mm at the tip
    before scaling) against its last move."""

    name = "backlash"
    summary = "lost motion: an axis lags by a constant against its last move"
    kinds = ("command",)
    axis_count = 1

    def parameters(self):
        a = self.machine.axis(self.axes[0])
        return [self._p("half_reversal", "length" if a.kind == "linear" else "angle", 1e-3)]

    def command(self, q, feats):
        k = self.machine.axis(self.axes[0]).index
        S = np.zeros((len(q), self.machine.n_axes, 1))
        S[:, k, 0] = feats.direction[:, k]
        return S

    @classmethod
    def candidates(cls, machine, feats):
        return [cls(machine, (a.name,)) for a in machine.axes]

    def simulate_command(self, q, feats):
        k = self.machine.axis(self.axes[0]).index
        dq = np.zeros_like(q)
        dq[:, k] = -0.5 * feats.direction[:, k] * tip_unit(self.machine)[k]
        return dq * self.scale

    def advice(self, values, std):
        a = self.machine.axis(self.axes[0])
        rev = -2 * values[0] / a.scale  # lagging by beta means the reversal value compensates -2 beta
        sd = 2 * std[0] / a.scale
        return [f"{self.label}: reversal error {abs(rev):.4f} ± {sd:.4f} {a.unit}; enter it as the backlash "
                f"compensation of {a.name} (Siemens MD32450 $MA_BACKLASH, Fanuc 1851 (and 1852 for rapid "
                "traverse)); row-dependent, not in the tables"]
