"""The true machine of a simulation: smooth 6-DoF errors per axis, gauge-line error,
axis repeatability, and a laser tracker placed off the machine.

Error functions are written in the same 6-DoF frame convention as the model
(:mod:`vecpin.errorframes`) but from a *different* function family: a short
Chebyshev series plus harmonics of non-integer frequency on linear axes, and
eccentricity/wobble/index harmonics on rotary axes, so a fitted Chebyshev model
never contains the truth exactly. A truth file stores everything in mm and
degrees (with the unit in each key).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vecpin.models.basis import chebyshev, normalise
from vecpin.kinematics.errorframes import ErrorFrames
from vecpin.fileio import write_text
from vecpin.kinematics.machine import Machine
from vecpin.measurement.tracker import Tracker, TrackerNoise
from vecpin.planning.sightline import tracker_side
from vecpin.units import MM_PER_M, M_PER_MM

COMPONENTS = ("dx", "dy", "dz", "ex", "ey", "ez")  # translations [m], rotations [rad], axis-local frame


@dataclass
class ErrorFunction:
    """f(q) = sum_j c_j T_j(u) + sum_h (a_h cos(w_h t) + b_h sin(w_h t)).

    u is q normalised over the travel; the harmonic argument t is ``pi * u`` on a
    linear axis and the angle ``q`` [rad] on a rotary axis. Values SI.
    """

    chebyshev: list[float] = field(default_factory=list)
    harmonics: list[tuple[float, float, float]] = field(default_factory=list)  # (w, a_cos, b_sin)

    def __call__(self, q: np.ndarray, lower: float, upper: float, rotary: bool) -> np.ndarray:
        q = np.asarray(q, float)
        u = normalise(q, lower, upper)
        out = np.zeros_like(q)
        if self.chebyshev:
            out += chebyshev(u, len(self.chebyshev) - 1) @ np.asarray(self.chebyshev)
        t = q if rotary else math.pi * u
        for w, a, b in self.harmonics:
            out += a * np.cos(w * t) + b * np.sin(w * t)
        return out

    def scaled(self, s: float) -> "ErrorFunction":
        return ErrorFunction([c * s for c in self.chebyshev], [(w, a * s, b * s) for w, a, b in self.harmonics])


class SimulatedMachine:
    """What every simulated true machine shares: the simulated effects, the tracker
    stations, axis repeatability and the measurements. A subclass supplies the geometry:
    :meth:`geometric_tip` (the noise-free tool tip and tool direction of a command).

    Attributes a subclass sets: ``machine``, ``tracker`` (:class:`Tracker`),
    ``repeatability`` ((n,) 1-sigma axis noise [m, rad]), ``stations`` (further trackers,
    ids 1, 2, ...), ``effects`` (simulated effects, applied when features are given).
    """

    machine: Machine
    tracker: Tracker
    repeatability: np.ndarray
    stations: list
    effects: list

    def geometric_tip(self, q: np.ndarray, tool: np.ndarray, *, frame: str = "base", point=0,
                      offset: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(tip (N,3) [m], unit tool direction (N,3)) for commands q (N,n) [m, rad] and
        tool lengths (N,) [m] from the nominal gauge line: in the machine base frame, or
        relative to the true workpiece frame (``frame="workpiece"``); tool point
        ``point`` (index or (N,) indices), target ``offset`` (3,) or (N,3) [m] in the tool
        link frame."""
        raise NotImplementedError

    def geometric_workpiece_points(self, q: np.ndarray, p_wp: np.ndarray) -> np.ndarray:
        """(N,3) [m] points fixed at p_wp (3,) or (N,3) [m] in the true workpiece frame, in
        the base frame (a table nest); fixed in the base frame without a workpiece."""
        raise NotImplementedError

    def tool_tip(self, q: np.ndarray, tool: np.ndarray | float, features=None, *, frame: str = "base", point=0,
                 offset: np.ndarray | None = None) -> np.ndarray:
        """Noise-free true tool tip (N,3) [m] in the base frame (or relative to the
        workpiece). Geometric effects (a skew, coupled axes) are part of the machine and
        always act; row-dependent ones (thermal, backlash) act when ``features`` (time,
        temperature, move order) are given (tip effects act in the base frame)."""
        q = np.atleast_2d(np.asarray(q, float))
        active = [e for e in self.effects if features is not None or e.geometric]
        for e in active:
            q = q + e.simulate_command(q, features)
        tool = np.broadcast_to(np.asarray(tool, float), (len(q),))
        tip_effects = any(type(e).simulate_tip is not _base_simulate_tip(e) for e in active)
        relative = frame == "workpiece" and self.machine.has_workpiece
        if relative and tip_effects:  # effects act on the base-frame tip: move it there, then relative
            tip, tool_dir = self.geometric_tip(q, tool, frame="base", point=point, offset=offset)
            for e in active:
                tip = e.simulate_tip(q, tip, tool_dir, features)
            R, o = self.workpiece_frame(q)
            return np.einsum("pji,pj->pi", R, tip - o)
        tip, tool_dir = self.geometric_tip(q, tool, frame=frame, point=point, offset=offset)
        for e in active:
            tip = e.simulate_tip(q, tip, tool_dir, features)
        return tip

    def workpiece_frame(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(R (N,3,3), origin (N,3)) of the true workpiece frame in the base frame (from
        four of its points: the frame is rigid)."""
        q = np.atleast_2d(np.asarray(q, float))
        o = self.geometric_workpiece_points(q, np.zeros(3))
        R = np.stack([self.geometric_workpiece_points(q, e) - o for e in np.eye(3)], axis=-1)
        return R, o

    def workpiece_points(self, q: np.ndarray, p_wp: np.ndarray, features=None) -> np.ndarray:
        """True points fixed in the workpiece frame (N,3) [m], base frame, with the command
        effects (geometric ones always, row-dependent ones when ``features`` are given)."""
        q = np.atleast_2d(np.asarray(q, float))
        for e in [e for e in self.effects if features is not None or e.geometric]:
            q = q + e.simulate_command(q, features)
        return self.geometric_workpiece_points(q, p_wp)

    def measure_radius(self, q: np.ndarray, tool: np.ndarray, pivot: np.ndarray, sigma: float,
                       rng: np.random.Generator | None) -> np.ndarray:
        """Ball bar readings [m]: |true tip - pivot| with axis and ball bar noise (eq. 46, 65)."""
        q = np.atleast_2d(np.asarray(q, float))
        if rng is not None:
            q = q + rng.standard_normal(q.shape) * self.repeatability
        r = np.linalg.norm(self.tool_tip(q, tool) - pivot, axis=1)
        return r if rng is None else r + rng.normal(0, sigma, len(r))

    def measure(self, q: np.ndarray, tool: np.ndarray | float, rng: np.random.Generator | None,
                features=None, station: int = 0, *, point=0, offset: np.ndarray | None = None,
                nest: np.ndarray | None = None, dq: np.ndarray | None = None) -> np.ndarray:
        """Tracker readings (N,3) [m]: axis repeatability noise on the commands, then the
        true kinematics (with the simulated effects when ``features`` are given), the
        tracker pose, tracker noise in spherical coordinates and gross errors.
        ``rng=None``: noise-free (and no gross errors). The point read is the tool tip
        of tool point ``point`` with target ``offset`` [m] (tool link frame), or, with
        ``nest`` (3,) or (N,3) [m], a reflector fixed at that position in the workpiece
        frame. ``dq`` (N,n) [m, rad]: the axes' positioning noise of each row drawn by the
        caller (rows read at one standstill share it), instead of a draw per row."""
        q = np.atleast_2d(np.asarray(q, float))
        if rng is not None:
            q = q + (rng.standard_normal(q.shape) * self.repeatability if dq is None else dq)
        tracker = self.tracker if station == 0 else self.stations[station - 1]
        p = (self.workpiece_points(q, nest, features) if nest is not None
             else self.tool_tip(q, tool, features, point=point, offset=offset))
        y = tracker.to_tracker(p)
        if features is not None:
            for e in self.effects:
                y = e.simulate_tracker(y, features)
        if rng is None:
            return y
        y = tracker.add_noise(y, rng)
        if features is not None:
            for e in self.effects:
                y = e.simulate_gross(y)
        return y

    def calibrate_effects(self, q: np.ndarray, tool: np.ndarray, features) -> None:
        """Scale every effect not sized yet so that its RMS tool-tip displacement over these
        rows is its ``strength_mm`` (outliers: the size of the gross errors); a truth's
        effects keep that scale in every later run (and in its file). On a machine with a
        workpiece the displacement of a machine effect is that of the tip relative to the
        workpiece (an effect of a table axis moves the part, not the tip in the base
        frame); a tracker effect's is that of the readings."""
        effects, self.effects = self.effects, []
        relative = self.machine.has_workpiece

        def displaced(e):
            if relative and "tracker" not in e.kinds:
                return self.tool_tip(q, tool, features, frame="workpiece")
            return self.measure(q, tool, None, features)
        for e in effects:
            if e.flags_rows or getattr(e, "calibrated", False):   # a truth's effects are sized once, when drawn
                continue
            base = displaced(e)
            e.scale = 1.0
            self.effects = [e]
            rms = np.sqrt((np.linalg.norm(displaced(e) - base, axis=1) ** 2).mean())
            self.effects = []
            e.scale = e.strength_mm * M_PER_MM / rms if rms > 0 else 0.0
            e.calibrated = True
        self.effects = effects


@dataclass
class TrueMachine(SimulatedMachine):
    """Ground truth for simulated campaigns (SI inside).

    errors[k][c]: error function of slot k (the axes, then mimic joints: :func:`error_slots`),
    component c in :data:`COMPONENTS`;
    perturbations[i][j]: optional axis perturbation f_ij (input i, output j), the
    AP form of error (eq. 7-8), applied to the commands before the 6-DoF chain;
    harmonics[k]: the harmonic frequencies axis k's functions use (the family);
    gauge_error: actual minus nominal gauge-line offset along the tool [m];
    repeatability: (n,) 1-sigma axis positioning noise [m, rad];
    tracker: its pose and noise.
    """

    machine: Machine
    errors: list[list[ErrorFunction]]
    gauge_error: float
    repeatability: np.ndarray
    tracker: Tracker
    perturbations: list[list[ErrorFunction | None]] | None = None
    harmonics: list[tuple[float, ...]] | None = None
    effects: list = field(default_factory=list)  # simulated effects (vecpin.models.effects), with features
    stations: list = field(default_factory=list)  # further tracker positions (Tracker), ids 1, 2, ...
    _frames: ErrorFrames | None = field(default=None, repr=False)

    @property
    def frames(self) -> ErrorFrames:
        if self._frames is None:
            self._frames = ErrorFrames(self.machine)
        return self._frames

    def error_values(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """delta (N,S,3) [m] and eps (N,S,3) [rad] of every slot (axes, then mimic joints,
        each a function of its driving axis) at commands q."""
        q = np.atleast_2d(q)
        slots = error_slots(self.machine)
        vals = np.zeros((len(q), len(slots), 6))
        for k, (_, a, _) in enumerate(slots):
            if k >= len(self.errors):
                break
            for c in range(6):
                vals[:, k, c] = self.errors[k][c](q[:, a.index], a.lower, a.upper, a.kind == "rotary")
        return vals[..., :3], vals[..., 3:]

    def perturbed(self, q: np.ndarray) -> np.ndarray:
        """Commands after the true axis perturbations (eq. 7), [m, rad]."""
        if not self.perturbations:
            return q
        out = q.copy()
        for i, a in enumerate(self.machine.axes):
            for j in range(self.machine.n_axes):
                f = self.perturbations[i][j]
                if f is not None:
                    out[:, j] += f(q[:, i], a.lower, a.upper, a.kind == "rotary")
        return out

    def family_bases(self, order: int = 4) -> list:
        """One basis per axis that contains every true error function exactly
        (Chebyshev up to ``order`` plus the axis' harmonics): fitting it gives the
        noise-limited floor."""
        from vecpin.models.basis import AxisBasis
        harm = self.harmonics or [()] * self.machine.n_axes
        return [AxisBasis(a.lower, a.upper, order, "chebyshev", tuple(h), a.kind == "rotary")
                for a, h in zip(self.machine.axes, harm)]

    def geometric_tip(self, q: np.ndarray, tool: np.ndarray, *, frame: str = "base", point=0,
                      offset: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Tip and tool direction of the 6-DoF error chain after the axis perturbations."""
        q = self.perturbed(np.atleast_2d(np.asarray(q, float)))
        delta, eps = self.error_values(q)
        out = self.frames.tool_tip(q, delta, eps, np.asarray(tool, float) + self.gauge_error, jacobian=False,
                                   frame=frame, point=point, offset=offset)
        return out.tip, out.tool_dir

    def geometric_workpiece_points(self, q: np.ndarray, p_wp: np.ndarray) -> np.ndarray:
        q = self.perturbed(np.atleast_2d(np.asarray(q, float)))
        delta, eps = self.error_values(q)
        return self.frames.workpiece_points(q, delta, eps, p_wp, jacobian=False).xyz

    # ------------------------------------------------------------------ files
    def to_dict(self) -> dict:
        axes = {}
        for k, (name, a, _) in enumerate(error_slots(self.machine)):
            comp = {}
            for c, cname in enumerate(COMPONENTS):
                f = self.errors[k][c]
                s = 1e3 if c < 3 else 180 / math.pi
                comp[cname] = {"chebyshev": [v * s for v in f.chebyshev],
                               "harmonics": [[w, x * s, y * s] for w, x, y in f.harmonics]}
            axes[name] = comp
        return {"format": "vecpin-truth", "version": 1, "machine": self.machine.name,
                "units": {"dx dy dz": "mm", "ex ey ez": "deg", "gauge_error": "mm", "repeatability": "mm or deg"},
                "axis_errors": axes, "gauge_error": self.gauge_error * MM_PER_M,
                "harmonics": {a.name: list(h) for a, h in zip(self.machine.axes, self.harmonics or [()] * self.machine.n_axes)},
                "axis_perturbations": self._perturbations_dict(),
                "repeatability": {a.name: float(a.to_user(s)) for a, s in zip(self.machine.axes, self.repeatability)},
                "tracker": self.tracker.to_dict(),
                "effects": [e.simulation_dict() for e in self.effects],
                "stations": [s.to_dict() for s in self.stations]}

    def _perturbations_dict(self) -> dict:
        out = {}
        for i, ai in enumerate(self.machine.axes):
            for j, aj in enumerate(self.machine.axes):
                f = (self.perturbations or [[None] * self.machine.n_axes] * self.machine.n_axes)[i][j]
                if f is not None:
                    s = 1e3 if aj.kind == "linear" else 180 / math.pi
                    out[f"{ai.name}->{aj.name}"] = {"chebyshev": [v * s for v in f.chebyshev],
                                                   "harmonics": [[w, x * s, y * s] for w, x, y in f.harmonics]}
        return out

    def save(self, path: str | Path) -> None:
        write_text(path, json.dumps(self.to_dict(), indent=1))

    @classmethod
    def from_dict(cls, d: dict, machine: Machine) -> "TrueMachine":
        errors = []
        for slot, _, _ in error_slots(machine):
            row = []
            for c, name in enumerate(COMPONENTS):
                s = 1e-3 if c < 3 else math.pi / 180
                e = d["axis_errors"].get(slot, {}).get(name, {"chebyshev": [], "harmonics": []})
                row.append(ErrorFunction([v * s for v in e["chebyshev"]], [(w, x * s, y * s) for w, x, y in e["harmonics"]]))
            errors.append(row)
        rep = np.array([float(a.to_si(d["repeatability"][a.name])) for a in machine.axes])
        pert = None
        if d.get("axis_perturbations"):
            pert = [[None] * machine.n_axes for _ in machine.axes]
            for i, ai in enumerate(machine.axes):
                for j, aj in enumerate(machine.axes):
                    e = d["axis_perturbations"].get(f"{ai.name}->{aj.name}")
                    if e is not None:
                        s = 1e-3 if aj.kind == "linear" else math.pi / 180
                        pert[i][j] = ErrorFunction([v * s for v in e["chebyshev"]], [(w, x * s, y * s) for w, x, y in e["harmonics"]])
        harm = [tuple(d.get("harmonics", {}).get(a.name, ())) for a in machine.axes]
        stations = [Tracker.from_dict(s) for s in d.get("stations", [])]
        return cls(machine, errors, d["gauge_error"] * M_PER_MM, rep, Tracker.from_dict(d["tracker"]), pert, harm,
                   [_simulated_effect(e, machine) for e in d.get("effects", [])], stations)

    @classmethod
    def load(cls, path: str | Path, machine: Machine) -> "TrueMachine":
        return cls.from_dict(json.loads(Path(path).read_text()), machine)

    # ------------------------------------------------------------------ random truth
    @classmethod
    def random(cls, machine: Machine, rng: np.random.Generator, mean_error_mm: float = 0.5,
               repeatability_mm: float = 0.006, repeatability_deg: float = 0.0015,
               tracker_noise: TrackerNoise | None = None, tracker_distance_m: float = 2.0,
               family: str = "6dof") -> "TrueMachine":
        """A plausible machine with smooth errors scaled so that the mean volumetric
        error (true minus nominal tip, machine frame, over the axis space and tools
        of 150-350 mm) is ``mean_error_mm``; a gauge-line error of 40-100 µm; a
        tracker standing ``tracker_distance_m`` in front of the travel.

        ``family="6dof"``: 6-DoF errors on every axis: on linear axes a Chebyshev
        series to order 4 plus one harmonic of 0.5-1.5 periods over the travel (smooth
        but not polynomial), pitch dominating; on rotary axes location offsets
        (eccentricity), runout, index error and wobble at 1 and 2 cycles per turn.
        ``family="ap"``: the same kind of functions as axis perturbations f_ij
        (eq. 7-8) instead, the AP model's own family."""
        um, urad = 1e-6, 1e-6
        n = machine.n_axes
        harmonics = [(float(rng.uniform(0.5, 1.5)),) if a.kind == "linear" else (1.0, 2.0) for a in machine.axes]
        slots = error_slots(machine)
        errors = [[ErrorFunction() for _ in range(6)] for _ in slots]
        perturbations = None
        if family == "6dof":
            for k, (_, a, direction) in enumerate(slots):
                along = int(np.argmax(np.abs(direction)))
                for c in range(6):
                    if a.kind == "linear":
                        s = 50 * um if c < 3 else 30 * urad
                        cheb = rng.normal(size=5) * s / (1 + np.arange(5)) ** 1.5
                        if c == along:
                            cheb[1] += rng.choice([-1, 1]) * 100 * um  # scale (pitch) error dominates positioning
                        w = harmonics[a.index][0]
                        harm = [(w, rng.normal() * s / 2, rng.normal() * s / 2)]
                    elif c < 3:  # location offset (constant in the moving frame: eccentric circle) and runout
                        cheb = [rng.normal() * (150 * um if c != along else 50 * um)]
                        harm = [(1.0, rng.normal() * 20 * um, rng.normal() * 20 * um),
                                (2.0, rng.normal() * 10 * um, rng.normal() * 10 * um)]
                    elif c - 3 == along:  # index error: encoder eccentricity, 1st and 2nd harmonic
                        cheb = [rng.normal() * 30 * urad]
                        harm = [(1.0, rng.normal() * 100 * urad, rng.normal() * 100 * urad),
                                (2.0, rng.normal() * 30 * urad, rng.normal() * 30 * urad)]
                    else:  # tilt (squareness to the previous axis) and wobble
                        cheb = [rng.normal() * 100 * urad]
                        harm = [(1.0, rng.normal() * 40 * urad, rng.normal() * 40 * urad)]
                    errors[k][c] = ErrorFunction([float(v) for v in cheb], [(float(w), float(x), float(y)) for w, x, y in harm])
        elif family == "ap":
            perturbations = [[None] * n for _ in range(n)]
            for i, ai in enumerate(machine.axes):
                for j, aj in enumerate(machine.axes):
                    s = 40 * um if aj.kind == "linear" else 60 * urad
                    cheb = rng.normal(size=5) * s / (1 + np.arange(5)) ** 1.5
                    if ai.kind == "rotary":  # a rotary input repeats every turn: periodic terms only
                        cheb = cheb[:1]
                    cheb[0] = cheb[0] if i == 0 else 0.0  # one constant per output axis
                    hs = s if ai.kind == "rotary" else s / 3
                    harm = [(w, rng.normal() * hs, rng.normal() * hs) for w in harmonics[i]]
                    perturbations[i][j] = ErrorFunction([float(v) for v in cheb], [(float(w), float(x), float(y)) for w, x, y in harm])
        else:
            raise ValueError("family is '6dof' or 'ap'")
        raw = cls(machine, errors, 0.0, np.zeros(n), Tracker(), perturbations, harmonics)
        # scale to the requested mean volumetric error (errors are small: nearly linear)
        q = uniform_commands(machine, 400, rng)
        tool = rng.uniform(0.15, 0.35, len(q))
        nominal = machine.tool_tip(q, tool, frame="workpiece")  # the error that matters: tool vs part
        for _ in range(3):
            mean = np.linalg.norm(raw.tool_tip(q, tool, frame="workpiece") - nominal, axis=1).mean()
            s = mean_error_mm * M_PER_MM / mean
            raw.errors = [[f.scaled(s) for f in row] for row in raw.errors]
            if raw.perturbations:
                raw.perturbations = [[f.scaled(s) for f in row] for row in raw.perturbations]
        gauge = float(rng.choice([-1, 1]) * rng.uniform(0.04e-3, 0.1e-3))
        rep = np.array([repeatability_mm * M_PER_MM if a.kind == "linear" else math.radians(repeatability_deg) for a in machine.axes])
        tracker = place_tracker(machine, rng, tracker_noise or TrackerNoise(), tracker_distance_m)
        return cls(machine, raw.errors, gauge, rep, tracker, raw.perturbations, harmonics)


def _simulated_effect(d: dict, machine: Machine):
    """A simulated effect as a truth file keeps it (:meth:`Effect.simulation_dict`): its size,
    seed and calibrated scale restored, so a reloaded truth displaces the tip as the saved one."""
    from vecpin.models.effects.base import REGISTRY
    from vecpin.errors import VecpinError
    if d.get("name") not in REGISTRY:
        raise VecpinError(f"unknown effect '{d.get('name')}' in the truth file (known: {', '.join(REGISTRY)})")
    e = REGISTRY[d["name"]](machine, d.get("axes", ()), strength_mm=d.get("strength_mm", 0.05),
                            seed=d.get("seed", 0), **d.get("options", {}))
    e.scale, e.calibrated = float(d.get("scale", 1.0)), True
    return e


def error_slots(machine: Machine) -> list[tuple[str, object, tuple]]:
    """(joint name, driving axis, joint direction) of every error transform: the axes,
    then the mimic joints (a mirrored head's slides are parts of their own)."""
    out = [(a.name, a, a.direction) for a in machine.axes]
    for mj in machine.mimic_joints:
        out.append((mj.name, machine.axis(mj.axis), tuple(machine.tree.joints[mj.name].axis)))
    return out


def _base_simulate_tip(effect):
    """The base class' simulate_tip (no tip effect), to tell which effects move the tip."""
    from vecpin.models.effects.base import Effect
    return Effect.simulate_tip


def uniform_commands(machine: Machine, n: int, rng: np.random.Generator) -> np.ndarray:
    """n commands uniformly random over the axis limits [m, rad]."""
    return machine.lower + rng.random((n, machine.n_axes)) * (machine.upper - machine.lower)


def place_tracker(machine: Machine, rng: np.random.Generator, noise: TrackerNoise, distance_m: float,
                  side: float = 0.0) -> Tracker:
    """A tracker standing ``distance_m`` in front (-y side) of the tool-tip workspace,
    on the floor level of the workspace, with a random heading and a tilt below 2°; on a
    machine whose geometry hides the tips from the front, on the side and at the height
    where it sees them (:func:`vecpin.planning.sightline.tracker_side`).
    ``side`` [rad] turns the stand position about the workspace centre (other stations)."""
    q = uniform_commands(machine, 200, rng)
    tips = np.vstack([machine.tool_tip(q, 0.25, frame="base", point=k) for k in range(len(machine.tool_links))])
    lo, hi = tips.min(axis=0), tips.max(axis=0)
    centre = (lo + hi) / 2
    position = np.array([centre[0] + rng.uniform(-0.2, 0.2) * (hi[0] - lo[0]), lo[1] - distance_m,
                         lo[2] + rng.uniform(0.0, 0.3) * (hi[2] - lo[2])])
    az, height = tracker_side(machine, 0.25, distance_m)  # where the machine's geometry lets it see the tips
    if az:
        position[2] += height - lo[2]
    if side or az:
        from vecpin.kinematics.so3 import exp3 as _exp3
        position = centre + _exp3(np.array([0.0, 0.0, side + az])) @ (position - centre)
    yaw = rng.uniform(-math.pi, math.pi)
    tilt_axis = rng.normal(size=3)
    tilt_axis[2] = 0
    tilt = np.radians(rng.uniform(0, 2.0)) * tilt_axis / np.linalg.norm(tilt_axis)
    from vecpin.kinematics.so3 import exp3
    R = exp3(tilt) @ exp3(np.array([0, 0, yaw]))  # machine -> tracker rotation
    return Tracker(R, -R @ position, noise)
