"""Instruments, one module each behind one interface (:mod:`.base`): a new instrument
is a new module with a registered :class:`~vecpin.measurement.instruments.base.Instrument`.

Built in: ``cartesian`` and ``spherical`` tracker readings, ``range`` (multilateration),
``nest`` (tracker readings of reflectors in table nests) and ``ballbar``.
"""
# each module registers its instrument
from vecpin.measurement.instruments import ballbar, cartesian, multilateration, nest, spherical  # noqa: F401
from vecpin.measurement.instruments.base import (REGISTRY, ROW_KINDS, Equations, Instrument, instrument_for,
                                               register_instrument)

__all__ = ["REGISTRY", "ROW_KINDS", "Equations", "Instrument", "instrument_for", "register_instrument"]
