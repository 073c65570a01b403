"""The joint moves of an arm's program between points, kept clear of the arm itself.

Between two points an arm's program makes one joint move, from the last pose of a point
(its retract pose) to the approach pose of the next: the controller interpolates every
joint linearly (URScript ``movej``), and on the way the target holder, a rod of a few
hundred mm on the flange, can sweep through the arm's own links (a UR5's forearm, on
about half of the moves of a random order). Every such move is posed with the planner's
geometry (:meth:`~vecpin.planning.sightline.SightLine.collisions`: the holder, a
cylinder of the plan's holder radius, against every solid) at configurations at most
:data:`STEP_DEG` apart on every joint, and between them the area the holder's axis
sweeps against the solids grown by that radius (:func:`blocked_moves`, all the moves of
a batch posed in one vectorised call).

A move that meets a solid goes through *via* poses instead:

1. one via pose: of the poses where the joints split in two groups (one group moved
   before the other) and :data:`VIA_TRIES` seeded random configurations around the
   move's middle, the free one with the shortest detour (the largest joint move, the
   time of a ``movej``, a -> via -> b);
2. else a roadmap (a probabilistic roadmap, PRM): :data:`ROADMAP_NODES` free random
   configurations in a box about the move, widened each round up to every joint's
   travel, each joined to its :data:`NEIGHBOURS` nearest (largest joint move) by the
   free joint moves; the shortest route a -> b through it (Dijkstra), then shortened:
   the shortest route over the free direct moves between its own poses.

A move no route frees is returned by name, for the program's header and the plan's
warnings: never a silent collision.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial.distance import cdist

from vecpin.planning.sightline import _holder_hits, _to_local, spindle_chain
from vecpin.planning.sweep import _swept

STEP_DEG = 2.0        # deg: configurations checked along a joint move, at most this apart on every joint
VIA_TRIES = 48        # random one-via configurations tried for a blocked move
VIA_SPREAD_DEG = 45.0  # deg: their spread around the move's middle, per joint, at least (or half the joint's move)
ROADMAP_NODES = (120, 300, 600)   # random configurations of the roadmap, per round (the box widened each round)
ROADMAP_MARGIN_DEG = (45.0, 120.0, 360.0)  # deg: the box about the move's ends, per round (clipped to the travel)
NEIGHBOURS = 8        # roadmap poses joined to each
VIA_BATCH = 12        # one-via tries posed at once


def _path_params(A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the move each configuration belongs to (K,), its fraction of the move (K,)) of
    the joint moves A -> B (E, n) [rad], ends included, at most :data:`STEP_DEG` apart."""
    n = np.ceil(np.max(np.abs(B - A), axis=1, initial=0.0) / np.radians(STEP_DEG)).astype(int)
    n = np.maximum(n, 1)
    edge = np.repeat(np.arange(len(A)), n + 1)
    first = np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)
    return edge, (np.arange(len(edge)) - first) / n[edge]


def blocked_moves(sight, A: np.ndarray, B: np.ndarray, holder: np.ndarray | float) -> np.ndarray:
    """(E,) the first solid the holder meets on each joint move A -> B (E, n) [rad]
    ('' where free), holders ``holder`` [m] ((E,) or one): at configurations at most
    :data:`STEP_DEG` apart, and between two of them the area the holder's axis sweeps
    relative to each solid grown by the holder's radius (its axis at both and paths of
    points along it, in the solid's own frame: :func:`~vecpin.planning.sweep._swept`), so
    that a link crossed between two configurations counts (a mesh, which is not grown: its
    lines at the holder's radius at every configuration). The solids of the flange's own
    link do not count (the holder sits in them)."""
    A, B = np.atleast_2d(np.asarray(A, float)), np.atleast_2d(np.asarray(B, float))
    by = np.full(len(A), "", dtype=object)
    if not len(A):
        return by
    edge, s = _path_params(A, B)
    q = A[edge] + s[:, None] * (B - A)[edge]
    L = np.broadcast_to(np.asarray(holder, float), (len(A),))[edge]
    i = np.flatnonzero(edge[:-1] == edge[1:])      # consecutive configurations of one move
    for sol, n, t in _holder_in_solids(sight, q, L):
        # posed only where the swept area can reach the solid's bounding sphere: every point of
        # it lies within the larger of the two ends' displacements of the holder at the first
        near = _near(sol, n, t)
        reach = np.maximum(np.linalg.norm(n[i + 1] - n[i], axis=1), np.linalg.norm(t[i + 1] - t[i], axis=1))
        j = i[(near[i] <= reach) & (by[edge[i]] == "")]
        if not len(j):
            continue
        hit = _swept(sol, n[j], t[j], n[j + 1], t[j + 1])
        if sol.kind == "mesh" and len(sol.size):   # the lines off the axis at the holder's radius
            off = _holder_hits(sol, n, t)
            hit |= off[j] | off[j + 1]
        e = np.unique(edge[j[hit]])
        by[e[by[e] == ""]] = sol.name
    return by


