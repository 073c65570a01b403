"""Line of sight from the laser tracker to the target, past the machine's own geometry.

Paper I Fig. 6 removes points where the tracker cannot see the target ("LoS"). Here the
obstacles are the machine's URDF geometry posed at each command: the collision geometry
when the URDF has any, else the visual geometry (boxes, cylinders, spheres and meshes),
plus the tool holder as a cylinder from the gauge line to the target. The sight line is
the segment from the tracker head to the target centre, cut short by
``target_clearance`` at the target end (the retroreflector's own radius: the holder
the target sits on does not block its own centre). A command is blocked when that
segment meets any solid.

Every test is closed form and vectorised over poses: slab test for boxes, quadratic
intervals for cylinders (axis along local z, as URDF and Pinocchio define them) and
spheres, Möller-Trumbore for mesh triangles. Frames: machine base frame, metres.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pinocchio as pin

from vecpin.errors import MachineError
from vecpin.kinematics.axes import is_arm
from vecpin.kinematics.machine import Machine

DEFAULT_TOOL_RADIUS = 0.010       # m, radius of the target holder (tool shank)
DEFAULT_TARGET_CLEARANCE = 0.0191  # m, radius of a 1.5 in retroreflector (38.1 mm ball)


@dataclass
class Solid:
    """One obstacle: ``kind`` "box" (``size`` = half sides (3,)), "cylinder" (radius,
    half length along local z), "sphere" (radius,) or "mesh" (``vertices`` (V,3),
    ``triangles`` (T,3) in the local frame). ``placement`` (4,4) is the solid's pose in
    the frame of joint ``joint`` (0: the fixed base)."""

    name: str
    kind: str
    joint: int
    placement: np.ndarray
    size: np.ndarray
    vertices: np.ndarray | None = None
    triangles: np.ndarray | None = None


@dataclass
class SightResult:
    """``blocked`` (N,) per command; ``by`` (N,) name of the first solid met ('' if
    visible); ``distance`` (N,) tracker-to-target distance [m]."""

    blocked: np.ndarray
    by: np.ndarray
    distance: np.ndarray


def _load_geometry(machine: Machine, which: str) -> tuple[pin.GeometryModel, str]:
    dirs = [str(machine.urdf_path.parent)] if machine.urdf_path is not None else []
    kinds = {"collision": pin.GeometryType.COLLISION, "visual": pin.GeometryType.VISUAL}
    order = ["collision", "visual"] if which == "auto" else [which]
    last = None
    for k in order:
        try:
            gm = pin.buildGeomFromUrdfString(machine.model, machine.urdf_xml, kinds[k], package_dirs=dirs)
        except (RuntimeError, ValueError) as exc:
            raise MachineError(f"{machine.source}: its {k} geometry cannot be loaded ({exc}); "
                               "a mesh file may be missing") from None
        last = (gm, k)
        if gm.ngeoms:
            return gm, k
    return last


def solids_from_urdf(machine: Machine, which: str = "auto") -> tuple[list[Solid], str]:
    """The machine's obstacles and which geometry they came from ("collision"/"visual").

    ``which``: "auto" (collision if the URDF has any, else visual), "collision" or
    "visual". Geometry types other than box, cylinder, sphere and mesh raise."""
    gm, used = _load_geometry(machine, which)
    out = []
    for go in gm.geometryObjects:
        g = go.geometry
        kind = type(g).__name__
        M = go.placement.homogeneous.copy()
        if kind == "Box":
            out.append(Solid(go.name, "box", go.parentJoint, M, np.asarray(g.halfSide, float).copy()))
        elif kind == "Cylinder":
            out.append(Solid(go.name, "cylinder", go.parentJoint, M, np.array([g.radius, g.halfLength])))
        elif kind == "Sphere":
            out.append(Solid(go.name, "sphere", go.parentJoint, M, np.array([g.radius])))
        elif kind.startswith("BVHModel"):
            V = np.asarray(g.vertices(), float).copy()
            T = np.array([[g.tri_indices(i)[j] for j in range(3)] for i in range(g.num_tris)], int)
            out.append(Solid(go.name, "mesh", go.parentJoint, M, np.zeros(0), V, T))
        else:
            raise MachineError(f"{machine.source}: geometry '{go.name}' is a {kind}; the sight-line test knows "
                               "boxes, cylinders, spheres and meshes")
    return out, used


class SightLine:
    """Line-of-sight test for one machine and one tracker position.

    ``tracker`` (3,) [m], machine base frame: the centre of the tracker head.
    ``tool_radius`` [m] (0: no holder), ``target_clearance`` [m]: see the module text.
    """

    def __init__(self, machine: Machine, tracker: np.ndarray, *, geometry: str = "auto",
                 tool_radius: float = DEFAULT_TOOL_RADIUS, target_clearance: float = DEFAULT_TARGET_CLEARANCE,
                 solids: list[Solid] | None = None):
        self.machine = machine
        self.tracker = np.asarray(tracker, float).reshape(3)
        if solids is None:
            solids, self.geometry = solids_from_urdf(machine, geometry)
        else:
            self.geometry = "given"
        self.solids = solids
        self.tool_radius = float(tool_radius)
        self.target_clearance = float(target_clearance)
        self._data = machine.model.createData()

    # ------------------------------------------------------------------ poses
    def solid_poses(self, q: np.ndarray) -> np.ndarray:
        """(N, S, 4, 4) placement of every solid in the base frame at commands q (N,n)."""
        q = np.atleast_2d(np.asarray(q, float))
        m = self.machine
        joints = sorted({s.joint for s in self.solids})
        qf = m.full_q(q)
        oMi = _joint_placements(m.model, qf)
        if oMi is not None:
            return np.stack([oMi[:, s.joint] @ s.placement for s in self.solids], axis=1) if self.solids else \
                np.zeros((len(q), 0, 4, 4))
        oMi = np.empty((len(q), m.model.njoints, 4, 4))
        oMi[:] = np.eye(4)
        for i in range(len(q)):  # one Pinocchio call per pose (~1 µs)
            pin.forwardKinematics(m.model, self._data, qf[i])
            for j in joints:
                oMi[i, j] = self._data.oMi[j].homogeneous
        return np.stack([oMi[:, s.joint] @ s.placement for s in self.solids], axis=1) if self.solids else \
            np.zeros((len(q), 0, 4, 4))

    def inside_fixed(self) -> list[str]:
        """Names of fixed solids (on the base) that contain the tracker position."""
        out = []
        for s in self.solids:
            if s.joint != 0:
                continue
            p = np.linalg.solve(s.placement, np.r_[self.tracker, 1.0])[:3][None]
            if _contains(s, p)[0]:
                out.append(s.name)
        return out

    # ------------------------------------------------------------------ test
    def check(self, q: np.ndarray, tool: np.ndarray | float) -> SightResult:
        """Which commands q (N,n) [m, rad] with tool lengths [m] the tracker cannot see."""
        q = np.atleast_2d(np.asarray(q, float))
        tool = np.broadcast_to(np.asarray(tool, float), (len(q),))
        kin = self.machine.kinematics(q, tool, jacobian=False, frame="base")
        return self._sight(q, kin.tip, kin, tool)

    def check_nests(self, q: np.ndarray, p_wp: np.ndarray, tool: np.ndarray | float) -> SightResult:
        """Which readings of reflectors fixed in the workpiece (table) frame at p_wp (3,)
        or (N,3) [m] the tracker cannot see at commands q (N,n) [m, rad]: the table nests
        of a machine with table axes. The machine's geometry is posed at each command,
        the holder of length ``tool`` [m] in the spindle included (it can hide a nest)."""
        q = np.atleast_2d(np.asarray(q, float))
        tool = np.broadcast_to(np.asarray(tool, float), (len(q),))
        target = self.machine.workpiece_points(q, p_wp, jacobian=False).xyz
        kin = self.machine.kinematics(q, tool, jacobian=False, frame="base")
        return self._sight(q, target, kin, tool)

    @property
    def holder_radius(self) -> float:
        """[m] the holder's radius :meth:`collisions` counts: ``tool_radius`` on an arm (every
        pose its program visits is checked with the holder as a cylinder), 0 on a machine
        with linear axes (the holder's axis, the spindle's own solids then hold it)."""
        return self.tool_radius if is_arm(self.machine) else 0.0

    def holder_solids(self) -> list[Solid]:
        """The solids grown by :attr:`holder_radius` (:func:`grown`): the holder's axis meets
        one of them where the holder, a cylinder of that radius, may meet the solid."""
        return [grown(s, self.holder_radius) for s in self.solids]

    def collisions(self, q: np.ndarray, tool: np.ndarray | float) -> np.ndarray:
        """(N,) the name of the solid the target holder runs into at commands q (N,n)
        [m, rad] with holder lengths ``tool`` [m] ('' where it is free): a solid met by
        the holder's axis from the gauge line to the target centre, the solids grown by
        the holder's radius (:meth:`holder_solids`). The solids on the
        tool link's own joint (the spindle the holder sits in) do not count, nor a solid
        of the head's moving chain that holds the gauge line itself (coarse geometry: a
        saddle's box the ram slides through); on an arm the flange inside one of its own
        links is the arm folded into itself, and counts. A command that collides is not a
        line-of-sight loss: the machine cannot go there at all."""
        q = np.atleast_2d(np.asarray(q, float))
        tool = np.broadcast_to(np.asarray(tool, float), (len(q),))
        kin = self.machine.kinematics(q, tool, jacobian=False, frame="base")
        m = self.machine
        own, chain = spindle_chain(m)
        if is_arm(m):
            chain = set()
        by = np.full(len(q), "", dtype=object)
        poses = self.solid_poses(q)
        for k, s in enumerate(self.holder_solids()):
            if s.joint == own:
                continue
            H = poses[:, k]
            nose = _to_local(H, kin.spindle)
            hit = _holder_hits(s, nose, _to_local(H, kin.tip)) & (by == "")
            if s.joint in chain:
                hit &= ~_contains(s, nose)
            by[hit] = s.name
        return by

    def _sight(self, q: np.ndarray, target: np.ndarray, kin, tool: np.ndarray) -> SightResult:
        """The sight lines from the tracker to ``target`` (N,3) [m], base frame, past the
        solids posed at q and the holder of length ``tool`` (tool kinematics ``kin``)."""
        N = len(q)
        seg = target - self.tracker
        dist = np.linalg.norm(seg, axis=1)
        keep = np.clip(1.0 - self.target_clearance / np.maximum(dist, 1e-12), 0.0, 1.0)
        p0 = np.broadcast_to(self.tracker, (N, 3))
        p1 = self.tracker + seg * keep[:, None]
        blocked = np.zeros(N, bool)
        by = np.full(N, "", dtype=object)
        poses = self.solid_poses(q)
        for k, s in enumerate(self.solids):
            H = poses[:, k]
            hit = _segment_hits(s, _to_local(H, p0), _to_local(H, p1))
            new = hit & ~blocked
            by[new] = s.name
            blocked |= hit
        if self.tool_radius > 0:
            # the holder: a cylinder along the tool from the gauge line to the target
            H = np.zeros((N, 4, 4))
            H[:, :3, :3] = kin.rotation
            H[:, :3, 3] = kin.spindle - kin.rotation[:, :, 2] * (tool / 2)[:, None]
            H[:, 3, 3] = 1.0
            hit = _segment_cylinder(_to_local(H, p0), _to_local(H, p1), np.full(N, self.tool_radius), tool / 2)
            new = hit & ~blocked
            by[new] = "tool holder"
            blocked |= hit
        return SightResult(blocked, by, dist)


# ---------------------------------------------------------------------- geometry
_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


def _joint_placements(model: pin.Model, qf: np.ndarray) -> np.ndarray | None:
    """(N, njoints, 4, 4) every joint's placement in the base frame at the configurations
    qf (N, nq), as Pinocchio's ``forwardKinematics`` gives them, computed for all poses
    at once (revolute and prismatic joints, aligned or not); None when the model has
    another kind of joint (a mimic joint: the caller asks Pinocchio pose by pose)."""
    N = len(qf)
    out = np.empty((N, model.njoints, 4, 4))
    out[:, 0] = np.eye(4)
    for j in range(1, model.njoints):
        jm = model.joints[j]
        kind = jm.shortname().replace("JointModel", "")
        if kind[:1] in "RP" and kind[1:] in _AXES:
            axis = np.array(_AXES[kind[1:]])
        elif kind in ("RevoluteUnaligned", "PrismaticUnaligned"):
            axis = np.asarray(jm.extract().axis, float)
        else:
            return None
        x = qf[:, jm.idx_q]
        T = np.broadcast_to(np.eye(4), (N, 4, 4)).copy()
        if kind[0] == "R":
            K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
            c, s = np.cos(x)[:, None, None], np.sin(x)[:, None, None]
            T[:, :3, :3] = np.eye(3) + s * K + (1.0 - c) * (K @ K)
        else:
            T[:, :3, 3] = x[:, None] * axis
        out[:, j] = out[:, model.parents[j]] @ model.jointPlacements[j].homogeneous @ T
    return out


def _to_local(H: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Points p (N,3) in the base frame into the frames H (N,4,4)."""
    R, t = H[:, :3, :3], H[:, :3, 3]
    return np.einsum("nji,nj->ni", R, p - t)


