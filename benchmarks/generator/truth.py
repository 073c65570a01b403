"""The true machine: smooth random 6-component error fields per axis, and the effects to detect.

Every actuated joint gets six Gaussian-process draws along its own travel (3 translations, m;
3 rotations, rad, in its moved frame), periodic per turn on a rotary axis that turns more than
once. Effects (at most one per campaign) add geometric terms (``coupled``: one linear axis' error
depending on another linear axis' position, purely non-separable; ``skew``: the twin-drive gantry
beam yawing with the carriage and beam positions together; ``harmonic``: a per-turn harmonic of a rotary axis) or
row-dependent ones handled by the campaign (thermal, backlash, tracker shift, gross errors).
Geometric effect terms are built at unit amplitude and scaled by the campaign to their drawn size.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .fields import Field1D, gp_1d, gp_2d
from .kinematics import ErrorFn
from .layouts import Layout

# effect families; their names in vecpin's diagnosis.json (``outliers`` for both gross kinds)
VECPIN_NAME = {"thermal": "thermal", "shift": "instrument_shift", "gross_isolated": "outliers",
               "gross_cluster": "outliers", "backlash": "backlash", "harmonic": "rotary_periodic",
               "coupled": "coupled_axes", "skew": "gantry_skew"}
FAMILIES = tuple(VECPIN_NAME)
SCALED = ("thermal", "shift", "backlash", "harmonic", "coupled", "skew")   # drawn size = RMS tip move


def _loguniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


@dataclass
class AxisField:
    """The six error functions of one joint: delta x y z (m) and eps x y z (rad) of its position."""

    joint: str
    parts: list[Field1D]

    def __call__(self, q) -> np.ndarray:
        x = np.asarray(q[self.joint], dtype=float)
        return np.stack([f(x) for f in self.parts], axis=1)


def draw_fields(rng: np.random.Generator, layout: Layout) -> dict[str, AxisField]:
    """Per actuated joint, six smooth random error functions of realistic size.

    Translations RMS 5..50 um (arm 10..80 um), rotations 5..40 urad (arm 10..80 urad), length scales
    0.2..1 of the travel (of a turn on a periodic rotary axis).
    """
    arm = layout.kind == "arm"
    t_rng, r_rng = ((10e-6, 80e-6), (10e-6, 80e-6)) if arm else ((5e-6, 50e-6), (5e-6, 40e-6))
    out = {}
    for j in layout.axes:
        periodic = j.kind == "revolute" and (j.upper - j.lower) > 2 * np.pi + 1e-9
        parts = []
        for k in range(6):
            rms = _loguniform(rng, *(t_rng if k < 3 else r_rng))
            parts.append(gp_1d(rng, j.lower, j.upper, rms, _loguniform(rng, 0.2, 1.0), periodic=periodic))
        out[j.name] = AxisField(j.name, parts)
    return out


@dataclass
class Effect:
    """One effect of a campaign: its family, the axes it involves, parameters (SI), size (mm RMS at
    the tool tip over the tool rows, or the smallest gross error), and geometric error terms."""

    family: str
    axes: list[str] = field(default_factory=list)
    params: dict = field(default_factory=dict)
    size_mm: float = 0.0
    amplitude: float = 1.0
    terms: dict[str, list[ErrorFn]] = field(default_factory=dict)

    @property
    def vecpin_name(self) -> str:
        return VECPIN_NAME[self.family]


def applicable(layout: Layout) -> list[str]:
    """The effect families this layout can carry."""
    fams = ["thermal", "shift", "gross_isolated", "gross_cluster", "backlash"]
    rot = [j for j in layout.rotary() if (j.upper - j.lower) >= np.radians(180.0)]
    if rot and layout.kind != "arm":
        fams.append("harmonic")
    if len(layout.linear()) >= 2:
        fams.append("coupled")
    if layout.twin_axis:
        fams.append("skew")
    return fams


def _scaled(amp_box: list, fn):
    """An error function multiplied by the effect's current amplitude (set after sizing)."""
    return lambda q: amp_box[0] * fn(q)


