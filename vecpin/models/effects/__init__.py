"""Candidate unmodelled effects: optional model terms (see :mod:`vecpin.models.effects.library`)."""
from vecpin.models.effects.library import *  # noqa: F401,F403
from vecpin.models.effects.library import (REGISTRY, Backlash, CoupledAxes, Effect, GantrySkew, InstrumentShift,  # noqa: F401
                                           RotaryPeriodic, Thermal, TipContext, effect_from_dict, effect_names, register)
