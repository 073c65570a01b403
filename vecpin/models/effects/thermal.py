"""Thermal drift: linear axes grow and the spindle grows with the temperature change
(or with time when the campaign has no temperature)."""
from __future__ import annotations

import numpy as np

from vecpin.models.effects.base import Effect, Key, register


@register
class Thermal(Effect):
    """Scale of every linear axis and spindle growth along the tool, proportional to the
    temperature change from ``t_ref`` (``driver="temperature"``) or to the hours elapsed
    (``driver="time"``).

    Simulated as steel expansion (11.5 ppm/K) of the linear axes and 20 µm/K spindle
    growth with the temperature above ``t_ref`` (20 °C), or per hour without temperature."""

    name = "thermal"
    summary = "linear-axis scale and spindle growth with the temperature (or time)"
    kinds = ("command", "tip")
    keys = (Key("t_ref", 20.0, "degC", "reference temperature of the simulated expansion", lo=-50.0, hi=100.0),)
    axis_kinds = ("linear",)

    def __init__(self, machine, axes=(), driver: str = "temperature", t_ref: float = 20.0, **kw):
        axes = axes or self.default_axes(machine)
        super().__init__(machine, axes, driver=driver, t_ref=t_ref, **kw)
        self.driver, self.t_ref = driver, float(t_ref)

    @classmethod
    def default_axes(cls, machine):
        return tuple(a.name for a in machine.axes if a.kind == "linear")

    def _delta(self, feats):
        x = feats.require_temperature("the thermal effect") if self.driver == "temperature" else feats.time / 3600.0
        return np.asarray(x, float) - self.t_ref

    def prepare(self, campaign, feats):
        x = feats.temperature if self.driver == "temperature" else feats.time / 3600.0
        self.t_ref = float(np.mean(x))
        self.options["t_ref"] = self.t_ref

    @property
    def unit(self) -> str:
        return "K" if self.driver == "temperature" else "h"

    def parameters(self):
        return [self._p(f"{a}.scale_per_{self.unit}", "ratio", 1e-3) for a in self.axes] + \
               [self._p(f"spindle_growth_per_{self.unit}", "length", 1e-3)]

    def command(self, q, feats):
        d = self._delta(feats)
        S = np.zeros((len(q), self.machine.n_axes, len(self.axes) + 1))
        for k, a in enumerate(self.axes):
            S[:, self.machine.axis(a).index, k] = q[:, self.machine.axis(a).index] * d
        return S

    def tip(self, ctx, feats):
        D = np.zeros((len(ctx.q), 3, len(self.axes) + 1))
        D[:, :, -1] = ctx.tool_dir * self._delta(feats)[:, None]
        return D

    @classmethod
    def candidates(cls, machine, feats):
        """Against temperature when the campaign has it, else against elapsed time; none
        without either (row numbers are not hours)."""
        if feats.temperature is not None:
            return [cls(machine, driver="temperature")]
        return [cls(machine, driver="time")] if feats.has_time else []

    def _sim_delta(self, feats) -> np.ndarray:
        if feats.temperature is not None:
            return feats.temperature - self.options.get("t_ref", 20.0)
        return feats.time / 3600.0

    def simulate_command(self, q, feats):
        d = self._sim_delta(feats)
        dq = np.zeros_like(q)
        for name in self.axes:  # the heated axes (default: every linear axis)
            a = self.machine.axis(name)
            dq[:, a.index] = 11.5e-6 * q[:, a.index] * d
        return dq * self.scale

    def simulate_tip(self, q, tip, tool_dir, feats):
        return tip + tool_dir * (20e-6 * self.scale * self._sim_delta(feats))[:, None]

    def advice(self, values, std):
        u = self.unit
        lines = []
        for k, a in enumerate(self.axes):
            lines.append(f"{self.label}: {a} scale {values[k] * 1e6:+.1f} ± {std[k] * 1e6:.1f} ppm/{u}")
        lines.append(f"{self.label}: spindle growth {values[-1] * 1e6:+.1f} ± {std[-1] * 1e6:.1f} µm/{u}")
        if self.driver == "temperature":
            lines.append(f"{self.label}: row-dependent, not in the tables: measure warm (after a warm-up cycle), "
                         "keep the hall temperature steady, or enable the controller's temperature compensation "
                         "with these coefficients")
        else:
            lines.append(f"{self.label}: drift with time, not in the tables: warm the machine up before measuring and "
                         "record the temperature with the points")
        return lines
