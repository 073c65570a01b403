"""Approach moves that cannot collide: every position a measurement program passes on its
way into a point, posed with the machine's geometry as the point itself is.

A program reaches a point ``q`` (machine coordinates, mm and degrees) in three moves
after the transit at the safe height (:mod:`vecpin.planning.ncprogram`): the retract
axis plunges from its safe position to the approach position ``a = q - sign * step``
(the other axes already there), then one move at the feed from ``a`` to ``q``. The
approach ``sign`` per axis (+1 from below, -1 from above, 0 none) is chosen per point
among candidates, in this order:

1. the plan's sign on every axis, but the retract axis always from the side away from
   the work (``-up``): no rapid ever passes a point toward the work;
2. the same with every other axis from the opposite side;
3. along the retract axis alone (the tool's axis at zero rotary angles);
4. the plan's sign on the other axes and none on the retract axis (its plunge ends at
   the point's own height).

A candidate is free when its approach position lies inside the travel and the holder
(its axis from the gauge line to the target centre, as
:meth:`~vecpin.planning.sightline.SightLine.collisions` poses it) meets no solid on
either move (:func:`move_hits`). A point whose candidates all collide is dropped by the
plan ('collision', the solid named with "(approach)"). Every move is taken as a straight
line in axis space (linear interpolation, as ``L``, ``G1`` and a linear-interpolated
``G0`` move).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.planning.retract import retract_axis, safe_position
from vecpin.planning.sweep import swept_collisions

PLUNGE_STEP = 20.0   # mm between the positions checked on a move that turns a rotary axis too
ROTARY_STEP = 2.0    # deg between the positions checked on a move of a rotary axis
MODE_SIGNS = {"below": (1,), "above": (-1,), "both": (1, -1), "none": (0,)}


@dataclass(frozen=True)
class Retract:
    """The retract axis ``axis`` (index), ``up`` (+1 when its + direction moves the tool
    back from the work) and its safe machine position ``safe`` [mm]."""

    axis: int
    up: int
    safe: float


def planning_retract(machine: Machine) -> Retract | None:
    """The retract axis the programs use by default (None: the machine has none, e.g. an
    arm, whose approaches are not planned here)."""
    try:
        r, up = retract_axis(machine)
    except InputError:
        return None
    return Retract(r, up, safe_position(machine, r, up, None))


def candidate_signs(sign: np.ndarray, r: int, up: int) -> list[np.ndarray]:
    """The approach signs (n,) to try for a point the plan approaches with ``sign`` (n,),
    in order (see the module text); none but zeros for a point without approach."""
    sign = np.asarray(sign, int)
    if not np.any(sign):
        return [np.zeros_like(sign)]
    base = sign.copy()
    base[r] = -up
    flip = -sign
    flip[r] = -up
    only = np.zeros_like(sign)
    only[r] = -up
    level = sign.copy()
    level[r] = 0
    out: list[np.ndarray] = []
    for c in (base, flip, only, level):
        if np.any(c) and not any(np.array_equal(c, o) for o in out):
            out.append(c)
    return out


def move_hits(machine: Machine, sight, moves, tool: np.ndarray) -> np.ndarray:
    """(M,) the solid the target holder meets on each straight move (from, to) (mm, deg)
    in axis space with holder lengths ``tool`` (M,) [m] ('' where it is free): a move of
    linear axes alone by the area the holder's axis sweeps
    (:func:`~vecpin.planning.sweep.swept_collisions`), a move of a rotary
    axis at positions every :data:`ROTARY_STEP` deg and :data:`PLUNGE_STEP` mm
    (:meth:`~vecpin.planning.sightline.SightLine.collisions`). ``moves``: a list of
    pairs, or the pair of arrays (M, n) from and to."""
    if isinstance(moves, tuple):
        a, b = (np.asarray(x, float) for x in moves)
    else:
        a = np.array([m[0] for m in moves], float).reshape(len(moves), machine.n_axes)
        b = np.array([m[1] for m in moves], float).reshape(len(moves), machine.n_axes)
    out = np.full(len(a), "", dtype=object)
    if not len(a):
        return out
    tool = np.asarray(tool, float)
    rot = np.array([x.kind == "rotary" for x in machine.axes])
    lin = ~np.any(np.abs(a[:, rot] - b[:, rot]) > 1e-9, axis=1)
    if lin.any():
        out[lin] = swept_collisions(sight, machine.to_si(a[lin]), machine.to_si(b[lin]), tool[lin])
    rows = np.flatnonzero(~lin)
    if len(rows):  # each move in pieces of at most PLUNGE_STEP mm and ROTARY_STEP deg, every piece's ends posed
        step = np.where(rot, ROTARY_STEP, PLUNGE_STEP)
        k = np.ceil(np.max(np.abs(b[rows] - a[rows]) / step, axis=1) - 1e-9).astype(int)
        paths, owner = [], []
        for kk in np.unique(k):
            sel = rows[k == kk]
            t = np.linspace(0.0, 1.0, kk + 1)[None, :, None]
            paths.append((a[sel][:, None] + t * (b[sel] - a[sel])[:, None]).reshape(-1, a.shape[1]))
            owner.append(np.repeat(sel, kk + 1))
        owner = np.concatenate(owner)
        hits = sight.collisions(machine.to_si(np.vstack(paths)), tool[owner])
        bad = hits != ""
        first = {}
        for i, h in zip(owner[bad], hits[bad]):
            first.setdefault(i, h)
        for i, h in first.items():
            out[i] = str(h)
    return out


def choose(machine: Machine, sight, q: np.ndarray, tool: np.ndarray, sign: np.ndarray, steps: np.ndarray,
           rt: Retract) -> tuple[np.ndarray, np.ndarray]:
    """((N, n) int approach signs, (N,) why none is free ('' where one is)) of the points
    ``q`` (N, n) [m, rad] with holders ``tool`` (N,) [m], planned with ``sign`` (N, n);
    ``steps`` (n,) [m, rad] the approach distance per axis. The first free candidate
    (:func:`candidate_signs`) of each point; for one without: the solid its first
    candidate meets (or "travel": every approach position is outside the travel)."""
    qu = np.round(machine.to_user(np.atleast_2d(q)), 3)
    step = machine.to_user(np.asarray(steps, float)[None])[0]
    lo = np.array([a.lower_user for a in machine.axes]) - 1e-9
    hi = np.array([a.upper_user for a in machine.axes]) + 1e-9
    tool = np.broadcast_to(np.asarray(tool, float), (len(qu),))
    sign = np.asarray(sign, int)
    out = np.zeros_like(sign)
    why = np.full(len(qu), "", dtype=object)
    todo = np.ones(len(qu), bool)
    kinds, which = np.unique(sign, axis=0, return_inverse=True)
    which = which.reshape(-1)
    cands = [candidate_signs(k, rt.axis, rt.up) for k in kinds]
    for level in range(max(len(c) for c in cands)):
        S = np.array([c[level] if level < len(c) else c[0] for c in cands])[which]
        rows = np.flatnonzero(todo & np.array([level < len(c) for c in cands])[which])
        a = np.round(qu[rows] - S[rows] * step, 3)
        inside = np.all((a >= lo) & (a <= hi), axis=1)
        why[rows[~inside]] = np.where(why[rows[~inside]] == "", "travel", why[rows[~inside]])
        rows, a = rows[inside], a[inside]
        if not len(rows):
            continue
        top = a.copy()
        top[:, rt.axis] = rt.up * np.maximum(rt.up * rt.safe, rt.up * a[:, rt.axis])
        hits = move_hits(machine, sight, (np.vstack([top, a]), np.vstack([a, qu[rows]])), np.tile(tool[rows], 2))
        h = np.where(hits[:len(rows)] != "", hits[:len(rows)], hits[len(rows):])
        free = h == ""
        out[rows[free]], todo[rows[free]], why[rows[free]] = S[rows[free]], False, ""
        first = rows[~free]
        why[first] = np.where((why[first] == "") | (why[first] == "travel"), h[~free], why[first])
    return out, why


def free_commands(machine: Machine, sight, q: np.ndarray, tool: float, mode: str, steps: np.ndarray,
                  rt: Retract | None) -> np.ndarray:
    """(N,) the solid (or "travel") that leaves the commands q (N, n) [m, rad] without a
    free approach with holder ``tool`` [m] in approach ``mode`` ('' where every approach
    the mode needs has a free candidate)."""
    why = np.full(len(q), "", dtype=object)
    if rt is None or not len(q):
        return why
    for s in MODE_SIGNS[mode]:
        _, w = choose(machine, sight, q, np.full(len(q), tool), np.full(q.shape, s, int), steps, rt)
        why = np.where(why == "", w, why)
    return why


def safe_template(machine: Machine, sight, template, steps: np.ndarray, rt: Retract | None):
    """``template`` with the approach of every row that moves (a tool row with an
    approach) replaced by its first free candidate (:func:`choose`); refuses a row
    without one (the plan screens its commands with :func:`free_commands` first)."""
    if rt is None or template.approach is None or sight is None:
        return template
    rows = np.flatnonzero(np.any(template.approach != 0, axis=1))
    if not len(rows):
        return template
    signs, why = choose(machine, sight, template.q[rows], template.tool[rows], template.approach[rows], steps, rt)
    bad = np.flatnonzero(why != "")
    if len(bad):
        k = rows[bad[0]]
        raise InputError(f"point {int(template.point[k])}: every approach puts the target holder into "
                         f"{why[bad[0]]}; leave it out (`exclude`) or plan shorter `tools_mm`")
    out = template.take(np.arange(len(template)))
    out.approach = template.approach.copy()
    out.approach[rows] = signs
    return out


__all__ = ["Retract", "planning_retract", "candidate_signs", "move_hits", "choose",
           "free_commands", "safe_template", "PLUNGE_STEP", "ROTARY_STEP", "MODE_SIGNS"]