def _coupled(rng, layout: Layout, eff: Effect, box: list) -> None:
    lin = layout.linear()
    i, j = rng.choice(len(lin), size=2, replace=False)
    a, b = lin[int(i)], lin[int(j)]
    comp = int(rng.integers(0, 3))
    f2 = gp_2d(rng, (a.lower, a.upper, b.lower, b.upper), 1e-5,
               (_loguniform(rng, 0.3, 1.0), _loguniform(rng, 0.3, 1.0)))

    def term(q, f2=f2, a=a.name, b=b.name, comp=comp):
        e = np.zeros((len(q[a]), 6))
        e[:, comp] = f2(np.asarray(q[a]), np.asarray(q[b]))
        return e
    eff.axes = [a.name, b.name]
    eff.params.update(component="xyz"[comp], error_of=a.name, depends_on=b.name)
    eff.terms = {a.name: [_scaled(box, term)]}


def _skew(rng, layout: Layout, eff: Effect, box: list) -> None:
    """Twin-drive yaw: the beam turns about z after the twin axis by an angle that depends on where the
    carriage is on the beam AND where the beam is (the part of either alone is an ordinary axis error)."""
    twin, cross = layout.joint(layout.twin_axis), layout.joint("X")
    f2 = gp_2d(rng, (cross.lower, cross.upper, twin.lower, twin.upper), 1e-5,
               (_loguniform(rng, 0.4, 1.5), _loguniform(rng, 0.3, 1.0)))

    def term(q, f2=f2, twin=twin.name):
        e = np.zeros((len(q[twin]), 6))
        e[:, 5] = f2(np.asarray(q["X"]), np.asarray(q[twin]))
        return e
    eff.axes = [twin.name, "X"]
    eff.params.update(about="z", after=twin.name, depends_on="X")
    eff.terms = {twin.name: [_scaled(box, term)]}


def _harmonic(rng, layout: Layout, eff: Effect, box: list) -> None:
    rot = max(layout.rotary(), key=lambda j: j.upper - j.lower)
    travel = rot.upper - rot.lower
    orders = [k for k in range(3, 9) if travel >= 2 * (2 * np.pi / k)]
    k = int(rng.choice(orders))
    ph1, ph2 = rng.uniform(0, 2 * np.pi, 2)
    axis = np.asarray(rot.axis, dtype=float)
    radial = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    radial /= np.linalg.norm(radial)
    lever = rng.uniform(0.05, 0.3)                   # m: how much radial motion per rad of index error

    def term(q, name=rot.name):
        th = np.asarray(q[name], dtype=float)
        e = np.zeros((len(th), 6))
        e[:, :3] = 1e-5 * lever * np.sin(k * th + ph2)[:, None] * radial[None, :]
        e[:, 3:] = 1e-5 * np.sin(k * th + ph1)[:, None] * axis[None, :]
        return e
    eff.axes = [rot.name]
    eff.params.update(order_per_turn=k)
    eff.terms = {rot.name: [_scaled(box, term)]}


def draw_effect(rng: np.random.Generator, layout: Layout, family: str | None,
                size_mm: tuple[float, float] = (0.005, 0.08)) -> Effect | None:
    """One effect of the family (None: a clean campaign); its size log-uniform in ``size_mm``."""
    if family is None:
        return None
    eff = Effect(family, size_mm=_loguniform(rng, *size_mm))
    box = [1.0]
    eff.params["_box"] = box
    if family == "coupled":
        _coupled(rng, layout, eff, box)
    elif family == "skew":
        _skew(rng, layout, eff, box)
    elif family == "harmonic":
        _harmonic(rng, layout, eff, box)
    elif family == "backlash":
        cand = layout.linear() or layout.rotary()
        eff.axes = [cand[int(rng.integers(len(cand)))].name]
    elif family == "thermal":
        eff.params.update(lag_h=rng.uniform(0.2, 1.5), nonlinearity_per_K=rng.uniform(-0.3, 0.3),
                          gains_ppm_per_K={j.name: rng.uniform(-15.0, 15.0) if layout.kind != "arm"
                                           else rng.uniform(10.0, 25.0) for j in layout.axes},
                          spindle_um_per_K=rng.uniform(2.0, 15.0))
    elif family == "shift":
        frac = rng.uniform(0.15, 0.35) if rng.random() < 0.5 else rng.uniform(0.65, 0.85)
        axis = rng.normal(size=3)
        eff.params.update(at_fraction=frac, rot_axis=axis / np.linalg.norm(axis),
                          rot_weight=rng.uniform(0.0, 1.0), direction=unit_vector(rng))
    elif family.startswith("gross"):
        eff.size_mm = 0.0
    return eff


def unit_vector(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)
