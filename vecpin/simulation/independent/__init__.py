"""A second, independent family of simulated true machines (issue 11).

vecpin's own simulator (:mod:`vecpin.simulation.truth`) draws errors from the families
vecpin fits; the machines here do not: their kinematics are a separate reading of the
URDF (:mod:`.chain`), their errors come from families outside vecpin's bases
(:mod:`.families`: windup, periodic_drift, spline, bumps, mixed), and each separable
family comes with its oracle basis (the fit of the true family) for judging fits
(:mod:`vecpin.simulation.judge`).
"""
from vecpin.simulation.independent.chain import URDFChain, error_transform
from vecpin.simulation.independent.families import FAMILIES
from vecpin.simulation.independent.functions import BASE, COMPONENTS, Shape, Term
from vecpin.simulation.independent.layouts import LAYOUTS, layout, machine_with_limits
from vecpin.simulation.independent.machine import IndependentMachine

__all__ = ["BASE", "COMPONENTS", "FAMILIES", "LAYOUTS", "IndependentMachine", "Shape", "Term", "URDFChain",
           "error_transform", "layout", "machine_with_limits"]
