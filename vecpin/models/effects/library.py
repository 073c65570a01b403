"""Candidate unmodelled effects: optional terms added to either base model.

An effect contributes, linearly in its own parameters ``theta`` (SI):

* ``command``: a perturbation of the axis commands ``dq = S theta`` (N, n), applied
  before the kinematics (exact);
* ``tip``: a displacement of the tool tip in the machine frame ``dp = D theta`` (N, 3);
* ``tracker``: a displacement of the measured point in the tracker frame.

Each depends on the commands and on per-row :class:`~vecpin.features.Features`
(time, temperature, approach direction from the row order). To add your own, subclass
:class:`Effect`, implement ``parameters`` and one or more of ``command``/``tip``/
``tracker``, optionally ``candidates``, and call :func:`register`.

Built in (seed Section 2.3 and the usual suspects):

============== ================================================================
gantry_skew    a small rotation inserted after an axis, about one of its frame
               axes, whose angle is a sum of series in the other axes (eq. 23-24)
coupled_axes   a non-separable perturbation of every command by products of
               series in two axes (the base models are sums of single-axis terms)
thermal        linear-axis scale and spindle growth proportional to the
               temperature change (or to elapsed time without temperature)
backlash       lost motion: an axis lags by a constant against its last move
rotary_periodic higher harmonics of a rotary axis' angle in every command
instrument_shift the tracker disturbed: a rigid step of the measured points from
               one row on (the row is scanned by the diagnosis)
============== ================================================================
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.models.basis import chebyshev, normalise
from vecpin.errors import VecpinError
from vecpin.measurement.features import Features
from vecpin.kinematics.machine import Machine
from vecpin.models import Parameter

REGISTRY: dict[str, type["Effect"]] = {}


def register(cls: type["Effect"]) -> type["Effect"]:
    """Make an effect class available by its ``name`` (decorator)."""
    REGISTRY[cls.name] = cls
    return cls


@dataclass
class TipContext:
    """What tip effects may use: commands [m, rad], modelled tips (N,3) and tool
    directions (N,3) in the machine frame; ``frames(axis)`` gives the (N,4,4) placement
    of an axis' joint frame after its motion (computed on demand)."""

    machine: Machine
    q: np.ndarray
    tip: np.ndarray
    tool_dir: np.ndarray

    def frames(self, axis: str) -> np.ndarray:
        return self.machine.joint_frames(self.q, axis)


class Effect:
    """Base class: ``axes`` names the axes the effect concerns (may be empty)."""

    name = "effect"
    kinds: tuple[str, ...] = ()

    def __init__(self, machine: Machine, axes=(), **options):
        self.machine = machine
        self.axes = tuple(axes)
        for a in self.axes:
            machine.axis(a)
        self.options = dict(options)

    @property
    def label(self) -> str:
        return self.name + (f"[{','.join(self.axes)}]" if self.axes else "")

    def parameters(self) -> list[Parameter]:
        raise NotImplementedError

    @property
    def n_parameters(self) -> int:
        return len(self.parameters())

    def command(self, q: np.ndarray, feats: Features) -> np.ndarray:
        """S (N, n, P): command perturbation per parameter."""
        raise NotImplementedError

    def tip(self, ctx: TipContext, feats: Features) -> np.ndarray:
        """D (N, 3, P): machine-frame tip displacement per parameter."""
        raise NotImplementedError

    def tip_gradient(self, ctx: TipContext, feats: Features, theta: np.ndarray) -> np.ndarray:
        """(N, 3, 3) d (D theta) / d tip: nonzero when the displacement moves with the tip.
        (Dependence on the tool direction is neglected: second order in small errors.)"""
        return np.zeros((len(ctx.q), 3, 3))

    def tracker(self, y: np.ndarray, feats: Features) -> np.ndarray:
        """D (N, 3, P): tracker-frame displacement per parameter at measured points y."""
        raise NotImplementedError

    def tracker_gradient(self, y: np.ndarray, feats: Features, theta: np.ndarray) -> np.ndarray:
        """(N, 3, 3) d (D(y) theta) / d y; zero unless the displacement depends on y."""
        return np.zeros((len(y), 3, 3))

    def prepare(self, campaign, feats: Features) -> None:
        """Set data-dependent options (reference temperature...) from the fitted campaign."""

    def to_dict(self) -> dict:
        return {"name": self.name, "axes": list(self.axes), "options": self.options}

    @classmethod
    def candidates(cls, machine: Machine, feats: Features) -> list["Effect"]:
        return []

    def _p(self, suffix: str, quantity: str, prior: float) -> Parameter:
        return Parameter(f"{self.label}.{suffix}", quantity, prior, 99, self.label)


