"""What every candidate effect is: a model term, its physical simulation, its keys and
its advice to the engineer, in one class.

An effect contributes to a model, linearly in its own parameters ``theta`` (SI):

* ``command``: a perturbation of the axis commands ``dq = S theta`` (N, n), applied
  before the kinematics (exact);
* ``tip``: a displacement of the tool tip in the machine frame ``dp = D theta`` (N, 3);
* ``tracker``: a displacement of the measured point in the tracker frame.

Each depends on the commands and on per-row :class:`~vecpin.measurement.features.Features`
(time, temperature, approach direction from the row order). The same class simulates
the effect *physically* on a true machine (``simulate_*``, written independently of the
model term: exact rotations, non-polynomial shapes, a real change of tracker pose),
scaled by the simulator to an RMS tool-tip displacement of ``strength_mm``; declares the
keys a user may set for that simulation (:class:`Key`, with units and defaults); and
turns fitted parameters into advice (:meth:`Effect.advice`).

To add an effect: write one module with a subclass of :class:`Effect` decorated with
:func:`register_effect` (see ARCHITECTURE.md); it is then a candidate of the diagnosis, a
simulated effect of ``vecpin simulate`` and listed by :func:`effects_help`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from vecpin.errors import InputError, VecpinError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.features import Features
from vecpin.models.basis import chebyshev, normalise
from vecpin.models.parameters import Parameter

REGISTRY: dict[str, type["Effect"]] = {}


def register_effect(cls: type["Effect"]) -> type["Effect"]:
    """Make an effect class available everywhere by its ``name`` (decorator)."""
    REGISTRY[cls.name] = cls
    return cls


@dataclass(frozen=True)
class Key:
    """One key of an effect's ``NAME:key=value`` specification."""

    name: str
    default: Any
    unit: str
    help: str
    kind: type = float
    choices: tuple = ()
    lo: float | None = None   # allowed range (inclusive) of a number
    hi: float | None = None

    def parse(self, text: str, where: str):
        try:
            v = self.kind(text)
        except ValueError:
            raise InputError(f"{where}: {self.name}={text!r} is not a {self.kind.__name__}") from None
        if self.kind is float and not np.isfinite(v):
            raise InputError(f"{where}: {self.name}={text!r} must be a finite number")
        if self.choices and v not in self.choices:
            raise InputError(f"{where}: {self.name} is one of {', '.join(map(str, self.choices))}, not {text!r}")
        if (self.lo is not None and v < self.lo) or (self.hi is not None and v > self.hi):
            rng = f"{'' if self.lo is None else self.lo} .. {'' if self.hi is None else self.hi}"
            raise InputError(f"{where}: {self.name}={text!r} is outside {rng} {self.unit}".rstrip())
        return v


COMMON_KEYS = (Key("strength", 0.05, "mm", "RMS tool-tip displacement the effect causes over the campaign",
                   lo=1e-9, hi=1000.0),
               Key("seed", 0, "", "seed of the effect's random shape", int, lo=0))


@dataclass
class TipContext:
    """What tip effects may use: commands [m, rad], modelled tips (N,3) and tool
    directions (N,3) in the machine frame; ``frames(axis)`` gives the (N,4,4) placement
    of an axis' joint frame after its motion (computed on demand, once per axis: every
    candidate about that axis reads the same array, so none may write to it)."""

    machine: Machine
    q: np.ndarray
    tip: np.ndarray
    tool_dir: np.ndarray
    _frames: dict = field(default_factory=dict, repr=False, compare=False)

    def frames(self, axis: str) -> np.ndarray:
        if axis not in self._frames:
            self._frames[axis] = self.machine.joint_frames(self.q, axis)
        return self._frames[axis]