def _contains(s: Solid, p: np.ndarray) -> np.ndarray:
    if s.kind == "box":
        return np.all(np.abs(p) <= s.size, axis=1)
    if s.kind == "cylinder":
        return (np.hypot(p[:, 0], p[:, 1]) <= s.size[0]) & (np.abs(p[:, 2]) <= s.size[1])
    if s.kind == "sphere":
        return np.linalg.norm(p, axis=1) <= s.size[0]
    # mesh: a ray to +x crosses a closed surface an odd number of times from inside
    far = p + np.array([1e3, 0.0, 0.0])
    n_cross = _segment_triangles(p, far, s.vertices, s.triangles, count=True)
    return n_cross % 2 == 1


def grown(s: Solid, r: float) -> Solid:
    """The solid ``s`` grown by ``r`` [m] all round, so that a segment meeting it marks a
    cylinder of radius ``r`` about the segment that may meet ``s`` (a box's half sides and a
    cylinder's radius and half length + r: a little more than the exact grown shape; a
    sphere's radius + r: exact). A mesh keeps its triangles and gets ``size`` = (r,):
    :func:`_holder_hits` tests it with lines ``r`` off the axis."""
    if r <= 0:
        return s
    return replace(s, size=np.asarray(s.size, float) + r if s.kind != "mesh" else np.array([r]))