def effect_from_dict(d: dict, machine: Machine) -> Effect:
    try:
        cls = REGISTRY[d["name"]]
    except KeyError:
        raise VecpinError(f"unknown effect '{d['name']}' (known: {', '.join(REGISTRY)})") from None
    return cls(machine, d.get("axes", ()), **d.get("options", {}))


def _in_every_output(cols: np.ndarray, n: int) -> np.ndarray:
    """S (N, n, n*m): the same m feature columns perturbing each of the n commands."""
    N, m = cols.shape
    S = np.zeros((N, n, n * m))
    for o in range(n):
        S[:, o, o * m:(o + 1) * m] = cols
    return S


def _cheb(machine: Machine, axis: str, q: np.ndarray, order: int) -> np.ndarray:
    a = machine.axis(axis)
    return chebyshev(normalise(q[:, a.index], a.lower, a.upper), order)[:, 1:]


@register
class GantrySkew(Effect):
    """Rotation after axis ``axes[0]`` about its frame axis ``about`` (x, y or z) by
    ``theta(q) = sum_k sum_j a_kj T_j(u_k)`` over the other axes k (seed eq. 23-24)."""

    name = "gantry_skew"
    kinds = ("tip",)

    def __init__(self, machine, axes=(), about: str = "x", order: int = 3, **kw):
        super().__init__(machine, axes, about=about, order=order, **kw)
        self.about, self.order = about, int(order)
        self.others = [a.name for a in machine.axes if a.name != self.axes[0]]

    @property
    def label(self) -> str:
        return f"{self.name}[{self.axes[0]}/{self.about}]"

    def parameters(self):
        return [self._p(f"{k}.{j}", "angle", 1e-3) for k in self.others for j in range(1, self.order + 1)]

    def tip(self, ctx, feats):
        F = ctx.frames(self.axes[0])
        axis_w = F[:, :3, "xyz".index(self.about)]
        lever = np.cross(axis_w, ctx.tip - F[:, :3, 3])  # d tip / d angle
        basis = np.concatenate([_cheb(self.machine, k, ctx.q, self.order) for k in self.others], axis=1)
        return lever[:, :, None] * basis[:, None, :]

    def tip_gradient(self, ctx, feats, theta):
        from vecpin.kinematics.so3 import skew
        F = ctx.frames(self.axes[0])
        axis_w = F[:, :3, "xyz".index(self.about)]
        basis = np.concatenate([_cheb(self.machine, k, ctx.q, self.order) for k in self.others], axis=1)
        return skew(axis_w * (basis @ theta)[:, None])

    @classmethod
    def candidates(cls, machine, feats):
        return [cls(machine, (a.name,), about=c) for a in machine.axes[:-1] if a.kind == "linear" for c in "xyz"]


@register
class CoupledAxes(Effect):
    """``dq_o = sum_{a,b=1..m} c_oab T_a(u_i) T_b(u_j)`` for every output o: an error
    that depends on two axes jointly."""

    name = "coupled_axes"
    kinds = ("command",)

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
        Bi = _cheb(self.machine, self.axes[0], q, self.order)
        Bj = _cheb(self.machine, self.axes[1], q, self.order)
        return _in_every_output((Bi[:, :, None] * Bj[:, None, :]).reshape(len(q), -1), self.machine.n_axes)

    @classmethod
    def candidates(cls, machine, feats):
        names = machine.axis_names
        return [cls(machine, (names[i], names[j])) for i in range(len(names)) for j in range(i + 1, len(names))]


