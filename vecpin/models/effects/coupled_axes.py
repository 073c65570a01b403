"""Coupled axes: an error that depends on two axes jointly (the base models are sums of
single-axis terms)."""
from __future__ import annotations

import numpy as np

from vecpin.models.basis import normalise
from vecpin.models.effects.base import (Effect, ProductOrder, axes_product_chebyshev, in_every_output, register_effect,
                                        tip_unit)


@register_effect
class CoupledAxes(ProductOrder, Effect):
    """``dq_o = sum_{a,b=1..m} c_oab T_a(u_i) T_b(u_j)`` for every output o.

    Simulated as every command perturbed by sin(pi u_i) sin(pi u_j + 0.5)."""

    name = "coupled_axes"
    summary = "a non-separable error of two axes together (every command, products of their series)"
    kinds = ("command",)
    axis_count = 2
    geometric = True

    def __init__(self, machine, axes=(), order: int = 3, **kw):
        super().__init__(machine, axes, order=order, **kw)
        self.order = int(order)

    def parameters(self):
        out = []
        for ao in self.machine.axes:
            q = "length" if ao.kind == "linear" else "angle"
            out += [self._p(f"{ao.name}.{a}{b}", q, 1e-3) for a in range(1, self.order + 1) for b in range(1, self.order + 1)]
        return out

    def command(self, q, feats):
        return in_every_output(axes_product_chebyshev(self.machine, self.axes, q, self.order), self.machine.n_axes)

    @classmethod
    def candidates(cls, machine, feats):
        names = machine.axis_names
        return [cls(machine, (names[i], names[j])) for i in range(len(names)) for j in range(i + 1, len(names))]

    def simulate_command(self, q, feats):
        rng = self._rng()
        m = self.machine
        ai, aj = m.axis(self.axes[0]), m.axis(self.axes[1])
        shape = np.sin(np.pi * normalise(q[:, ai.index], ai.lower, ai.upper)) * \
            np.sin(np.pi * normalise(q[:, aj.index], aj.lower, aj.upper) + 0.5)
        amp = rng.normal(size=m.n_axes) * tip_unit(m)
        return shape[:, None] * amp[None, :] * self.scale

    def advice(self, values, std):
        i, j = self.axes
        return [f"{self.label}: the error of {i} depends on {j} (and the reverse): geometric; a cross table with input "
                f"{i} cannot hold a product of two axes, so the tables carry only its separable part; a 2-D "
                f"(volumetric) table or a table on {i} multiplied by one on {j} (Siemens $AN_CEC_MULT_BY_TABLE) "
                "carries it fully"]
