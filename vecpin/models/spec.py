"""One model specification: what an error model is, before it is fitted.

A :class:`ModelSpec` holds the kind (``"6dof"``, ``"ap"`` or any registered kind), the
basis of every axis (:class:`~vecpin.models.basis.AxisBasis`, which carries that axis'
order), the effects, the tool-length corrections and the prior scale. Every way a model
comes to be goes through it: the model's constructor makes one from its arguments
(:meth:`ModelSpec.of`) and builds itself from it (``model.spec``),
:meth:`~vecpin.models.base.ErrorModel.with_effects` extends it, the model choice's
candidates are constructor arguments, and the model file stores it (:meth:`to_dict`, the
file's ``model`` section) and reads it back (:meth:`from_dict`). Two models of equal
specs on one machine have the same parameters in the same order.

Units: SI inside (basis travels and knots in m or rad, tool lengths in m); the file's
section in mm and degrees (a key ending ``_mm`` is mm; a basis' travel and knots are in
its axis' unit).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.models.basis import AxisBasis
from vecpin.models.effects.base import Effect, effect_from_dict
from vecpin.models.prior import SmoothPrior
from vecpin.units import MM_PER_M, M_PER_MM

#: how the bases were made: "fourier" (Chebyshev over the travel, a Fourier series per turn on
#: rotary axes travelling more than a turn), "chebyshev" (everywhere), "custom" (given per axis)
BASIS_RULES = ("fourier", "chebyshev", "custom")


@dataclass(frozen=True, eq=False)
class ModelSpec:
    """An error model's definition (see the module text). ``order``: the common series
    order the model was asked for (the largest of :attr:`orders` for custom bases);
    ``bases``: one per axis in the machine's axis order; ``basis``: one of
    :data:`BASIS_RULES`; ``tool_lengths`` [m]: a length correction per tool (None: the
    gauge-line correction only); ``prior_scale``: the factor on every prior standard
    deviation (Σ_b), dimensionless; ``prior``: a smoothness prior on the series' coefficients
    (:class:`~vecpin.models.prior.SmoothPrior`; None: every coefficient's prior is the
    default times ``prior_scale``)."""

    kind: str
    order: int
    bases: tuple[AxisBasis, ...]
    basis: str = "fourier"
    effects: tuple[Effect, ...] = ()
    tool_lengths: tuple[float, ...] | None = None
    prior_scale: float = 1.0
    prior: SmoothPrior | None = None

    @classmethod
    def of(cls, kind: str, machine: Machine, order: int = 6, basis: str = "fourier",
           tool_lengths: list[float] | None = None, prior_scale: float = 1.0,
           bases: list[AxisBasis] | None = None, effects: list | None = None,
           prior: SmoothPrior | None = None) -> "ModelSpec":
        """The spec of a model's constructor arguments (checked; each message names the
        parameter). ``bases`` given: ``basis`` is "custom"; else every axis gets
        ``basis``' family at ``order``."""
        if isinstance(order, bool) or int(order) != order or order < 0:
            raise InputError(f"`order` {order}: the series order must be a whole number >= 0")
        if not (math.isfinite(prior_scale) and prior_scale > 0):
            raise InputError(f"`prior_scale` {prior_scale}: the prior scale must be a positive number")
        if basis not in ("chebyshev", "fourier"):
            raise InputError(f"`basis` {basis}: 'fourier' (a Fourier series per turn on rotary axes travelling more "
                             "than a turn, Chebyshev elsewhere) or "
                             "'chebyshev'")
        if bases is None:
            bases = [AxisBasis(a.lower, a.upper, int(order), "fourier" if basis == "fourier" and a.multiturn else "chebyshev",
                               rotary=a.kind == "rotary") for a in machine.axes]
        else:
            if len(bases) != machine.n_axes:
                raise InputError(f"`bases`: one basis per axis: {machine.n_axes} axes, {len(bases)} bases")
            basis = "custom"
        tools = None if tool_lengths is None else tuple(float(t) for t in tool_lengths)
        return cls(kind, int(order), tuple(bases), basis, tuple(effects or ()), tools, float(prior_scale), prior)

    @property
    def orders(self) -> tuple[int, ...]:
        """The series order (or spline degree) of every axis' basis."""
        return tuple(B.order for B in self.bases)

    def priors_of(self, parameters: list, axis_names: list[str]) -> list:
        """The model's parameters with their priors from :attr:`prior` (unchanged without one)."""
        return parameters if self.prior is None else self.prior.apply(parameters, dict(zip(axis_names, self.bases)))

    def with_effects(self, effects: list) -> "ModelSpec":
        """The same model with these effects instead of its own."""
        return replace(self, effects=tuple(effects))

    def options(self) -> dict:
        """The constructor's keyword arguments after ``machine`` that make this spec."""
        return {"order": self.order, "basis": "fourier" if self.basis == "custom" else self.basis,
                "tool_lengths": None if self.tool_lengths is None else list(self.tool_lengths),
                "prior_scale": self.prior_scale, "bases": list(self.bases) if self.basis == "custom" else None,
                "effects": list(self.effects), "prior": self.prior}

    def key(self) -> tuple:
        """What two equal specs share (effects by their definition)."""
        return (self.kind, self.order, self.bases, self.basis, tuple(str(e.to_dict()) for e in self.effects),
                self.tool_lengths, self.prior_scale, self.prior)

    def __eq__(self, other) -> bool:
        return isinstance(other, ModelSpec) and self.key() == other.key()

    __hash__ = None  # effects are mutable objects

    def to_dict(self, machine: Machine) -> dict:
        """The model file's ``model`` section (mm, deg)."""
        out = {"kind": self.kind, "order": self.order, "basis": self.basis,
               "axis_bases": [basis_to_dict(a, B) for a, B in zip(machine.axes, self.bases)],
               "tool_lengths_mm": None if self.tool_lengths is None else [t * MM_PER_M for t in self.tool_lengths],
               "prior_scale": self.prior_scale, "effects": [e.to_dict() for e in self.effects]}
        return out if self.prior is None else out | {"smooth_prior": self.prior.to_dict()}

    @classmethod
    def from_dict(cls, d: dict, machine: Machine) -> "ModelSpec":
        """Inverse of :meth:`to_dict` on ``machine`` (refused with the field's name)."""
        if d.get("basis") not in BASIS_RULES:
            raise InputError(f"model.basis {d.get('basis')!r}: one of {', '.join(BASIS_RULES)}")
        bases = None
        if d["basis"] == "custom":
            if len(d["axis_bases"]) != machine.n_axes:
                raise InputError(f"model.axis_bases: {len(d['axis_bases'])} bases for {machine.n_axes} axes")
            bases = []
            for a, b in zip(machine.axes, d["axis_bases"]):
                try:
                    bases.append(basis_from_dict(a, b))
                except InputError as exc:
                    raise InputError(f"model.axis_bases: the basis of axis {a.name} is invalid ({exc})") from None
        tools = None if d["tool_lengths_mm"] is None else [t * M_PER_MM for t in d["tool_lengths_mm"]]
        effects = [effect_from_dict(e, machine) for e in d["effects"]]
        prior = SmoothPrior.from_dict(d["smooth_prior"]) if d.get("smooth_prior") is not None else None
        return cls.of(d["kind"], machine, d["order"], "fourier" if bases else d["basis"], tools, d["prior_scale"],
                      bases, effects, prior)


def basis_to_dict(axis, B: AxisBasis) -> dict:
    """One axis basis in user units (mm or deg)."""
    return B.to_dict(axis.scale) | {"lower": float(axis.to_user(B.lower)), "upper": float(axis.to_user(B.upper)),
                                    "rotary": B.rotary}


def basis_from_dict(axis, b: dict) -> AxisBasis:
    """Inverse of :func:`basis_to_dict`; a travel written as the axis' own reads back as it exactly."""
    lower, upper = (getattr(axis, e) if float(b[e]) == float(axis.to_user(getattr(axis, e))) else float(axis.to_si(b[e]))
                    for e in ("lower", "upper"))
    return AxisBasis.from_dict(b, lower, upper, bool(b["rotary"]), axis.scale)
