"""Families of true error functions outside vecpin's model families.

vecpin fits, per axis, Chebyshev series over the travel or Fourier series per turn
(rotary axes travelling more than a turn), as 6-DoF errors or axis perturbations.
Every truth here is an ordinary :func:`background` (a cubic on linear axes; location
and orientation offsets, runout and encoder eccentricity at 1-2 cycles per turn on
rotary axes, the sizes of :meth:`vecpin.simulation.truth.TrueMachine.random`) plus
the content of one family, which those bases do not contain:

``windup``          rotary errors that grow with the angle (cable and hose wind-up,
                    torsion: linear and quadratic in q over the whole multi-turn
                    travel) plus a gear stage behind the encoder with a period of
                    1/3 turn or 2.5 turns (3 or 0.4 cycles per turn).
``periodic_drift``  rotary errors repeating every turn (1-3 cycles) plus a slow
                    quadratic drift over the travel.
``spline``          smooth random cubic splines on every axis, knots about 1/10 of the
                    travel apart.
``bumps``           2-3 local Gaussian bumps per axis (width 4-7 % of the travel).
``mixed``           errors that depend on two axes at once: ram sag growing with
                    extension and varying with the cross axis, a deformation field of
                    the bed in the base frame, head droop that depends on orientation
                    and extension, bridge twist under the saddle.

``windup`` and ``periodic_drift`` act on rotary axes only (on a machine whose rotary
axes turn less than a turn they are smooth and nearly inside vecpin's Chebyshev
family); the others act on every axis. :data:`DEFAULT_SHARE` is the usual part of the
mean volumetric error a family's content makes: local, short-wavelength errors
(splines, bumps) are smaller on real machines than wind-up or sag.

Each generator returns the family's terms and, per axis, the :class:`AxisBasis` that
contains that axis' separable terms *and* the background exactly (the oracle basis);
``mixed`` has terms no per-axis basis contains. A ``<mimic>`` joint (a joint that follows
an axis, like the second head of a machine with mirrored spindles) gets errors of its
own (:func:`mimic_terms`): the terms of the axis it follows, redrawn with the same
structure, so the axis' oracle basis contains them too.
"""
from __future__ import annotations

import numpy as np

from vecpin.kinematics.machine import Machine
from vecpin.models.basis import AxisBasis
from vecpin.simulation.independent.functions import BASE, Shape, Term

UM = URAD = 1e-6
FAMILIES = ("windup", "periodic_drift", "spline", "bumps", "mixed")
DEFAULT_SHARE = {"windup": 0.3, "periodic_drift": 0.3, "spline": 0.15, "bumps": 0.15, "mixed": 0.25}


def _along(a) -> int:
    return int(np.argmax(np.abs(a.direction)))


def _sizes(a) -> np.ndarray:
    """Typical size of each component (dx dy dz [m], ex ey ez [rad]) of an axis' errors."""
    if a.kind == "linear":
        s = np.array([50 * UM] * 3 + [30 * URAD] * 3)
        s[_along(a)] = 100 * UM  # positioning (scale) error dominates
        return s
    s = np.array([150 * UM] * 3 + [100 * URAD] * 3)  # location offsets, tilt and wobble
    s[_along(a)] = 50 * UM  # axial runout
    return s


def _sep(k: int, c: int, size: float, shape: Shape, family: str) -> Term:
    return Term(k, c, float(size), (shape,), family)


def _f(x) -> tuple[float, ...]:
    return tuple(float(v) for v in np.atleast_1d(x))


def _harm(rng, ws, scale) -> tuple[tuple[float, float, float], ...]:
    return tuple((float(w), float(rng.normal() * scale), float(rng.normal() * scale)) for w in ws)


