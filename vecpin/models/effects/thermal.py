"""Thermal drift: linear axes grow and the spindle grows with the temperature change
(or with time when the campaign has no temperature); an arm (a machine without linear
axes: a robot) grows as a whole, its links with it. The machine's own temperature may
follow the air's with a first-order lag (a heavy structure warms slowly): the diagnosis
scans the lag (:data:`LAGS_H`) and takes the one the data fit best, so a lagged drift is
named as one thermal effect, not as a thermal effect plus a step of the tracker."""
from __future__ import annotations

import numpy as np

from vecpin.kinematics.axes import is_arm
from vecpin.models.effects.base import Effect, Key, register_effect

LAGS_H = (0.0, 0.5, 1.0, 2.0, 4.0)  # first-order lags [h] the diagnosis tries (0: the air temperature itself)


def lagged(time_s: np.ndarray, x: np.ndarray, lag_h: float) -> np.ndarray:
    """``x`` (N,) seen through a first-order lag of ``lag_h`` hours over the rows' times
    ``time_s`` (N,) [s]: y_k = y_{k-1} + (1 - exp(-dt_k / tau)) (x_k - y_{k-1}), y_0 = x_0
    (exact for x constant between rows; the structure starts at the first reading)."""
    x = np.asarray(x, float)
    if lag_h <= 0 or len(x) == 0:
        return x
    a = 1.0 - np.exp(-np.maximum(np.diff(np.asarray(time_s, float)), 0.0) / (lag_h * 3600.0))
    y = np.empty_like(x)
    y[0] = x[0]
    for k in range(1, len(x)):
        y[k] = y[k - 1] + a[k - 1] * (x[k] - y[k - 1])
    return y


@register_effect
class Thermal(Effect):
    """Scale of every linear axis and spindle growth along the tool, proportional to the
    temperature change from ``t_ref`` (``driver="temperature"``) or to the hours elapsed
    (``driver="time"``). A machine without linear axes (an arm) has, instead of axis
    scales, one scale of the whole chain: every link grows alike, so the tip moves by
    scale x change x its position from the machine frame's origin (the arm's base).

    Simulated as steel expansion (11.5 ppm/K) of the linear axes, aluminium expansion
    (23 ppm/K) of an arm's chain and 20 µm/K spindle growth with the temperature above
    ``t_ref`` (20 °C), or per hour without temperature."""

    name = "thermal"
    summary = "linear-axis scale (an arm: the chain's scale) and spindle growth with the temperature (or time)"
    kinds = ("command", "tip")
    keys = (Key("t_ref", 20.0, "degC", "reference temperature of the simulated expansion", lo=-50.0, hi=100.0),)
    axis_kinds = ("linear",)
    scanned = True
    in_time = True

    def __init__(self, machine, axes=(), driver: str = "temperature", t_ref: float = 20.0, lag_h: float = 0.0, **kw):
        axes = axes or self.default_axes(machine)
        super().__init__(machine, axes, driver=driver, t_ref=t_ref, lag_h=float(lag_h), **kw)
        self.driver, self.t_ref, self.lag_h = driver, float(t_ref), float(lag_h)
        self.chain = is_arm(machine)   # an arm: its links grow as a whole

    @classmethod
    def default_axes(cls, machine):
        return tuple(a.name for a in machine.axes if a.kind == "linear")

    def _driver(self, feats) -> np.ndarray:
        """The machine's temperature [°C] (the air's through the lag) or the hours elapsed."""
        if self.driver != "temperature":
            return np.asarray(feats.time, float) / 3600.0
        return lagged(feats.time, feats.require_temperature("the thermal effect"), self.lag_h)

    def _delta(self, feats):
        return self._driver(feats) - self.t_ref

    def prepare(self, campaign, feats):
        self.t_ref = float(np.mean(self._driver(feats)))
        self.options["t_ref"] = self.t_ref

    @property
    def unit(self) -> str:
        return "K" if self.driver == "temperature" else "h"

    def parameters(self):
        return [self._p(f"{a}.scale_per_{self.unit}", "ratio", 1e-3) for a in self.axes] + \
               ([self._p(f"chain.scale_per_{self.unit}", "ratio", 1e-3)] if self.chain else []) + \
               [self._p(f"spindle_growth_per_{self.unit}", "length", 1e-3)]

    def command(self, q, feats):
        d = self._delta(feats)
        S = np.zeros((len(q), self.machine.n_axes, len(self.axes) + self.chain + 1))
        for k, a in enumerate(self.axes):
            S[:, self.machine.axis(a).index, k] = q[:, self.machine.axis(a).index] * d
        return S

    def tip(self, ctx, feats):
        d = self._delta(feats)[:, None]
        D = np.zeros((len(ctx.q), 3, len(self.axes) + self.chain + 1))
        if self.chain:
            D[:, :, len(self.axes)] = ctx.tip * d
        D[:, :, -1] = ctx.tool_dir * d
        return D

    @classmethod
    def candidates(cls, machine, feats):
        """Against temperature when the campaign has it (through every lag of
        :data:`LAGS_H` when it has times too), else against elapsed time; none without
        either (row numbers are not hours)."""
        if feats.temperature is not None:
            return [cls(machine, driver="temperature", lag_h=h) for h in (LAGS_H if feats.has_time else (0.0,))]
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
        d = (self.scale * self._sim_delta(feats))[:, None]
        return tip + tool_dir * 20e-6 * d + (tip * 23e-6 * d if self.chain else 0.0)

    def advice(self, values, std):
        u = self.unit
        lines = []
        for k, a in enumerate(self.axes):
            lines.append(f"{self.label}: {a} scale {values[k] * 1e6:+.1f} ± {std[k] * 1e6:.1f} ppm/{u}")
        if self.chain:
            k = len(self.axes)
            lines.append(f"{self.label}: the arm grows {values[k] * 1e6:+.1f} ± {std[k] * 1e6:.1f} ppm/{u} "
                         "(aluminium: 23 ppm/K, steel: 11.5)")
        lines.append(f"{self.label}: spindle growth {values[-1] * 1e6:+.1f} ± {std[-1] * 1e6:.1f} µm/{u}")
        if self.driver == "temperature" and self.lag_h > 0:
            lines.append(f"{self.label}: the machine follows the air temperature with a lag of about {self.lag_h:g} h "
                         "(the lag the data fit best of " + ", ".join(f"{h:g}" for h in LAGS_H) + " h): a sensor on "
                         "the structure, not in the air, carries this drift")
        if self.driver == "temperature":
            lines.append(f"{self.label}: row-dependent, not in the tables: measure warm (after a warm-up cycle), "
                         "keep the hall temperature steady, or enable the controller's temperature compensation "
                         "with these coefficients")
        else:
            lines.append(f"{self.label}: drift with time, not in the tables: warm the machine up before measuring and "
                         "record the temperature with the points")
        return lines
