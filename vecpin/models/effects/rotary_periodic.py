"""Higher harmonics of a rotary axis' angle (gear, worm or encoder errors)."""
from __future__ import annotations

import math

import numpy as np

from vecpin.models.effects.base import Effect, in_every_output, register_effect, tip_unit


@register_effect
class RotaryPeriodic(Effect):
    """Harmonics ``h_min..h_max`` of a rotary axis' angle in every command.

    Added as a candidate from 4 cycles per turn: below, an added series would take the axis' smooth
    error (its runout, wobble and ovality fall off over the first few orders). A lower harmonic the
    base model's own Fourier series carry is named ``rotary_periodic`` only when it stands out of
    that smooth error as a spectral line (:mod:`vecpin.diagnosis.harmonics`).

    Simulated as 5th and 7th harmonics of the angle in every command."""

    name = "rotary_periodic"
    summary = "higher harmonics of a rotary axis' angle in every command"
    kinds = ("command",)
    axis_count = 1
    axis_kinds = ("rotary",)
    geometric = True

    def __init__(self, machine, axes=(), h_min: int = 4, h_max: int = 8, **kw):
        super().__init__(machine, axes, h_min=h_min, h_max=h_max, **kw)
        self.h = list(range(int(h_min), int(h_max) + 1))

    def parameters(self):
        out = []
        for ao in self.machine.axes:
            q = "length" if ao.kind == "linear" else "angle"
            out += [self._p(f"{ao.name}.{f}{h}", q, 1e-3) for h in self.h for f in ("cos", "sin")]
        return out

    def command(self, q, feats):
        ang = q[:, self.machine.axis(self.axes[0]).index]
        cols = np.stack([f(h * ang) for h in self.h for f in (np.cos, np.sin)], axis=1)
        return in_every_output(cols, self.machine.n_axes)

    def supported(self, design):
        """Harmonics the axis' visited travel tells from a polynomial (at least two whole
        periods of the lowest over the travel) and its positions resolve (two positions a
        period, and a position for each cos/sin term)."""
        a = self.axes[0]
        travel, n = design.travel.get(a, 0.0), design.positions.get(a, 0)
        if travel <= 0:
            return None
        lo = max(self.h[0], math.ceil(4 * math.pi / travel - 1e-9))
        hi = min(self.h[-1], math.floor(math.pi * (n - 1) / travel - 1e-9), lo + (n - 1) // 2 - 1)
        if hi < lo:
            return None
        if (lo, hi) == (self.h[0], self.h[-1]):
            return self
        return type(self)(self.machine, self.axes, **(self.options | {"h_min": lo, "h_max": hi}))

    @classmethod
    def candidates(cls, machine, feats):
        return [cls(machine, (a.name,)) for a in machine.axes if a.kind == "rotary"]

    def simulate_command(self, q, feats):
        rng = self._rng()
        ang = q[:, self.machine.axis(self.axes[0]).index]
        unit = tip_unit(self.machine)
        dq = np.zeros_like(q)
        for o in range(self.machine.n_axes):
            c5, s5, c7, s7 = rng.normal(size=4) * unit[o]
            dq[:, o] = c5 * np.cos(5 * ang) + s5 * np.sin(5 * ang) + 0.6 * (c7 * np.cos(7 * ang) + s7 * np.sin(7 * ang))
        return dq * self.scale

    def advice(self, values, std):
        a = self.axes[0]
        return [f"{self.label}: harmonics {self.h[0]}..{self.h[-1]} per turn of {a}: geometric; the tables on input "
                f"{a} carry them when they have enough points per turn (at least {4 * self.h[-1]}); a worm or encoder "
                "error of this order is worth a mechanical check"]