def _near(s, n: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(N,) how far [m] the segments n-t (the solid's own frame) pass outside the sphere
    about its origin that holds the solid (<= 0: they may meet it)."""
    if s.kind == "box":
        r = float(np.linalg.norm(s.size))
    elif s.kind == "cylinder":
        r = float(np.hypot(*s.size))
    elif s.kind == "sphere":
        r = float(s.size[0])
    else:
        r = float(np.linalg.norm(s.vertices, axis=1).max()) + (float(s.size[0]) if len(s.size) else 0.0)
    d = t - n
    u = np.clip(-np.einsum("ij,ij->i", n, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-30), 0.0, 1.0)
    return np.linalg.norm(n + u[:, None] * d, axis=1) - r


def _holder_in_solids(sight, q: np.ndarray, L: np.ndarray):
    """(solid grown by the holder's radius, gauge line (N, 3), target centre (N, 3)) in the
    solid's own frame [m], for every solid but those of the flange's own link, at the
    configurations q (N, n) [rad] with holders L (N,) [m]: every joint posed once for all
    configurations (:func:`~vecpin.planning.sightline._joint_placements`), the points
    taken into each joint's frame, then into each solid's (a fixed placement)."""
    m = sight.machine
    own, _ = spindle_chain(m)
    solids = [s for s in sight.holder_solids() if s.joint != own]
    oMi = _placements(m.model, m.full_q(q))
    if oMi is None:   # a joint _placements does not pose: Pinocchio pose by pose
        kin = m.kinematics(q, L, jacobian=False, frame="base")
        poses = sight.solid_poses(q)
        keep = [k for k, s in enumerate(sight.solids) if s.joint != own]
        for k, s in zip(keep, solids):
            yield s, _to_local(poses[:, k], kin.spindle), _to_local(poses[:, k], kin.tip)
        return
    fr = m.model.frames[m.spindle_frame_id]
    R, t = oMi[fr.parentJoint]
    nose = t + R @ fr.placement.translation
    tip = nose + (R @ (fr.placement.rotation @ m.tool_axis)) * L[:, None]
    in_joint = {}
    for j in {s.joint for s in solids}:
        R, t = oMi[j]
        in_joint[j] = (np.einsum("nij,ni->nj", R, nose - t), np.einsum("nij,ni->nj", R, tip - t))
    for s in solids:
        Rt, p = s.placement[:3, :3], s.placement[:3, 3]
        n, t = in_joint[s.joint]
        yield s, (n - p) @ Rt, (t - p) @ Rt


def _placements(model, qf: np.ndarray) -> dict[int, tuple[np.ndarray, np.ndarray]] | None:
    """{joint: (rotation (N, 3, 3), position (N, 3))} of every joint in the base frame at
    the configurations qf (N, nq), as Pinocchio's ``forwardKinematics`` gives them, for a
    chain of revolute and prismatic joints (one product of a stack with a 3 x 3 matrix per
    joint); None with another kind of joint."""
    N = len(qf)
    out = {0: (np.broadcast_to(np.eye(3), (N, 3, 3)), np.zeros((N, 3)))}
    for j in range(1, model.njoints):
        jm = model.joints[j]
        kind = jm.shortname().replace("JointModel", "")
        if kind[:1] in "RP" and kind[1:] in ("X", "Y", "Z"):
            axis = np.eye(3)["XYZ".index(kind[1:])]
        elif kind in ("RevoluteUnaligned", "PrismaticUnaligned"):
            axis = np.asarray(jm.extract().axis, float)
        else:
            return None
        R0, t0 = out[model.parents[j]]
        P = model.jointPlacements[j]
        A = (R0.reshape(-1, 3) @ P.rotation).reshape(N, 3, 3)
        t = t0 + R0 @ P.translation
        x = qf[:, jm.idx_q]
        if kind[0] == "R":
            K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
            AK = (A.reshape(-1, 3) @ K).reshape(N, 3, 3)
            AKK = (AK.reshape(-1, 3) @ K).reshape(N, 3, 3)
            A = A + np.sin(x)[:, None, None] * AK + (1.0 - np.cos(x))[:, None, None] * AKK
        else:
            t = t + x[:, None] * (A @ axis)
        out[j] = (A, t)
    return out


def _cost(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The largest joint move [rad] a -> b (the time of a ``movej`` at one joint speed)."""
    return np.max(np.abs(np.asarray(b) - np.asarray(a)), axis=-1)


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


def _inside(machine, q: np.ndarray) -> np.ndarray:
    return q[np.all((q >= machine.lower) & (q <= machine.upper), axis=1)]


def posed_hits(sight, q: np.ndarray, holder: np.ndarray | float) -> np.ndarray:
    """(N,) the first solid the holder meets at the configurations q (N, n) [rad] with
    holders ``holder`` [m] ('' where free), the solids grown by the holder's radius (as
    :meth:`~vecpin.planning.sightline.SightLine.collisions` on an arm)."""
    q = np.atleast_2d(np.asarray(q, float))
    by = np.full(len(q), "", dtype=object)
    for sol, n, t in _holder_in_solids(sight, q, np.broadcast_to(np.asarray(holder, float), (len(q),))):
        by[_holder_hits(sol, n, t) & (by == "")] = sol.name
    return by


def _one_via(sight, machine, a: np.ndarray, b: np.ndarray, holder: float, rng) -> np.ndarray | None:
    """The free via pose with the shortest detour a -> via -> b among the splits and
    :data:`VIA_TRIES` random poses around the move's middle (checked in batches of
    :data:`VIA_BATCH`, the shortest detours first), or None."""
    spread = np.maximum(np.radians(VIA_SPREAD_DEG), np.abs(b - a) / 2)   # per joint
    tries = np.vstack(_splits(a, b) + [(a + b) / 2 + rng.normal(size=(VIA_TRIES, len(a))) * spread])
    tries = _inside(machine, tries)
    tries = tries[posed_hits(sight, tries, holder) == ""]
    tries = tries[np.argsort(_cost(a, tries) + _cost(tries, b), kind="stable")]
    for c in range(0, len(tries), VIA_BATCH):
        v = tries[c:c + VIA_BATCH]
        k = len(v)
        hit = blocked_moves(sight, np.vstack([np.repeat(a[None], k, 0), v]), np.vstack([v, np.repeat(b[None], k, 0)]),
                            holder)
        ok = np.flatnonzero((hit[:k] == "") & (hit[k:] == ""))
        if len(ok):
            return v[ok[0]]
    return None


def _shortest(nodes: np.ndarray, i: np.ndarray, j: np.ndarray) -> list[int] | None:
    """The node indices of the shortest route 0 -> 1 over the moves (i, j) (both ways,
    weighed by :func:`_cost`), or None."""
    w = np.maximum(_cost(nodes[i], nodes[j]), 1e-12)
    g = coo_matrix((w, (i, j)), shape=(len(nodes),) * 2).tocsr()
    dist, pred = dijkstra(g, directed=False, indices=0, return_predecessors=True)
    if not np.isfinite(dist[1]):
        return None
    route, k = [1], 1
    while k != 0:
        k = int(pred[k])
        route.append(k)
    return route[::-1]


def _shorten(sight, route: np.ndarray, holder: float) -> np.ndarray:
    """``route`` (m, n) [rad], every move between consecutive poses free, shortened: the
    shortest route over the free direct moves between any two of its poses."""
    i, j = np.triu_indices(len(route), 2)
    free = blocked_moves(sight, route[i], route[j], holder) == ""
    k = np.arange(len(route) - 1)
    order = [0, len(route) - 1] + list(range(1, len(route) - 1))   # _shortest goes from node 0 to node 1
    nodes = route[order]
    back = np.argsort(order)
    keep = _shortest(nodes, back[np.r_[k, i[free]]], back[np.r_[k + 1, j[free]]])
    return nodes[keep]


def _lazy_route(sight, nodes: np.ndarray, pairs: np.ndarray, known: dict, holder: float) -> list[int] | None:
    """The shortest route 0 -> 1 over the moves ``pairs`` (P, 2) whose every move is free,
    the moves checked lazily (only those on a shortest route, :func:`blocked_moves`),
    their verdicts kept in ``known`` {(i, j): free}."""
    state = np.array([known.get((int(i), int(j)), True) for i, j in pairs], bool)   # free or not yet checked
    checked = np.array([(int(i), int(j)) in known for i, j in pairs], bool)
    at = {(int(i), int(j)): k for k, (i, j) in enumerate(pairs)}
    while state.any():
        route = _shortest(nodes, pairs[state, 0], pairs[state, 1])
        if route is None:
            return None
        on = np.array([at[tuple(sorted((int(i), int(j))))] for i, j in zip(route[:-1], route[1:])])
        new = on[~checked[on]]
        if not len(new):
            return route
        free = blocked_moves(sight, nodes[pairs[new, 0]], nodes[pairs[new, 1]], holder) == ""
        state[new], checked[new] = free, True
        known.update(zip(map(tuple, pairs[new].tolist()), free.tolist()))
    return None


def _roadmap(sight, machine, a: np.ndarray, b: np.ndarray, holder: float, rng) -> np.ndarray | None:
    """The via poses (m, n) [rad] of a route a -> b through a roadmap of free random
    configurations (:data:`ROADMAP_NODES`, the box widened each round; the moves checked
    lazily: :func:`_lazy_route`), shortened; None when no round joins a and b."""
    nodes, known = np.vstack([a, b]), {}
    for count, margin in zip(ROADMAP_NODES, ROADMAP_MARGIN_DEG):
        lo = np.maximum(np.minimum(a, b) - np.radians(margin), machine.lower)
        hi = np.minimum(np.maximum(a, b) + np.radians(margin), machine.upper)
        x = lo + rng.random((count, len(a))) * (hi - lo)
        nodes = np.vstack([nodes, x[posed_hits(sight, x, holder) == ""]])
        d = cdist(nodes, nodes, "chebyshev")
        near = np.argsort(d, axis=1)[:, 1:NEIGHBOURS + 1]
        i = np.repeat(np.arange(len(nodes)), near.shape[1])
        pairs = np.unique(np.sort(np.c_[i, near.ravel()], axis=1), axis=0)
        route = _lazy_route(sight, nodes, pairs, known, holder)
        if route is not None:
            return _shorten(sight, nodes[route], holder)[1:-1]
    return None


def route_move(sight, machine, a: np.ndarray, b: np.ndarray, holder: float, rng) -> list[np.ndarray] | None:
    """Via poses [rad] whose joint moves a -> via ... -> b are all free (one via pose when
    one does, else through a roadmap), or None."""
    if np.any(posed_hits(sight, np.vstack([a, b]), holder) != ""):
        return None   # an end of the move meets the machine itself: no route frees it
    v = _one_via(sight, machine, a, b, holder, rng)
    if v is not None:
        return [v]
    vias = _roadmap(sight, machine, a, b, holder, rng)
    return None if vias is None else list(vias)


def free_transits(machine, template, poses: list, sight, seed: int = 0) -> tuple[list, list[str]]:
    """(``poses`` with *via* poses before every approach whose joint move from the pose
    before it meets the machine, the moves no route frees: "P0003 -> P0004 (the holder
    meets link_3)").
    ``poses``: :class:`~vecpin.planning.armprogram.Pose` in program order; the holder of a
    move is the next point's (the program mounts it before the move)."""
    from vecpin.measurement.plantemplate import point_name
    rng = np.random.default_rng(seed)
    moves = [i for i, p in enumerate(poses)
             if i > 0 and (p.kind == "approach" or (p.kind == "measure" and poses[i - 1].kind != "approach"))]
    holders = np.array([float(template.tool[poses[i].row]) for i in moves])
    hit = blocked_moves(sight, np.array([poses[i - 1].q for i in moves]).reshape(-1, machine.n_axes),
                        np.array([poses[i].q for i in moves]).reshape(-1, machine.n_axes), holders)
    vias_at, left = {}, []
    for k in np.flatnonzero(hit != ""):
        i = moves[k]
        vias = route_move(sight, machine, poses[i - 1].q, poses[i].q, holders[k], rng)
        if vias is None:
            left.append(f"{point_name(template.point[poses[i - 1].row])} -> "
                        f"{point_name(template.point[poses[i].row])} (the holder meets {hit[k]})")
        else:
            vias_at[i] = vias
    out = []
    for i, p in enumerate(poses):
        out += [replace(p, kind="via", q=v, dwell_s=0.0, reads="") for v in vias_at.get(i, [])]
        out.append(p)
    return out, left


__all__ = ["free_transits", "blocked_moves", "route_move", "STEP_DEG"]