def background(machine: Machine, rng: np.random.Generator) -> list[Term]:
    """The ordinary part of every truth (tagged "background"): on linear axes a cubic
    over the travel with the scale error dominating positioning; on rotary axes
    location and orientation offsets (constants in the moving frame), bearing runout
    and encoder eccentricity at 1 and 2 cycles per turn, as machines usually have."""
    terms = []
    for k, a in enumerate(machine.axes):
        for c, size in enumerate(_sizes(a)):
            if a.kind == "linear":
                cheb = rng.normal(size=4) * 0.5 / (1 + np.arange(4)) ** 1.5
                if c == _along(a):
                    cheb[1] += rng.choice([-1, 1])
                shape = Shape(k, _f(cheb))
            else:
                shape = Shape(k, (float(rng.normal()),), _harm(rng, [1.0], 0.25) + _harm(rng, [2.0], 0.12))
            terms.append(_sep(k, c, size, shape, "background"))
    return terms


def _background_basis(a, order: int | None = None, harmonics: tuple[float, ...] = (), bumps=()) -> AxisBasis:
    """The background's basis of an axis (a cubic; or a constant and 1-2 cycles per turn),
    widened by a Chebyshev ``order``, ``harmonics`` and ``bumps``."""
    if a.kind == "linear":
        return AxisBasis(a.lower, a.upper, 3 if order is None else max(order, 3), "chebyshev", harmonics, False, bumps=bumps)
    per_turn = tuple(sorted({1.0, 2.0} | set(harmonics)))
    return AxisBasis(a.lower, a.upper, order or 0, "chebyshev", per_turn, True, bumps=bumps)


def windup(machine: Machine, rng: np.random.Generator):
    terms, bases = [], []
    for k, a in enumerate(machine.axes):
        if a.kind == "linear":
            bases.append(_background_basis(a))
            continue
        gear = float(rng.choice([3.0, 0.4]))  # cycles per turn: a period of 1/3 turn or 2.5 turns
        for c, size in enumerate(_sizes(a)):
            growth = rng.normal() * 0.8
            if c == 3 + _along(a):
                growth = rng.choice([-1, 1]) * 1.5  # torsion of the hoses: an index error growing with the angle
            shape = Shape(k, (0.0, float(growth), float(rng.normal() * 0.4)), _harm(rng, [gear], 0.35))
            terms.append(_sep(k, c, size, shape, "windup"))
        bases.append(_background_basis(a, order=2, harmonics=(gear,)))
    return terms, bases


def periodic_drift(machine: Machine, rng: np.random.Generator):
    terms, bases = [], []
    for k, a in enumerate(machine.axes):
        if a.kind == "linear":  # the drift of a linear axis is a low-order polynomial: the background
            bases.append(_background_basis(a))
            continue
        for c, size in enumerate(_sizes(a)):
            drift = rng.normal(size=2) * 0.6
            if c == 3 + _along(a):
                drift[0] = rng.choice([-1, 1]) * 0.8  # thermal drift of the index over the travel
            harm = _harm(rng, [1.0], 0.5) + _harm(rng, [2.0], 0.3) + _harm(rng, [3.0], 0.25)
            terms.append(_sep(k, c, size, Shape(k, (0.0, *_f(drift)), harm), "periodic_drift"))
        bases.append(AxisBasis(a.lower, a.upper, 6, "fourier_trend", (), True, trend=2))
    return terms, bases


def spline(machine: Machine, rng: np.random.Generator, n_knots: int = 9, degree: int = 3):
    terms, bases = [], []
    for k, a in enumerate(machine.axes):
        h = a.travel / (n_knots + 1)
        inner = a.lower + h * (np.arange(1, n_knots + 1) + rng.uniform(-0.3, 0.3, n_knots))
        knots = np.r_[[a.lower] * (degree + 1), inner, [a.upper] * (degree + 1)]
        for c, size in enumerate(_sizes(a)):
            coefs = rng.normal(size=n_knots + degree + 1) * 0.7
            terms.append(_sep(k, c, size, Shape(k, knots=_f(knots), coefs=_f(coefs), degree=degree), "spline"))
        if a.kind == "linear":  # cubic B-splines contain the cubic background
            bases.append(AxisBasis(a.lower, a.upper, degree, "bspline", knots=_f(inner)))
        else:
            bases.append(AxisBasis(a.lower, a.upper, degree, "bspline", (1.0, 2.0), True, knots=_f(inner)))
    return terms, bases


