"""Candidate unmodelled effects, one module each (:mod:`.base` has the interface).

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
outliers       gross errors on a few rows (flagged, not a term)
twin_skew      a twin-drive yaw: a rotation after an axis by an angle that depends
               on it and the axis it carries together (products of their series)
============== ================================================================
"""
from vecpin.models.effects import (backlash, coupled_axes, gantry_skew, instrument_shift, outliers,  # noqa: F401
                                   rotary_periodic, thermal, twin_skew)
from vecpin.models.effects.backlash import Backlash
from vecpin.models.effects.base import (REGISTRY, Effect, Key, TipContext, Visited, effect_from_dict,
                                        effect_names, effects_help, parse_effect, register_effect)
from vecpin.models.effects.coupled_axes import CoupledAxes
from vecpin.models.effects.gantry_skew import GantrySkew
from vecpin.models.effects.instrument_shift import InstrumentShift
from vecpin.models.effects.outliers import Outliers
from vecpin.models.effects.rotary_periodic import RotaryPeriodic
from vecpin.models.effects.thermal import Thermal
from vecpin.models.effects.twin_skew import TwinSkew

__all__ = ["REGISTRY", "Effect", "Key", "TipContext", "Visited", "effect_from_dict", "effect_names", "effects_help",
           "parse_effect", "register_effect", "Backlash", "CoupledAxes", "GantrySkew", "InstrumentShift", "Outliers",
           "RotaryPeriodic", "Thermal", "TwinSkew"]
