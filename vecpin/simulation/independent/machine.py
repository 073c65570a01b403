"""The independent true machine: its own URDF chain, exact error transforms, error
functions from :mod:`~vecpin.simulation.independent.families`.

Nothing here uses vecpin's Pinocchio kinematics or its bases to compute the truth
(the URDF is read a second time by :class:`URDFChain`); only the oracle bases, the
tracker placement and the measuring machinery (:class:`SimulatedMachine`) are shared.
A truth file stores every term in mm and degrees.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from vecpin.errors import InputError
from vecpin.fileio import write_text
from vecpin.kinematics.machine import Machine
from vecpin.measurement.tracker import Tracker, TrackerNoise
from vecpin.models.basis import AxisBasis
from vecpin.simulation.independent.chain import URDFChain, error_transform
from vecpin.simulation.independent.families import DEFAULT_SHARE, FAMILIES, GENERATORS, background, mimic_terms
from vecpin.simulation.independent.functions import BASE, COMPONENTS, Shape, Term
from vecpin.simulation.truth import SimulatedMachine, place_tracker, uniform_commands
from vecpin.units import MM_PER_M, M_PER_MM, RAD_PER_DEG

FORMAT = "vecpin-independent-truth"


def _component_unit(c: int) -> float:
    """SI per user unit of an error component: m per mm or rad per degree."""
    return 1e-3 if c < 3 else RAD_PER_DEG


@dataclass
class IndependentMachine(SimulatedMachine):
    """A simulated true machine whose kinematics and error functions vecpin did not write.

    ``terms``: the error components (:class:`Term`, SI), after the axes and after every
    ``<mimic>`` joint (:attr:`slots`); ``family``: the name of the family they were drawn from; ``bases``: per axis the :class:`AxisBasis` that
    contains every separable term of that axis (the oracle, see :meth:`oracle_bases`);
    ``gauge_error``: actual minus nominal gauge-line offset along the tool [m];
    ``repeatability``: (n,) 1-sigma axis noise [m, rad]; ``tracker``: pose and noise.
    """

    machine: Machine
    terms: list[Term]
    family: str
    bases: list[AxisBasis]
    gauge_error: float
    repeatability: np.ndarray
    tracker: Tracker
    seed: int | None = None
    effects: list = field(default_factory=list)
    stations: list = field(default_factory=list)
    _chain: URDFChain | None = field(default=None, repr=False)

    @property
    def chain(self) -> URDFChain:
        if self._chain is None:
            m = self.machine  # which links and axis order: the machine's options; the kinematics: the chain's own
            self._chain = URDFChain(m.urdf_xml, m.source, tool_links=m.tool_links, tool_axis=m.tool_axis,
                                    workpiece=m.workpiece_link, axis_names=m.axis_names)
        return self._chain

    # ------------------------------------------------------------------ kinematics
    @property
    def slots(self) -> list[tuple[str, int]]:
        """(joint name, index of the axis that moves it) of every place errors act after:
        the axes, then the machine's ``<mimic>`` joints (which follow an axis)."""
        m = self.machine
        return [(a.name, a.index) for a in m.axes] + \
               [(mj.name, m.axis(mj.axis).index) for mj in getattr(m, "mimic_joints", ())]

    def _limits(self):
        m = self.machine
        return m.lower, m.upper, np.array([a.kind == "rotary" for a in m.axes])

    def error_values(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(errors (N,S,6) after each slot's motion (the axes, then the mimic joints:
        :attr:`slots`) [m, rad], base-frame translations (N,3) [m])."""
        q = np.atleast_2d(np.asarray(q, float))
        lo, hi, rot = self._limits()
        local = np.zeros((len(q), len(self.slots), 6))
        base = np.zeros((len(q), 3))
        for t in self.terms:
            v = t.value(q, lo, hi, rot)
            if t.target == BASE:
                base[:, t.component] += v
            else:
                local[:, t.target, t.component] += v
        return local, base

    def _errors(self, q: np.ndarray):
        """({joint name: (N,4,4) exact error transform after its motion}, base-frame translations)."""
        local, base = self.error_values(q)
        return {name: error_transform(local[:, k, :3], local[:, k, 3:]) for k, (name, _) in enumerate(self.slots)}, base

    def geometric_tip(self, q: np.ndarray, tool: np.ndarray, *, frame: str = "base", point=0,
                      offset: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """True tip (N,3) [m] and unit tool direction: the URDF paths with an exact error
        transform after every axis, the base-frame field added to the tip and the
        gauge-line error along the tool; in the base frame or relative to the (erroneous)
        workpiece frame."""
        q = np.atleast_2d(np.asarray(q, float))
        errors, base = self._errors(q)
        tool = np.broadcast_to(np.asarray(tool, float), (len(q),)) + self.gauge_error
        pt = np.broadcast_to(np.asarray(point), (len(q),))
        tip, u = np.empty((len(q), 3)), np.empty((len(q), 3))
        off = None if offset is None else np.broadcast_to(np.asarray(offset, float), (len(q), 3))
        for k in np.unique(pt):
            r = pt == k
            sub = {n: e[r] for n, e in errors.items()}
            tip[r], u[r] = self.chain.tool_tip(q[r], tool[r], sub, point=int(k), offset=None if off is None else off[r])
        tip = tip + base
        if frame == "workpiece" and self.chain.workpiece:
            T = np.linalg.inv(self.chain.pose(self.chain.workpiece, q, errors))
            tip = np.einsum("pij,pj->pi", T[:, :3, :3], tip) + T[:, :3, 3]
            u = np.einsum("pij,pj->pi", T[:, :3, :3], u)
        return tip, u

    def geometric_workpiece_points(self, q: np.ndarray, p_wp: np.ndarray) -> np.ndarray:
        q = np.atleast_2d(np.asarray(q, float))
        p = np.broadcast_to(np.asarray(p_wp, float), (len(q), 3))
        if not self.chain.workpiece:
            return p.copy()
        T = self.chain.pose(self.chain.workpiece, q, self._errors(q)[0])
        return np.einsum("pij,pj->pi", T[:, :3, :3], p) + T[:, :3, 3]

    # ------------------------------------------------------------------ oracle
    @property
    def separable(self) -> bool:
        """True when every term depends only on the axis it follows (a per-axis 6-DoF form)."""
        return all(t.separable for t in self.terms)

    def oracle_bases(self) -> list[AxisBasis] | None:
        """One basis per axis that contains the true error family exactly, so a 6-DoF fit
        with them reaches the noise-limited floor; None when the truth mixes axes."""
        return list(self.bases) if self.separable else None

    def separable_part(self) -> "IndependentMachine":
        """The same machine without the terms that mix axes (its oracle is :attr:`bases`)."""
        return replace(self, terms=[t for t in self.terms if t.separable], effects=list(self.effects),
                       stations=list(self.stations), _chain=self._chain)

    # ------------------------------------------------------------------ files
    def to_dict(self) -> dict:
        m = self.machine
        unit = [a.scale for a in m.axes]
        terms = []
        slots = self.slots
        for t in self.terms:
            terms.append({"at": "base frame" if t.target == BASE else slots[t.target][0],
                          "component": COMPONENTS[t.component],
                          "amplitude": t.amplitude / _component_unit(t.component),
                          "family": t.family,
                          "shapes": [{"axis_name": m.axes[s.axis].name} | s.to_dict(unit[s.axis]) for s in t.shapes]})
        return {"format": FORMAT, "version": 1, "machine": m.name, "family": self.family, "seed": self.seed,
                "units": {"amplitude": "mm (dx dy dz) or deg (ex ey ez)", "knots, bump centres and widths":
                          "mm or deg of the shape's axis", "gauge_error": "mm", "repeatability": "mm or deg",
                          "harmonics": "cycles per turn (rotary) or half-periods over the travel (linear)"},
                "meaning": "error value = amplitude * product of the shapes; 'at' an axis or a mimic joint: after "
                           "its motion, in its moving frame (rotation vector); 'base frame': a tool-tip translation",
                "terms": terms,
                "oracle_bases": {a.name: B.to_dict(a.scale) for a, B in zip(m.axes, self.bases)},
                "gauge_error": self.gauge_error * MM_PER_M,
                "repeatability": {a.name: float(a.to_user(s)) for a, s in zip(m.axes, self.repeatability)},
                "tracker": self.tracker.to_dict(),
                "effects": [e.to_dict() for e in self.effects],
                "stations": [s.to_dict() for s in self.stations]}

    def save(self, path: str | Path) -> None:
        write_text(path, json.dumps(self.to_dict(), indent=1))

    @classmethod
    def from_dict(cls, d: dict, machine: Machine) -> "IndependentMachine":
        slots = [(a.name, a.index) for a in machine.axes] + \
                [(mj.name, machine.axis(mj.axis).index) for mj in getattr(machine, "mimic_joints", ())]
        idx = {name: k for k, (name, _) in enumerate(slots)}
        unit = [a.scale for a in machine.axes]
        terms = []
        for t in d["terms"]:
            c = COMPONENTS.index(t["component"])
            shapes = tuple(Shape.from_dict(s, unit[int(s["axis"])]) for s in t["shapes"])
            if t["at"] != "base frame" and t["at"] not in idx:
                raise InputError(f"independent truth: an error 'at' {t['at']!r}, which is no axis or mimic joint of "
                                 f"{machine.name} ({', '.join(idx)})")
            k = BASE if t["at"] == "base frame" else idx[t["at"]]
            driver = slots[k][1] if k >= machine.n_axes else None
            terms.append(Term(k, c, t["amplitude"] * _component_unit(c), shapes, t.get("family", ""), driver))
        bases = [AxisBasis.from_dict(d["oracle_bases"][a.name], a.lower, a.upper, a.kind == "rotary", a.scale)
                 for a in machine.axes]
        rep = np.array([float(a.to_si(d["repeatability"][a.name])) for a in machine.axes])
        return cls(machine, terms, d["family"], bases, d["gauge_error"] / MM_PER_M, rep, Tracker.from_dict(d["tracker"]),
                   d.get("seed"), stations=[Tracker.from_dict(s) for s in d.get("stations", [])])

    @classmethod
    def load(cls, path: str | Path, machine: Machine) -> "IndependentMachine":
        return cls.from_dict(json.loads(Path(path).read_text()), machine)

    # ------------------------------------------------------------------ random truth
    @classmethod
    def random(cls, machine: Machine, family: str, seed: int = 0, mean_error_mm: float = 0.5, share: float | None = None,
               repeatability_mm: float = 0.006, repeatability_deg: float = 0.0015,
               tracker_noise: TrackerNoise | None = None, tracker_distance_m: float = 2.0) -> "IndependentMachine":
        """A machine with an ordinary background plus errors of ``family`` (one of
        :data:`FAMILIES`), drawn from ``seed``. Sizes: the family's terms alone make a
        mean volumetric error of ``share * mean_error_mm`` (default: the family's
        :data:`DEFAULT_SHARE`), the background alone the
        rest, and the whole is scaled to ``mean_error_mm`` (true minus nominal tip,
        machine frame, 400 random commands, tools of 150-350 mm). A gauge-line error of
        40-100 µm; axis repeatability; a tracker ``tracker_distance_m`` in front of the
        travel (spherical noise ``tracker_noise``)."""
        if family not in GENERATORS:
            raise InputError(f"unknown truth family '{family}' (choose {', '.join(FAMILIES)})")
        if not (math.isfinite(mean_error_mm) and mean_error_mm > 0):
            raise InputError(f"mean_error_mm {mean_error_mm!r}: a positive size in mm")
        share = DEFAULT_SHARE[family] if share is None else float(share)
        if not 0 < share < 1:
            raise InputError(f"share {share!r}: the family's part of the mean error, between 0 and 1")
        rng = np.random.default_rng(seed)
        back = background(machine, rng)
        terms, bases = GENERATORS[family](machine, rng)
        back += mimic_terms(back, machine, rng)  # a mimic joint's errors are its own (no draws without one)
        terms += mimic_terms(terms, machine, rng)
        n = machine.n_axes
        raw = cls(machine, [], family, bases, 0.0, np.zeros(n), Tracker(), seed)
        q = uniform_commands(machine, 400, rng)
        tool = rng.uniform(0.15, 0.35, len(q))
        bare = replace(raw, gauge_error=0.0)
        nominal = bare.geometric_tip(q, tool, frame="workpiece")[0]  # the error that matters: tool vs part

        def mean_error(ts):
            raw.terms = ts
            return np.linalg.norm(raw.geometric_tip(q, tool, frame="workpiece")[0] - nominal, axis=1).mean()

        def scaled(ts, target_mm, times):
            for _ in range(times):  # the errors are small: nearly linear in their size
                factor = target_mm * M_PER_MM / mean_error(ts)
                ts = [t.scaled(factor) for t in ts]
            return ts

        both = scaled(scaled(back, (1 - share) * mean_error_mm, 2) + scaled(terms, share * mean_error_mm, 2),
                      mean_error_mm, 3)
        gauge = float(rng.choice([-1, 1]) * rng.uniform(0.04e-3, 0.1e-3))
        rep = np.array([repeatability_mm * M_PER_MM if a.kind == "linear" else math.radians(repeatability_deg)
                        for a in machine.axes])
        tracker = place_tracker(machine, rng, tracker_noise or TrackerNoise(), tracker_distance_m)
        return cls(machine, both, family, bases, gauge, rep, tracker, seed, _chain=raw._chain)