def bumps(machine: Machine, rng: np.random.Generator):
    terms, bases = [], []
    for k, a in enumerate(machine.axes):
        n = int(rng.integers(2, 4))
        centres = np.sort(rng.uniform(a.lower + 0.1 * a.travel, a.upper - 0.1 * a.travel, n))
        widths = a.travel * rng.uniform(0.04, 0.07, n)
        for c, size in enumerate(_sizes(a)):
            heights = rng.normal(size=n)
            shape = Shape(k, bumps=tuple((float(m), float(s), float(g)) for m, s, g in zip(centres, widths, heights)))
            terms.append(_sep(k, c, size, shape, "bumps"))
        bases.append(_background_basis(a, bumps=tuple((float(m), float(s)) for m, s in zip(centres, widths))))
    return terms, bases


def mixed(machine: Machine, rng: np.random.Generator):
    terms, bases = [], [_background_basis(a) for a in machine.axes]
    lin = [a.index for a in machine.axes if a.kind == "linear"]
    rot = [a.index for a in machine.axes if a.kind == "rotary"]
    extension = lambda k: Shape(k, (0.5, 0.5))  # noqa: E731  0 at one end of the travel, 1 at the other
    if len(lin) >= 2:
        ram, cross = lin[-1], lin[-2]
        ram_dir = _along(machine.axes[ram])
        for c in (3, 4, 5):  # ram sag: tilt growing with extension, varying along the cross axis
            if c - 3 == ram_dir:
                continue
            size = float(rng.choice([-1, 1]) * 80 * URAD)
            along_cross = Shape(cross, (), _harm(rng, [rng.uniform(1.0, 2.5)], 0.8))
            terms.append(Term(ram, c, size, (extension(ram), along_cross), "mixed:ram_sag"))
        w1, w2 = rng.uniform(1.0, 3.0, 2)
        for c in (0, 1, 2):  # a deformation field of the bed, base frame
            size = float(rng.normal() * 60 * UM)
            field_x, field_y = Shape(lin[0], (), _harm(rng, [w1], 0.8)), Shape(lin[1], (), _harm(rng, [w2], 0.8))
            terms.append(Term(BASE, c, size, (field_x, field_y), "mixed:bed_field"))
        for c in (3, 4, 5):  # bridge twist under the load of the saddle
            size = float(rng.normal() * 40 * URAD)
            bridge = Shape(lin[0], (1.0, float(rng.normal() * 0.5)))
            saddle = Shape(lin[1], (0.0, 1.0, float(rng.normal() * 0.3)))
            terms.append(Term(lin[0], c, size, (bridge, saddle), "mixed:bridge_twist"))
    if rot and lin:
        head, ram = rot[-1], lin[-1]
        for c in range(6):  # head droop: depends on the head's orientation and the ram's extension
            if c % 3 == _along(machine.axes[head]):
                continue
            size = float(rng.normal() * (60 * UM if c < 3 else 60 * URAD))
            orientation = Shape(head, (), _harm(rng, [1.0], 0.8))
            terms.append(Term(head, c, size, (orientation, extension(ram)), "mixed:head_droop"))
    return terms, bases


GENERATORS = {"windup": windup, "periodic_drift": periodic_drift, "spline": spline, "bumps": bumps, "mixed": mixed}


def mimic_terms(terms: list[Term], machine: Machine, rng: np.random.Generator) -> list[Term]:
    """Errors of every ``<mimic>`` joint of the machine (slot n + m for the m-th): for each
    term acting after the axis the joint follows, a term of the same component, size
    and family acting after the joint, its shapes redrawn (:meth:`Shape.redrawn`) and
    its sign random: the second head's errors are of the same kind as the first's but
    its own. Base-frame terms are shared by every tool point already."""
    out = []
    n = machine.n_axes
    for m, mj in enumerate(getattr(machine, "mimic_joints", ())):
        k = machine.axis(mj.axis).index
        for t in terms:
            if t.target != k:
                continue
            shapes = tuple(s.redrawn(rng) for s in t.shapes)
            out.append(Term(n + m, t.component, float(t.amplitude * rng.choice([-1.0, 1.0])), shapes, t.family, k))
    return out