class Effect:
    """Base class. ``axes``: the axes the effect concerns (may be empty);
    ``options``: the model term's and the simulation's settings; ``strength_mm`` and
    ``seed``: the simulated size and shape; ``scale`` is set by the simulator.

    Class attributes: ``kinds`` (which of command/tip/tracker the model term uses),
    ``axis_count`` (axes a specification names: 0, 1 or 2), ``keys`` (simulation keys
    beyond axes/strength/seed), ``geometric`` (True when the term is a property of the
    machine's geometry, so tables can carry it), ``scanned`` (the candidates are one
    family scanned over a parameter: the diagnosis scores the best one and counts all),
    ``flags_rows`` (the effect is a set of rows to leave out, not a term)."""

    name: ClassVar[str] = "effect"
    summary: ClassVar[str] = ""
    kinds: ClassVar[tuple[str, ...]] = ()
    axis_count: ClassVar[int] = 0
    axis_kinds: ClassVar[tuple[str, ...]] = ("linear", "rotary")  # kinds of axis a specification may name
    keys: ClassVar[tuple[Key, ...]] = ()
    geometric: ClassVar[bool] = False
    scanned: ClassVar[bool] = False
    in_time: ClassVar[bool] = False   # driven by time or temperature, not by the axes (a drift, a step)
    flags_rows: ClassVar[bool] = False

    def __init__(self, machine: Machine, axes=(), strength_mm: float = 0.05, seed: int = 0, **options):
        self.machine = machine
        self.axes = tuple(axes)
        for a in self.axes:
            machine.axis(a)
        self.options = dict(options)
        self.strength_mm, self.seed = float(strength_mm), int(seed)
        self.scale = 1.0  # set by the simulator's calibration

    @property
    def label(self) -> str:
        return self.name + (f"[{','.join(self.axes)}]" if self.axes else "")

    # ------------------------------------------------------------ model term
    def parameters(self) -> list[Parameter]:
        return []

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

    @classmethod
    def default_axes(cls, machine: Machine) -> tuple[str, ...]:
        """Axes of a specification that names none."""
        return ()

    @classmethod
    def candidates(cls, machine: Machine, feats: Features) -> list["Effect"]:
        """Every instance the diagnosis should try on this machine and campaign."""
        return []

    def supported(self, design: "Visited") -> "Effect | None":
        """This candidate cut to what a campaign's design can support (no series with more
        terms along an axis than the axis has distinct positions less one; nothing the data
        cannot tell from the base model's own series), or None when nothing is left. Effects
        without a series along an axis are supported as they are."""
        return self

    def _p(self, suffix: str, quantity: str, prior: float) -> Parameter:
        return Parameter(f"{self.label}.{suffix}", quantity, prior, 99, self.label)

    # ------------------------------------------------------------ physical simulation
    def _rng(self) -> np.random.Generator:
        return np.random.default_rng(self.seed)

    def simulate_command(self, q: np.ndarray, feats: Features) -> np.ndarray:
        """dq (N, n) [m, rad] the effect adds to the true machine's commands."""
        return np.zeros_like(q)

    def simulate_tip(self, q: np.ndarray, tip: np.ndarray, tool_dir: np.ndarray, feats: Features) -> np.ndarray:
        """The true tip (N,3) [m] after the effect (machine frame)."""
        return tip

    def simulate_tracker(self, y: np.ndarray, feats: Features) -> np.ndarray:
        """Tracker readings (N,3) [m] after the effect."""
        return y

    def simulate_gross(self, y: np.ndarray) -> np.ndarray:
        """Readings after gross errors (noise already added)."""
        return y

    # ------------------------------------------------------------ advice
    def advice(self, values: np.ndarray, std: np.ndarray) -> list[str]:
        """What the engineer does, from the fitted parameters (SI) and their standard
        deviations: lines with numbers in mm, degrees, µm/m, ppm/K..."""
        return [f"{self.label}: {self.summary}"]

    # ------------------------------------------------------------ files
    def to_dict(self) -> dict:
        return {"name": self.name, "axes": list(self.axes), "options": self.options}

    def simulation_dict(self) -> dict:
        return self.to_dict() | {"strength_mm": self.strength_mm, "seed": self.seed, "scale": self.scale}


def effect_from_dict(d: dict, machine: Machine) -> Effect:
    try:
        cls = REGISTRY[d["name"]]
    except KeyError:
        raise VecpinError(f"unknown effect '{d['name']}' (known: {', '.join(REGISTRY)})") from None
    return cls(machine, d.get("axes", ()), **d.get("options", {}))


def effect_names() -> list[str]:
    return list(REGISTRY)


