"""The moves of a measurement program between its points, and the check that the target
holder is free on every one of them (issue 41).

Between two points the program (:mod:`vecpin.planning.ncprogram`) lifts the retract
axis to its safe position, moves the other linear axes, then the rotary axes, then
plunges to the next approach position (:func:`~vecpin.planning.ncprogram.visits`). On a
head machine a tilted holder at the top of the travel can reach into the machine's own
structure (the saddle or carriage the ram slides in). Where that sequence puts the holder
into the machine's geometry, a *swing* replaces it: the previous point's rotary axes turn
to their neutral position (0, or the end of the travel nearest to it) at the highest
height of the retract axis where the lift, that turn and the rest of the lift are free
(``depart``), the transit runs with the rotary axes neutral, and they turn to the next
point's angles at the highest height where the descent, that turn and the plunge are free
(``arrive``); heights tried: the safe position, then every :data:`SWING_STEP` mm down to
the point's own height.

Every move is checked with :func:`vecpin.planning.approaches.move_hits` (the area the
holder's axis sweeps on a move of linear axes, positions every 2 deg on a rotary move),
the holder of the point's row; moves from a position the program does not know (the
first lift and transit, from wherever the machine stands) are not checked.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.plantemplate import PlanTemplate, point_name
from vecpin.planning.approaches import move_hits
from vecpin.planning.retract import retract_axis, safe_position
from vecpin.units import MM_PER_M

SWING_STEP = 50.0  # mm between the heights tried for a swing of the rotary axes


@dataclass
class Visit:
    """One standstill of the program: its tool row ``row``, the retract axis' height before
    the move to it (``lift`` [mm], None: it is high enough already), the approach position
    ``a`` and the point ``q`` (mm, deg, on the 0.001 grid), the rows read there after
    the tool row (``after``: the tool's further readings, the nests and theirs) and which
    of them read again the point of the row before them (``again``, (len(after),) bool:
    :func:`rereads`)."""
    row: int
    lift: float | None
    a: np.ndarray
    q: np.ndarray
    after: range
    again: np.ndarray


def rereads(template: PlanTemplate, reads: int = 1) -> np.ndarray:
    """(N,) bool: the rows that read again the point of the row before them, at its
    standstill: the same instrument, nest, command, holder and station, within runs of
    ``reads`` (a run that reads every point ``reads`` times in a row; 1: none, as a plan
    whose repeated points are re-approached)."""
    n = len(template)
    if reads <= 1 or n < 2:
        return np.zeros(n, bool)
    inst = template.instrument if template.instrument is not None else np.full(n, "tracker", dtype=object)
    target = template.target if template.target is not None else np.full(n, "", dtype=object)
    st = template.stations
    same = np.r_[False, (inst[1:] == inst[:-1]) & (target[1:] == target[:-1]) & (st[1:] == st[:-1])
                 & (template.tool[1:] == template.tool[:-1]) & np.all(template.q[1:] == template.q[:-1], axis=1)]
    first = np.maximum.accumulate(np.where(same, 0, np.arange(n)))  # each row's first row of its run
    return same & ((np.arange(n) - first) % reads != 0)


def visits(machine: Machine, template: PlanTemplate, steps: np.ndarray, r: int, up: int,
           safe: float, reads: int = 1) -> tuple[list[Visit], float | None]:
    """The program's standstills in order and the retract axis' final lift (None: none
    needed): the retract axis ``r`` goes to the highest (``up``) of ``safe``, where it is
    and the next approach position before every move between points; the nest rows and
    the further readings of a point (:func:`rereads` of ``reads``) are read where the tool
    row before them stands (each :class:`Visit` carries which of its rows are such)."""
    is_nest = np.zeros(len(template), bool) if template.instrument is None else template.instrument == "nest"
    again = rereads(template, reads)
    stay = is_nest | again
    q_all = np.round(machine.to_user(template.q), 3)
    step = machine.to_user(np.asarray(steps, float)[None])[0]
    app = template.approach if template.approach is not None else np.zeros_like(template.q)
    out: list[Visit] = []
    cur = None
    for i in np.flatnonzero(~stay):
        a = np.round(q_all[i] - app[i] * step, 3)
        to = max((safe, a[r]) + (() if cur is None else (cur,)), key=lambda v: up * v)
        j = i + 1
        while j < len(template) and stay[j]:
            j += 1
        out.append(Visit(int(i), to if cur is None or up * (to - cur) > 1e-9 else None, a, q_all[i], range(i + 1, j),
                         again[i + 1:j]))
        cur = float(q_all[i][r])
    end = None if cur is None or up * (safe - cur) <= 1e-9 else safe
    return out, end


@dataclass
class Step:
    """One positioning move of the program: ``what`` it is, the axes it programs
    (``axes``, indices), the machine position after it (``to`` (n,) mm, deg) and the
    tool row it belongs to."""

    what: str
    axes: list[int]
    to: np.ndarray
    row: int


def neutral(machine: Machine) -> np.ndarray:
    """(n,) each rotary axis' neutral position [deg]: 0, or its travel's end nearest 0
    (nan on linear axes)."""
    return np.array([min(max(0.0, a.lower_user), a.upper_user) if a.kind == "rotary" else np.nan
                     for a in machine.axes])


class Router:
    """The moves of one program (see the module text): ``sight`` a SightLine (None: the
    plain sequence, unchecked)."""

    def __init__(self, machine: Machine, template: PlanTemplate, steps: np.ndarray, sight=None, *,
                 safe_z_mm: float | None = None, retract: str | None = None, reads: int = 1):
        self.m, self.t, self.sight = machine, template, sight
        self.r, self.up = retract_axis(machine, retract)
        self.safe = safe_position(machine, self.r, self.up, safe_z_mm)
        self.others = [a.index for a in machine.axes if a.kind == "linear" and a.index != self.r]
        self.rotary = [a.index for a in machine.axes if a.kind == "rotary"]
        self.route, self.end = visits(machine, template, steps, self.r, self.up, self.safe, reads)
        self.zero = neutral(machine)

    def _hits(self, moves: list[tuple[np.ndarray, np.ndarray]], rows: list[int]) -> np.ndarray:
        """(M,) the solid the holder of each move's row meets on it ('' free; a move from an
        unknown position (nan) is checked at its end, one to an unknown position not)."""
        out = np.full(len(moves), "", dtype=object)
        keep = [k for k, (_, b) in enumerate(moves) if not np.any(np.isnan(b))]
        if self.sight is None or not keep:
            return out
        mv = [(moves[k][1] if np.any(np.isnan(moves[k][0])) else moves[k][0], moves[k][1]) for k in keep]
        out[keep] = move_hits(self.m, self.sight, mv, np.array([float(self.t.tool[rows[k]]) for k in keep]))
        return out

    def _free(self, moves: list[tuple[np.ndarray, np.ndarray]], row: int) -> str:
        """'' when the holder of ``row`` is free on every move (from, to), else the solid."""
        return next((str(h) for h in self._hits(moves, [row] * len(moves)) if h), "")

    def _with(self, pos: np.ndarray, idx: list[int], values) -> np.ndarray:
        out = pos.copy()
        out[idx] = values if np.isscalar(values) else np.asarray(values)[idx]
        return out

    def _heights(self, low: float) -> list[float]:
        """The swing heights to try, highest first: the safe position, then every
        :data:`SWING_STEP` mm towards ``low`` (the point's height), ``low`` last."""
        span = self.up * (self.safe - low)
        hs = [self.safe - self.up * k * SWING_STEP for k in range(int(max(span, 0.0) // SWING_STEP) + 1)]
        return [round(h, 3) for h in hs] + ([round(low, 3)] if span > 1e-9 else [])

    def steps(self) -> list[Step]:
        """Every positioning move of the program in order (see the module text); refuses a
        program whose holder meets the machine's geometry on a move that no swing frees."""
        r = self.r
        pos, starts, plains, moves, owner = np.full(self.m.n_axes, np.nan), [], [], [], []
        for k, v in enumerate(self.route):
            plain = self._plain(v, pos)
            froms = [pos] + [s.to for s in plain[:-1]]
            moves += [(a, s.to) for a, s in zip(froms, plain)] + [(v.a, v.q)]
            owner += [k] * (len(plain) + 1)
            starts.append(pos)
            plains.append(plain)
            pos = v.q.copy()
        hits = self._hits(moves, [self.route[k].row for k in owner]) if moves else np.zeros(0, object)
        owner, out = np.array(owner), []
        for k, (v, plain) in enumerate(zip(self.route, plains)):
            why = next((str(h) for h in hits[owner == k] if h), "")
            out += self._swing(v, starts[k], plain[0].to[r] if v.lift is not None else starts[k][r], v.row, why) \
                if why and self.rotary else plain
        if self.end is not None:
            out.append(Step("final lift", [r], self._with(pos, [r], self.end), self.route[-1].row))
        return out

    def _plain(self, v: Visit, pos: np.ndarray) -> list[Step]:
        """The plain moves into the point of ``v`` from ``pos`` (nan: unknown): lift, the
        other linear axes, the rotary axes, plunge."""
        r, row = self.r, v.row
        plain = [Step("lift", [r], self._with(pos, [r], v.lift), row)] if v.lift is not None else []
        p = plain[-1].to if plain else pos
        for what, idx in (("transit", self.others), ("rotary move", self.rotary)):
            if idx:
                plain.append(Step(what, idx, self._with(p, idx, v.a), row))
                p = plain[-1].to
        plain.append(Step("plunge", [r], v.a.copy(), row))
        return plain

    def _swing(self, v: Visit, pos: np.ndarray, top: float, row: int, why: str) -> list[Step]:
        """The moves into ``v`` with the rotary axes neutral in the transit (see the module
        text); refuses when no height frees them (``why``: what the plain moves meet)."""
        r, rot, z = self.r, self.rotary, self.zero
        out: list[Step] = []
        p = pos
        if not np.any(np.isnan(pos)):
            for h in self._heights(pos[r]):
                a = self._with(pos, [r], h)
                b = self._with(a, rot, z)
                c = self._with(b, [r], top)
                if not self._free([(pos, a), (a, b), (b, c)], row):
                    out += [Step("lift", [r], a, row), Step("swing", rot, b, row), Step("lift", [r], c, row)]
                    p = c
                    break
            else:
                self._refuse(row, "lift", why)
        else:  # from an unknown position: lifted, then the rotary axes neutral
            out += [Step("lift", [r], self._with(pos, [r], top), row), Step("swing", rot, self._with(pos, rot, z), row)]
            p = self._with(self._with(pos, [r], top), rot, z)
        t = self._with(p, self.others, v.a)
        if self._free([(p, t)], row):
            self._refuse(row, "transit", self._free([(p, t)], row))
        out.append(Step("transit", self.others, t, row))
        for h in self._heights(v.a[r]):
            a = self._with(t, [r], h)
            b = self._with(a, rot, v.a)
            if not self._free([(t, a), (a, b), (b, v.a), (v.a, v.q)], row):
                return out + [Step("descent", [r], a, row), Step("swing", rot, b, row),
                              Step("plunge", [r], v.a.copy(), row)]
        self._refuse(row, "plunge", why)

    def _refuse(self, row: int, what: str, solid: str) -> None:
        raise InputError(f"{point_name(self.t.point[row])}: the {what} puts the target holder "
                         f"({self.t.tool[row] * MM_PER_M:.3f} mm) into {solid} at every height tried; leave the "
                         "point out (`exclude`) or plan shorter `tools_mm`")

__all__ = ["Router", "Step", "Visit", "visits", "rereads", "neutral", "SWING_STEP"]
