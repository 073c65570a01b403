"""Which machine point a row measures, and where the unknown ones start.

A row of a campaign measures one point that moves with the machine:

* a point on the **tool**: the tool tip (``tool`` mm along the tool axis from the
  gauge line) of one tool point (``point`` column), optionally a reflector off the
  tool axis (``target`` column): an offset vector in the tool link frame, known from a
  targets file or unknown and found by the fit (like a ball bar's pivot);
* a point on the **table** (``nest`` rows): a reflector in a nest fixed on the
  workpiece (table) frame, its position in that frame unknown and found by the fit.
  Only such points see the table axes of a machine whose tool a floor tracker cannot
  tell from a turning table.

A :class:`PointRequest` says this for the rows of one block of the likelihood; the
likelihood asks the model for the point and chains the Jacobians. Unknown target
offsets and nest positions are named ``target<id>.x|y|z`` and ``nest<id>.x|y|z``; the
request gives, per row, where its three coordinates sit among the block's unknowns.

:func:`initial_setup` places the tracker(s) before any fit: a rigid registration of
the nominal points, alternated with the mean position of every unknown target and nest
(the registration needs the points, the points need the registration).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.errors import IdentifiabilityError
from vecpin.measurement.registration import rigid_registration
from vecpin.measurement.setup import Setup

POINT_PRIOR = 1e-2  # m: prior on the correction of a target offset or nest position from its starting value


@dataclass
class PointRequest:
    """The points n rows measure (SI).

    ``kind``: "tool" or "workpiece"; ``tool`` (n,) tool length [m]; ``point`` (n,) tool
    point index; ``offset`` (n,3) [m]: target offset in the tool link frame (zeros for
    the plain tool tip); ``p_wp`` (n,3) [m]: nest positions in the workpiece frame
    (``kind == "workpiece"``); ``unknown`` (n,) index among the block's unknowns of the
    first of the row's three point coordinates, -1 when the point is known."""

    kind: str
    tool: np.ndarray
    point: np.ndarray
    offset: np.ndarray
    p_wp: np.ndarray | None = None
    unknown: np.ndarray | None = None

    def take(self, idx) -> "PointRequest":
        """The request of some of the rows (positions within the block)."""
        return PointRequest(self.kind, self.tool[idx], self.point[idx], self.offset[idx],
                            None if self.p_wp is None else self.p_wp[idx],
                            None if self.unknown is None else self.unknown[idx])

    def with_unknowns(self, u: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None]:
        """(offsets or nest positions with the corrections u added, column indices (n,3)
        of each row's corrections in u, or None when no row has one)."""
        base = self.p_wp if self.kind == "workpiece" else self.offset
        if self.unknown is None or not np.any(self.unknown >= 0):
            return base, None
        has = self.unknown >= 0
        cols = np.where(has[:, None], self.unknown[:, None] + np.arange(3), -1)
        out = base.copy()
        out[has] += u[cols[has]]
        return out, cols


def tool_request(campaign, rows: np.ndarray, setup: Setup, first: int) -> tuple[PointRequest, list[str]]:
    """The request of tool rows and the names of their unknown target offsets (after the
    block's ``first`` own unknowns). Known offsets come from ``campaign.targets``."""
    n = len(rows)
    offset = np.zeros((n, 3))
    unknown = np.full(n, -1)
    names: list[str] = []
    ids = campaign.target[rows]
    for tid in sorted(set(ids) - {""}):
        sel = ids == tid
        if tid in campaign.targets:
            offset[sel] = campaign.targets[tid]
            continue
        offset[sel] = setup.targets.get(tid, np.zeros(3))
        unknown[sel] = first + len(names)
        names += [f"target{tid}.{c}" for c in "xyz"]
    return PointRequest("tool", campaign.tool[rows], campaign.point[rows], offset, None, unknown), names


def nest_request(campaign, rows: np.ndarray, setup: Setup, first: int) -> tuple[PointRequest, list[str]]:
    """The request of nest rows (every nest position unknown) and the names of the unknowns."""
    n = len(rows)
    p_wp = np.zeros((n, 3))
    unknown = np.full(n, -1)
    names: list[str] = []
    ids = campaign.target[rows]
    for nid in sorted(set(ids)):
        sel = ids == nid
        p_wp[sel] = setup.nests.get(nid, np.zeros(3))
        unknown[sel] = first + len(names)
        names += [f"nest{nid}.{c}" for c in "xyz"]
    return PointRequest("workpiece", campaign.tool[rows], campaign.point[rows], np.zeros((n, 3)), p_wp, unknown), names


def nominal_points(machine, q: np.ndarray, req: PointRequest) -> np.ndarray:
    """(n,3) [m] the requested points of the nominal machine in the base frame."""
    if req.kind == "workpiece":
        return machine.workpiece_points(q, req.p_wp, jacobian=False).xyz
    offset = req.offset if np.any(req.offset) else None   # no offset: the tips the campaign's checks asked for
    return machine.tool_tip(q, req.tool, frame="base", point=req.point, offset=offset)


