"""The joint moves of an arm's program between points, kept clear of the arm itself.

Between two points an arm's program makes one joint move, from the last pose of a point
(its retract pose) to the approach pose of the next: the controller interpolates every
joint linearly (URScript ``movej``), and on the way the target holder, a rod of a few
hundred mm on the flange, can sweep through the arm's own links (a UR5's forearm, on
about half of the moves of a random order). Every such move is posed with the planner's
geometry (:meth:`~vecpin.planning.sightline.SightLine.collisions`: the holder's axis
against every solid) at configurations at most :data:`STEP_DEG` apart on every joint,
and between them the area the holder's axis sweeps (:func:`_blocked`).
A move that meets a solid goes through *via* poses instead: one via pose where the
joints split in two groups, one group moved before the other (the wrist's joints first,
or the arm's, at every split), else one of seeded random configurations around the
move's middle (:data:`VIA_TRIES`, the shortest first), else one joint at a time in a few
orders, else two via poses (a random one, then a split); the first route whose every
joint move is free is taken. A move no route frees
is returned by name, for the program's header and the plan's warnings: never a silent
collision.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from vecpin.planning.sightline import _to_local, spindle_chain
from vecpin.planning.sweep import _swept

STEP_DEG = 2.0        # deg: configurations checked along a joint move, at most this apart on every joint
VIA_TRIES = 40        # random via configurations tried for a move the split moves do not free
VIA_SPREAD_DEG = 45.0  # deg: their spread around the move's middle, per joint, at least (or half the joint's move)


def _path(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(k, n) configurations [rad] of the joint move a -> b, ends included."""
    n = int(np.ceil(max(float(np.max(np.abs(b - a))) / np.radians(STEP_DEG), 1.0)))
    return a + np.linspace(0.0, 1.0, n + 1)[:, None] * (b - a)


def _blocked(sight, a: np.ndarray, b: np.ndarray, holder: float) -> str:
    """The first solid the holder meets on the joint move a -> b ('' when free): at every
    configuration of :func:`_path`, and between two of them the area the holder's axis
    sweeps relative to each solid (its axis at both and paths of points along it, in the
    solid's own frame: :func:`~vecpin.planning.sweep._swept`), so that a link crossed
    between two configurations counts. The solids of the flange's own link do not count
    (the holder sits in them); an arm's other links count wherever the holder is, as
    :meth:`SightLine.collisions` has it."""
    q = _path(a, b)
    hit = sight.collisions(q, holder)
    if np.any(hit != ""):
        return str(hit[hit != ""][0])
    m = sight.machine
    kin = m.kinematics(q, np.full(len(q), holder), jacobian=False, frame="base")
    poses = sight.solid_poses(q)
    own, _ = spindle_chain(m)
    for k, s in enumerate(sight.solids):
        if s.joint == own:
            continue
        n, t = _to_local(poses[:, k], kin.spindle), _to_local(poses[:, k], kin.tip)
        if np.any(_swept(s, n[:-1], t[:-1], n[1:], t[1:])):
            return s.name
    return ""


def _sequences(a: np.ndarray, b: np.ndarray) -> list[list[np.ndarray]]:
    """Via poses that move one joint at a time, in a few orders (the wrist's last joint
    first, the base's first, ...)."""
    n = len(a)
    orders = [list(range(n - 1, -1, -1)), list(range(n))]
    orders += [list(range(k, n)) + list(range(k)) for k in range(1, n)]
    out = []
    for order in orders:
        q, vias = a.copy(), []
        for j in order[:-1]:
            q = q.copy()
            q[j] = b[j]
            vias.append(q)
        out.append(vias)
    return out


def _route(sight, machine, a: np.ndarray, b: np.ndarray, holder: float, rng) -> list[np.ndarray] | None:
    """Via poses [rad] whose joint moves a -> via ... -> b are all free, or None."""
    randoms = _randoms(machine, a, b, rng)
    v = _via(sight, a, b, holder, _splits(a, b) + randoms)
    if v is not None:
        return [v]
    for vias in _sequences(a, b):
        ends = [a] + vias + [b]
        if all(not _blocked(sight, p, q, holder) for p, q in zip(ends[:-1], ends[1:])):
            return [v for k, v in enumerate(vias) if not np.allclose(v, ends[k])]
    for v in randoms:   # two via poses: a random one reached freely, then a split move on to b
        if not _blocked(sight, a, v, holder):
            w = _via(sight, v, b, holder, _splits(v, b))
            if w is not None:
                return [v, w]
    return None


def _splits(a: np.ndarray, b: np.ndarray) -> list[np.ndarray]:
    """Via poses that move one group of joints before the other (the wrist's first, or
    the arm's, at every split)."""
    tries = []
    for k in range(1, len(a)):
        first_wrist, first_arm = a.copy(), a.copy()
        first_wrist[k:] = b[k:]
        first_arm[:k] = b[:k]
        tries += [first_wrist, first_arm]
    return tries


def _randoms(machine, a: np.ndarray, b: np.ndarray, rng) -> list[np.ndarray]:
    """Seeded random via poses around the move's middle, inside the joint limits, the
    shortest detour first."""
    spread = np.maximum(np.radians(VIA_SPREAD_DEG), np.abs(b - a) / 2)   # per joint
    mid = (a + b) / 2 + rng.normal(size=(VIA_TRIES, len(a))) * spread
    mid = mid[np.all((mid >= machine.lower) & (mid <= machine.upper), axis=1)]
    travel = np.abs(mid - a).max(axis=1) + np.abs(b - mid).max(axis=1)
    return list(mid[np.argsort(travel)])


def _via(sight, a: np.ndarray, b: np.ndarray, holder: float, tries: list[np.ndarray]) -> np.ndarray | None:
    """The first of ``tries`` whose two joint moves a -> via -> b are free, or None."""
    for v in tries:
        if not _blocked(sight, a, v, holder) and not _blocked(sight, v, b, holder):
            return v
    return None


def free_transits(machine, template, poses: list, sight, seed: int = 0) -> tuple[list, list[str]]:
    """(``poses`` with *via* poses before every approach whose joint move from the pose
    before it meets the machine, the moves no route frees: "P0003 -> P0004 (the holder
    meets link_3)").
    ``poses``: :class:`~vecpin.planning.armprogram.Pose` in program order; the holder of a
    move is the next point's (the program mounts it before the move)."""
    from vecpin.measurement.plantemplate import point_name
    rng = np.random.default_rng(seed)
    out, left = [], []
    for i, p in enumerate(poses):
        if i > 0 and (p.kind == "approach" or (p.kind == "measure" and poses[i - 1].kind != "approach")):
            a, holder = poses[i - 1].q, float(template.tool[p.row])
            hit = _blocked(sight, a, p.q, holder)
            if hit:
                vias = _route(sight, machine, a, p.q, holder, rng)
                if vias is None:
                    left.append(f"{point_name(template.point[poses[i - 1].row])} -> "
                                f"{point_name(template.point[p.row])} (the holder meets {hit})")
                else:
                    out += [replace(p, kind="via", q=v, dwell_s=0.0, reads="") for v in vias]
        out.append(p)
    return out, left


__all__ = ["free_transits", "STEP_DEG"]