def parse_effect(text: str, machine: Machine) -> Effect:
    """``NAME:key=value,...`` (``axes=Y+X``, ``strength`` [mm], ``seed`` and the effect's own
    keys) -> an effect instance for simulation; unknown names and keys are refused."""
    where = f"`effect` '{text}'"
    name, _, rest = text.partition(":")
    name = name.strip()
    if name not in REGISTRY:
        raise InputError(f"{where}: unknown effect '{name}' (known: {', '.join(REGISTRY)})")
    cls = REGISTRY[name]
    keys = {k.name: k for k in COMMON_KEYS + cls.keys}
    values, axes = {}, None
    for part in filter(None, (p.strip() for p in rest.split(","))):
        if "=" not in part:
            raise InputError(f"{where}: write NAME:key=value,... (keys of {name}: axes, {', '.join(keys)})")
        k, v = (x.strip() for x in part.split("=", 1))
        if k == "axes":
            axes = tuple(a for a in v.split("+") if a)
            for a in axes:
                machine.axis(a)
        elif k in keys:
            values[k] = keys[k].parse(v, where)
        else:
            raise InputError(f"{where}: unknown key '{k}' for {name} (keys: axes, {', '.join(keys)}; "
                             "the list of effects: `help_effects`)")
    if axes is not None and not cls.axis_count and not cls.default_axes(machine):
        raise InputError(f"{where}: {name} takes no axes= (it concerns the whole machine)")
    axes = cls.default_axes(machine) if axes is None else axes
    if cls.axis_count and len(axes) != cls.axis_count:
        raise InputError(f"{where}: {name} needs axes= with {cls.axis_count} axis name(s) joined by '+', e.g. "
                         f"axes={'+'.join(machine.axis_names[:cls.axis_count])}")
    if len(set(axes)) != len(axes):
        raise InputError(f"{where}: the axes of {name} must differ, not {'+'.join(axes)}")
    wrong = [a for a in axes if machine.axis(a).kind not in cls.axis_kinds]
    if wrong:
        raise InputError(f"{where}: {name} acts on {' or '.join(cls.axis_kinds)} axes; {wrong[0]} is "
                         f"{machine.axis(wrong[0]).kind}")
    if values.get("strength", 1.0) <= 0:
        raise InputError(f"{where}: strength is the RMS displacement in mm and must be > 0")
    opts = {k.name: values.get(k.name, k.default) for k in cls.keys if values.get(k.name, k.default) is not None}
    return cls(machine, axes, strength_mm=values.get("strength", 0.05), seed=values.get("seed", 0), **opts)


def effects_help() -> str:
    """Every registered effect with its keys, units and defaults."""
    lines = ["effects, each written NAME:key=value,...  (axes=A+B names axes; every effect also takes "
             "strength=MM (RMS tool-tip displacement, default 0.05) and seed=N (default 0))"]
    for name, cls in REGISTRY.items():
        ax = {0: "no axes", 1: "axes=A (one axis)", 2: "axes=A+B (two axes)"}[cls.axis_count]
        lines.append(f"  {name}: {cls.summary} [{ax}]")
        for k in cls.keys:
            unit = f" [{k.unit}]" if k.unit else ""
            choices = f" (one of {', '.join(map(str, k.choices))})" if k.choices else ""
            default = "" if k.default is None else k.default
            lines.append(f"      {k.name}={default}{unit}: {k.help}{choices}")
    return "\n".join(lines)


@dataclass(frozen=True)
class Visited:
    """What a campaign visited along each axis: ``positions`` {axis: distinct positions},
    ``travel`` {axis: the visited span [m, rad]}."""

    positions: dict
    travel: dict

    @classmethod
    def of(cls, machine: Machine, q: np.ndarray) -> "Visited":
        pos, trav = {}, {}
        for a in machine.axes:
            x = np.round(q[:, a.index], 9)
            pos[a.name] = int(len(np.unique(x)))
            trav[a.name] = float(np.ptp(x)) if len(x) else 0.0
        return cls(pos, trav)

    def max_order(self, axis: str) -> int:
        """The most series terms (beyond a constant) the positions of ``axis`` can tell apart."""
        return max(self.positions.get(axis, 0) - 1, 0)


def in_every_output(cols: np.ndarray, n: int) -> np.ndarray:
    """S (N, n, n*m): the same m feature columns perturbing each of the n commands."""
    N, m = cols.shape
    S = np.zeros((N, n, n * m))
    for o in range(n):
        S[:, o, o * m:(o + 1) * m] = cols
    return S


def axis_chebyshev(machine: Machine, axis: str, q: np.ndarray, order: int) -> np.ndarray:
    """(N, order) Chebyshev columns 1..order of one axis' normalised position."""
    a = machine.axis(axis)
    return chebyshev(normalise(q[:, a.index], a.lower, a.upper), order)[:, 1:]


def axes_product_chebyshev(machine: Machine, axes: tuple[str, str], q: np.ndarray, order: int) -> np.ndarray:
    """(N, order**2) products of the two axes' Chebyshev columns 1..order (the first axis' index
    runs slower): a series in both positions together, nothing of either alone."""
    Ba = axis_chebyshev(machine, axes[0], q, order)
    Bb = axis_chebyshev(machine, axes[1], q, order)
    return (Ba[:, :, None] * Bb[:, None, :]).reshape(len(q), -1)


class ProductOrder:
    """For an effect whose series is :func:`axes_product_chebyshev` of order ``order``."""

    def supported(self, design):
        """At most one product term per distinct position less one along either axis."""
        o = min(self.order, design.max_order(self.axes[0]), design.max_order(self.axes[1]))
        if o < 1:
            return None
        return self if o == self.order else type(self)(self.machine, self.axes, **(self.options | {"order": o}))


def tip_unit(machine: Machine) -> np.ndarray:
    """(n,) a command step of each axis moving the tip about 1 mm (rotary: 1 mm at 0.3 m)."""
    return np.array([1e-3 if a.kind == "linear" else 1e-3 / 0.3 for a in machine.axes])