@register
class Thermal(Effect):
    """Scale of every linear axis and spindle growth along the tool, proportional to
    the temperature change from ``t_ref`` (``driver="temperature"``), or to the hours
    elapsed (``driver="time"``) when the campaign has no temperature."""

    name = "thermal"
    kinds = ("command", "tip")

    def __init__(self, machine, axes=(), driver: str = "temperature", t_ref: float = 0.0, **kw):
        axes = axes or tuple(a.name for a in machine.axes if a.kind == "linear")
        super().__init__(machine, axes, driver=driver, t_ref=t_ref, **kw)
        self.driver, self.t_ref = driver, float(t_ref)

    def _delta(self, feats):
        x = feats.require_temperature("the thermal effect") if self.driver == "temperature" else feats.time / 3600.0
        return np.asarray(x, float) - self.t_ref

    def prepare(self, campaign, feats):
        x = feats.temperature if self.driver == "temperature" else feats.time / 3600.0
        self.t_ref = float(np.mean(x))
        self.options["t_ref"] = self.t_ref

    def parameters(self):
        unit = "K" if self.driver == "temperature" else "h"
        return [self._p(f"{a}.scale_per_{unit}", "ratio", 1e-3) for a in self.axes] + \
               [self._p(f"spindle_growth_per_{unit}", "length", 1e-3)]

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
        return [cls(machine, driver="temperature" if feats.temperature is not None else "time")]


@register
class Backlash(Effect):
    """Lost motion of one axis: ``dq_k = beta * d_k`` with d the sign of its last move."""

    name = "backlash"
    kinds = ("command",)

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


@register
class RotaryPeriodic(Effect):
    """Harmonics ``h_min..h_max`` of a rotary axis' angle in every command."""

    name = "rotary_periodic"
    kinds = ("command",)

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
        return _in_every_output(cols, self.machine.n_axes)

    @classmethod
    def candidates(cls, machine, feats):
        return [cls(machine, (a.name,)) for a in machine.axes if a.kind == "rotary"]


@register
class InstrumentShift(Effect):
    """A rigid step of the tracker from time ``t0`` on: ``dy = delta + eps x y``."""

    name = "instrument_shift"
    kinds = ("tracker",)

    def __init__(self, machine, axes=(), t0: float = 0.0, **kw):
        super().__init__(machine, axes, t0=t0, **kw)
        self.t0 = float(t0)

    @property
    def label(self) -> str:
        return f"{self.name}[t>={self.t0:g}]"

    def parameters(self):
        return [self._p(c, "length", 1e-2) for c in ("dx", "dy", "dz")] + \
               [self._p(c, "angle", 1e-2) for c in ("ex", "ey", "ez")]

    def tracker(self, y, feats):
        if not feats.has_time:
            raise VecpinError("the instrument shift needs the 'time' column to know which rows follow the step")
        on = (feats.time >= self.t0).astype(float)
        D = np.zeros((len(y), 3, 6))
        D[:, :, :3] = np.eye(3)[None] * on[:, None, None]
        # eps x y = -[y]x eps
        D[:, 0, 4], D[:, 0, 5] = y[:, 2] * on, -y[:, 1] * on
        D[:, 1, 3], D[:, 1, 5] = -y[:, 2] * on, y[:, 0] * on
        D[:, 2, 3], D[:, 2, 4] = y[:, 1] * on, -y[:, 0] * on
        return D

    def tracker_gradient(self, y, feats, theta):
        from vecpin.kinematics.so3 import skew
        on = (feats.time >= self.t0).astype(float)
        return skew(theta[3:6])[None] * on[:, None, None]

    @classmethod
    def candidates(cls, machine, feats):
        """Steps at every few rows between 5% and 95% of the campaign (scanned)."""
        if not feats.has_time or len(feats.time) < 40:
            return []
        n = len(feats.time)
        idx = np.unique(np.linspace(int(0.05 * n), int(0.95 * n), min(120, n // 4)).astype(int))
        return [cls(machine, t0=float(feats.time[i])) for i in idx]


def effect_names() -> list[str]:
    return list(REGISTRY)