# ---------------------------------------------------------------------- starting values
def _frames(machine, campaign, rows):
    """Per row: the frame its point is fixed in (R (n,3,3), origin (n,3), base frame),
    the known local coordinates l (n,3) and the unknown group key ("" = known)."""
    n = len(rows)
    R = np.empty((n, 3, 3))
    o = np.empty((n, 3))
    local = np.zeros((n, 3))
    key = np.full(n, "", dtype=object)
    nest = campaign.instrument[rows] == "nest"
    ids = campaign.target[rows]
    if nest.any():
        T = machine.workpiece_pose(campaign.q[rows[nest]])
        R[nest], o[nest] = T[:, :3, :3], T[:, :3, 3]
        key[nest] = np.array(["nest:" + str(i) for i in ids[nest]], dtype=object)
    tool = ~nest
    if tool.any():
        r = rows[tool]
        R[tool], o[tool] = machine.tool_placements(campaign.q[r], campaign.point[r])
        lt = campaign.tool[r][:, None] * machine.tool_axis
        tids = ids[tool]
        for i in np.flatnonzero(tids != ""):   # the rows of targets only (a million tool tips: no loop)
            tid = tids[i]
            if tid in campaign.targets:
                lt[i] = lt[i] + campaign.targets[tid]
            else:
                key[np.flatnonzero(tool)[i]] = "target:" + str(tid)
        local[tool] = lt
    return R, o, local, key


def _alternate(R, o, local, key, x, known: dict, iterations: int = 60):
    """Register (R_t, t) and the unknown local points ``c`` of every group, alternating:
    x ≈ R_t (R_i (l_i + c_g) + o_i) + t. ``known``: groups already placed (kept)."""
    groups = sorted(set(key) - {""})
    c = {g: known.get(g, np.zeros(3)) for g in groups}
    free = [g for g in groups if g not in known]
    Rt, t = np.eye(3), np.zeros(3)
    for _ in range(iterations):
        C = np.array([c[g] if g else np.zeros(3) for g in key]) if groups else np.zeros_like(local)
        P = o + np.einsum("pij,pj->pi", R, local + C)
        Rt, t = rigid_registration(P, x)
        if not free:
            break
        Y = (x - t) @ Rt                                  # measured points in machine coordinates
        L = np.einsum("pji,pj->pi", R, Y - o) - local     # each row's estimate of its group's point
        change = 0.0
        for g in free:
            new = L[key == g].mean(axis=0)
            change = max(change, float(np.abs(new - c[g]).max()))
            c[g] = new
        if change < 1e-9:
            break
    return Rt, t, c


def initial_setup(machine, campaign, setup: Setup | None = None) -> Setup:
    """The tracker poses and the starting values of every unknown target offset and nest
    position (filled into ``setup``, or a new one registered on station 0's rows).
    Stations other than 0 are placed here too when they are not in ``setup``."""
    point_rows = np.flatnonzero(campaign.instrument != "ballbar")
    placed = setup is not None and set(np.unique(campaign.station[point_rows]).tolist()) <= {0, *setup.stations}
    if placed and not np.any(campaign.target[point_rows] != "") and not np.any(campaign.instrument == "nest"):
        return setup   # every pose given and no point to place: nothing to compute over the rows
    R, o, local, key = _frames(machine, campaign, point_rows)
    station = campaign.station[point_rows]
    known = {"target:" + k: v for k, v in (setup.targets.items() if setup else ())}
    known |= {"nest:" + k: v for k, v in (setup.nests.items() if setup else ())}
    order = [0] + sorted(int(s) for s in set(station.tolist()) - {0})
    for s in order:
        sel = station == s
        if s == 0 and setup is not None:
            # the pose is given: only place the groups it does not know
            Y = (campaign.xyz[point_rows[sel]] - setup.t) @ setup.R
            L = np.einsum("pji,pj->pi", R[sel], Y - o[sel]) - local[sel]
            for g in sorted(set(key[sel]) - {""} - set(known)):
                known[g] = L[key[sel] == g].mean(axis=0)
            continue
        if s != 0 and setup is not None and s in setup.stations:
            continue
        if sel.sum() < 3:
            if s == 0:
                raise IdentifiabilityError(f"{campaign.source}: tracker station 0 needs at least 3 rows; it anchors "
                                           "the machine frame")
            continue
        Rt, t, c = _alternate(R[sel], o[sel], local[sel], key[sel], campaign.xyz[point_rows[sel]], known)
        known |= c
        if s == 0:
            setup = Setup(Rt, t)
        else:
            setup.stations[s] = (Rt, t, np.zeros(6))
    for g, v in known.items():
        kind, gid = g.split(":", 1)
        (setup.nests if kind == "nest" else setup.targets).setdefault(gid, np.asarray(v, float))
    return setup
