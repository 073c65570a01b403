"""The area the target holder sweeps on a move of linear axes, against the machine's
solids (issue 41: a program's plunges, lifts and transits checked as a whole, not at
sampled positions).

On a move of linear axes alone the holder translates relative to every solid, so in the
solid's own frame its axis (gauge line to target centre) sweeps a parallelogram; it is
covered by the axis at both ends and by straight paths of points spread along it
(:func:`_swept`). A solid of the head's own moving chain (the saddle a ram slides in)
counts only where it does not hold the gauge line, as
:meth:`~vecpin.planning.sightline.SightLine.collisions` has it (:func:`_chain_hits`).
Frames: machine base frame and the solids' local frames, metres.
"""
from __future__ import annotations

import numpy as np

from vecpin.planning.sightline import SightLine, Solid, _contains, _segment_hits, _slab, _to_local, spindle_chain

CHAIN_STEP = 0.010  # m of the gauge line's travel between the poses of a moving-chain solid on a swept move


def _swept(s: Solid, n0: np.ndarray, t0: np.ndarray, n1: np.ndarray, t1: np.ndarray, lines: int = 4) -> np.ndarray:
    """(N,) does the area the holder (gauge line n, target centre t; local frame) sweeps
    translating from (n0, t0) to (n1, t1) meet the solid: the holder at both ends and
    ``lines`` + 1 paths of points along it."""
    hit = _segment_hits(s, n0, t0) | _segment_hits(s, n1, t1)
    for u in np.linspace(0.0, 1.0, lines + 1):
        hit |= _segment_hits(s, n0 + u * (t0 - n0), n1 + u * (t1 - n1))
    return hit


def _chain_hits(s: Solid, n0: np.ndarray, t0: np.ndarray, n1: np.ndarray, t1: np.ndarray) -> np.ndarray:
    """(N,) does the holder (gauge line n, target centre t, the solid's local frame) meet
    the solid ``s`` of the head's own chain at some pose of its translation from (n0, t0)
    to (n1, t1) where the gauge line is outside it (as :meth:`SightLine.collisions`): on a
    box the stretches of the move with the gauge line outside, swept (:func:`_swept`);
    another solid posed every :data:`CHAIN_STEP` of the travel."""
    if s.kind == "box":
        lo, hi = _slab(n0, n1 - n0, s.size[None, :])
        ua, ub = np.maximum(lo.max(axis=1), 0.0), np.minimum(hi.min(axis=1), 1.0)
        inside = ua <= ub
        eps = 1e-6 / np.maximum(np.linalg.norm(n1 - n0, axis=1), 1e-9)
        at = lambda p0, p1, u: p0 + u[:, None] * (p1 - p0)  # noqa: E731
        hit = np.zeros(len(n0), bool)
        for u0, u1, ok in ((np.zeros(len(n0)), np.where(inside, ua - eps, 1.0), ~inside | (ua > eps)),
                           (np.where(inside, ub + eps, 1.0), np.ones(len(n0)), inside & (ub < 1.0 - eps))):
            u1 = np.maximum(u0, u1)
            hit |= ok & _swept(s, at(n0, n1, u0), at(t0, t1, u0), at(n0, n1, u1), at(t0, t1, u1))
        return hit
    d = float(np.max(np.linalg.norm(n1 - n0, axis=1))) if len(n0) else 0.0
    k = 4 * int(np.ceil(d / (4 * CHAIN_STEP))) + 1
    u = np.linspace(0.0, 1.0, max(k, 1))[:, None, None]
    nu, tu = (n0 + u * (n1 - n0)).reshape(-1, 3), (t0 + u * (t1 - t0)).reshape(-1, 3)
    return (_segment_hits(s, nu, tu) & ~_contains(s, nu)).reshape(len(u), len(n0)).any(axis=0)


def swept_collisions(sight: SightLine, q0: np.ndarray, q1: np.ndarray, tool: np.ndarray | float,
                     lines: int = 4) -> np.ndarray:
    """(N,) the solid the target holder runs into on the straight moves q0 -> q1 (N,n)
    [m, rad] of the linear axes alone ('' where it is free), the rotary axes the same at
    both ends: relative to every solid the holder then translates, and the area its axis
    sweeps is covered by the axis at both ends and by ``lines`` + 1 straight paths of
    points spread evenly along it, gauge line to target centre (as :meth:`SightLine.collisions`; a
    solid of the head's moving chain does not count where it holds the gauge line:
    :func:`_chain_hits`)."""
    q0, q1 = np.atleast_2d(np.asarray(q0, float)), np.atleast_2d(np.asarray(q1, float))
    tool = np.broadcast_to(np.asarray(tool, float), (len(q0),))
    m = sight.machine
    k0 = m.kinematics(q0, tool, jacobian=False, frame="base")
    k1 = m.kinematics(q1, tool, jacobian=False, frame="base")
    own, chain = spindle_chain(m)
    by = np.full(len(q0), "", dtype=object)
    p0, p1 = sight.solid_poses(q0), sight.solid_poses(q1)
    for k, s in enumerate(sight.solids):
        if s.joint == own:
            continue
        n0, t0 = _to_local(p0[:, k], k0.spindle), _to_local(p0[:, k], k0.tip)
        n1, t1 = _to_local(p1[:, k], k1.spindle), _to_local(p1[:, k], k1.tip)
        # a solid of the head's own chain counts only where it does not hold the gauge line
        hit = _chain_hits(s, n0, t0, n1, t1) if s.joint in chain else _swept(s, n0, t0, n1, t1, lines)
        by[hit & (by == "")] = s.name
    return by


__all__ = ["swept_collisions", "CHAIN_STEP"]