def _holder_hits(s: Solid, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """(N,) does the holder, the segment p0-p1 (local frame) with the radius a mesh of
    :func:`grown` carries, meet the solid: its axis, and on a mesh also 4 lines at that
    radius about it (the mesh's own triangles)."""
    hit = _segment_hits(s, p0, p1)
    if s.kind != "mesh" or not len(s.size):
        return hit
    d = p1 - p0
    e = np.where(np.abs(d[:, :1]) < 0.9 * np.linalg.norm(d, axis=1, keepdims=True), [[1.0, 0, 0]], [[0, 1.0, 0]])
    u = np.cross(d, e)
    u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-15)
    v = np.cross(d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-15), u)
    for w in (u, -u, v, -v):
        hit |= _segment_hits(s, p0 + s.size[0] * w, p1 + s.size[0] * w)
    return hit


def _segment_hits(s: Solid, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    N = len(p0)
    if s.kind == "box":
        return _segment_box(p0, p1, s.size)
    if s.kind == "cylinder":
        return _segment_cylinder(p0, p1, np.full(N, s.size[0]), np.full(N, s.size[1]))
    if s.kind == "sphere":
        return _segment_sphere(p0, p1, s.size[0])
    return _segment_triangles(p0, p1, s.vertices, s.triangles) > 0


def _interval_and(lo, hi, a, b):
    return np.maximum(lo, a), np.minimum(hi, b)


def _slab(p0: np.ndarray, d: np.ndarray, half) -> tuple[np.ndarray, np.ndarray]:
    """Parameter interval [t0, t1] of p0 + t d inside |x| <= half (per component, N,)."""
    par = np.abs(d) < 1e-15
    with np.errstate(divide="ignore", invalid="ignore"):
        a = (-half - p0) / d
        b = (half - p0) / d
    t0, t1 = np.minimum(a, b), np.maximum(a, b)
    inside = np.abs(p0) <= half
    t0 = np.where(par, np.where(inside, -np.inf, np.inf), t0)
    t1 = np.where(par, np.where(inside, np.inf, -np.inf), t1)
    return t0, t1


def _segment_box(p0: np.ndarray, p1: np.ndarray, half: np.ndarray) -> np.ndarray:
    """(N,) does the segment p0-p1 (local frame) meet the box |x_i| <= half_i?"""
    t0, t1 = _slab(p0, p1 - p0, half[None, :])
    lo = np.maximum(t0.max(axis=1), 0.0)
    hi = np.minimum(t1.min(axis=1), 1.0)
    return lo <= hi


def _quadratic_interval(a, b, c):
    """Interval of t where a t^2 + b t + c <= 0 (a >= 0); empty as (inf, -inf)."""
    lo = np.full(a.shape, np.inf)
    hi = np.full(a.shape, -np.inf)
    flat = a < 1e-30
    lo = np.where(flat & (c <= 0), -np.inf, lo)
    hi = np.where(flat & (c <= 0), np.inf, hi)
    disc = b * b - 4 * a * c
    ok = ~flat & (disc >= 0)
    sq = np.sqrt(np.where(ok, disc, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        lo = np.where(ok, (-b - sq) / (2 * a), lo)
        hi = np.where(ok, (-b + sq) / (2 * a), hi)
    return lo, hi


def _segment_cylinder(p0: np.ndarray, p1: np.ndarray, radius: np.ndarray, half: np.ndarray) -> np.ndarray:
    """(N,) does the segment meet the cylinder x^2 + y^2 <= r^2, |z| <= half?"""
    d = p1 - p0
    a = d[:, 0] ** 2 + d[:, 1] ** 2
    b = 2 * (p0[:, 0] * d[:, 0] + p0[:, 1] * d[:, 1])
    c = p0[:, 0] ** 2 + p0[:, 1] ** 2 - radius ** 2
    lo, hi = _quadratic_interval(a, b, c)
    z0, z1 = _slab(p0[:, 2], d[:, 2], half)
    lo, hi = _interval_and(lo, hi, z0, z1)
    lo, hi = _interval_and(lo, hi, 0.0, 1.0)
    return lo <= hi


def _segment_sphere(p0: np.ndarray, p1: np.ndarray, radius: float) -> np.ndarray:
    d = p1 - p0
    lo, hi = _quadratic_interval(np.einsum("ni,ni->n", d, d), 2 * np.einsum("ni,ni->n", p0, d),
                                 np.einsum("ni,ni->n", p0, p0) - radius ** 2)
    lo, hi = _interval_and(lo, hi, 0.0, 1.0)
    return lo <= hi


def _segment_triangles(p0: np.ndarray, p1: np.ndarray, V: np.ndarray, T: np.ndarray, count: bool = False,
                       chunk: int = 200_000) -> np.ndarray:
    """(N,) number of triangles the segments cross (Möller-Trumbore, t in [0, 1])."""
    N = len(p0)
    A, B, C = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    e1, e2 = B - A, C - A
    out = np.zeros(N, int)
    step = max(1, chunk // max(len(T), 1))
    for s in range(0, N, step):
        o = p0[s:s + step, None, :]
        d = (p1 - p0)[s:s + step, None, :]
        h = np.cross(d, e2[None])
        a = np.einsum("ntk,tk->nt", h, e1)
        ok = np.abs(a) > 1e-18
        f = np.where(ok, 1.0 / np.where(ok, a, 1.0), 0.0)
        sv = o - A[None]
        u = f * np.einsum("ntk,ntk->nt", sv, h)
        qv = np.cross(sv, e1[None])
        v = f * np.einsum("ntk,ntk->nt", d, qv)
        t = f * np.einsum("tk,ntk->nt", e2, qv)
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= 1)
        out[s:s + step] = hit.sum(axis=1)
    return out


FRONT_SEES_ENOUGH = 0.75  # the usual front set-up is kept while it sees this share of the best position's tips


def tracker_side(machine: Machine, tool: float = 0.25, distance: float = 2.0) -> tuple[float, float]:
    """(azimuth [rad] about the workspace centre, 0 = the usual front set-up; height [m]
    of the tracker head) of a tracker standing ``distance`` [m] beyond the tool-tip
    workspace. The front (-y side, at the height of the lowest tip, as for a gantry)
    unless the machine's own URDF geometry hides most tool tips from there (a trunnion's
    column stands on that side): then, of 8 directions x 3 heights (lowest tip, centre,
    0.3 m above the highest tip), the one that sees the most tips of 128 commands.
    Without geometry in the URDF: the front."""
    from scipy.stats import qmc
    u = qmc.Halton(machine.n_axes, seed=0).random(128)
    q = machine.lower + u * (machine.upper - machine.lower)
    tips = machine.tool_tip(q, tool, frame="base")
    lo, hi = tips.min(axis=0), tips.max(axis=0)
    centre = (lo + hi) / 2
    try:
        solids, _ = solids_from_urdf(machine)
    except MachineError:
        return 0.0, float(lo[2])
    if not solids:
        return 0.0, float(lo[2])
    seen = []
    for k in range(8):
        az = k * np.pi / 4
        for z in (lo[2], centre[2], hi[2] + 0.3):
            pos = _around(tips, centre, az, distance, z)
            seen.append((1.0 - SightLine(machine, pos, solids=solids).check(q, tool).blocked.mean(), az, float(z)))
    best = max(v for v, _, _ in seen)
    if seen[0][0] >= FRONT_SEES_ENOUGH * best:
        return 0.0, float(lo[2])
    _, az, z = max(seen, key=lambda t: t[0])
    return az, z


def _around(tips: np.ndarray, centre: np.ndarray, azimuth: float, distance: float, z: float) -> np.ndarray:
    """A point ``distance`` [m] beyond the tips' extent in the direction -y turned by
    ``azimuth`` about the vertical through ``centre``, at height z."""
    d = np.array([np.sin(azimuth), -np.cos(azimuth), 0.0])
    reach = float(((tips - centre) @ d).max())
    pos = centre + (reach + distance) * d
    pos[2] = z
    return pos


def default_tracker_placement(machine: Machine, tool: float = 0.25, distance: float = 2.0) -> tuple[np.ndarray, float]:
    """(position (3,) [m], azimuth [rad] of :func:`tracker_side`) of a tracker standing
    ``distance`` [m] beyond the tool-tip workspace, centred on it: in front (-y side) at
    the height of its lowest tip (the usual set-up for a gantry, azimuth 0), or where
    :func:`tracker_side` finds the tips in sight."""
    from scipy.stats import qmc
    u = qmc.Halton(machine.n_axes, seed=0).random(256)
    tips = machine.tool_tip(machine.lower + u * (machine.upper - machine.lower), tool, frame="base")
    lo, hi = tips.min(axis=0), tips.max(axis=0)
    az, z = tracker_side(machine, tool, distance)
    if az == 0.0:
        return np.array([(lo[0] + hi[0]) / 2, lo[1] - distance, lo[2]]), 0.0
    return _around(tips, (lo + hi) / 2, az, distance, z), az


def default_tracker_position(machine: Machine, tool: float = 0.25, distance: float = 2.0) -> np.ndarray:
    """The position [m] of :func:`default_tracker_placement`."""
    return default_tracker_placement(machine, tool, distance)[0]


def side_name(azimuth: float) -> str:
    """The side of the workspace a tracker at ``azimuth`` (of :func:`tracker_side`)
    stands on: "-y" (the front), "+y", "+x", "-x", or a corner such as "+x/-y"."""
    d = np.array([np.sin(azimuth), -np.cos(azimuth)])
    parts = [f"{'+' if v > 0 else '-'}{c}" for c, v in zip("xy", d) if abs(v) > 0.3]
    return "/".join(parts)


def describe_solids(solids: list[Solid]) -> str:
    kinds = {}
    for s in solids:
        kinds[s.kind] = kinds.get(s.kind, 0) + 1
    return ", ".join(f"{v} {k}{'es' if k == 'box' and v > 1 else ('s' if v > 1 else '')}" for k, v in kinds.items())


def spindle_chain(machine) -> tuple[int, set[int]]:
    """(the Pinocchio joint that carries the spindle, the joints of its chain down to the base):
    solids on that chain hold the gauge line, so the holder meeting them is not a collision."""
    own = machine.model.frames[machine.spindle_frame_id].parentJoint
    chain, j = set(), own
    while j > 0:
        chain.add(j)
        j = machine.model.parents[j]
    return own, chain


__all__ = ["SightLine", "SightResult", "Solid", "solids_from_urdf", "default_tracker_position", "default_tracker_placement",
           "tracker_side", "side_name", "describe_solids",
           "grown", "DEFAULT_TOOL_RADIUS", "DEFAULT_TARGET_CLEARANCE"]
