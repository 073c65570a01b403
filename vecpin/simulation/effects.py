"""Which effects a simulated machine has: a specification a test or script writes
without a machine at hand. The physics of each effect is in its class
(:mod:`vecpin.models.effects`, ``simulate_*``)."""
from __future__ import annotations

from dataclasses import dataclass, field

from vecpin.models.effects import REGISTRY


@dataclass
class EffectSpec:
    """One simulated effect: ``name`` (registered effect), ``axes``, ``strength_mm`` (RMS
    tool-tip displacement over the campaign), the effect's ``options`` (its simulation
    keys, e.g. ``about``/``depends`` of a skew, ``at`` of an instrument shift), ``seed``."""

    name: str
    axes: tuple[str, ...] = ()
    strength_mm: float = 0.05
    options: dict = field(default_factory=dict)
    seed: int = 0

    def build(self, machine):
        cls = REGISTRY[self.name]
        axes = self.axes or cls.default_axes(machine)
        return cls(machine, axes, strength_mm=self.strength_mm, seed=self.seed, **self.options)


TrueEffect = EffectSpec  # the name earlier scripts use
