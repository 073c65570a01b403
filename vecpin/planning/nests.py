"""Table nests: where reflectors sit on the table of a machine with table axes.

A floor tracker reading the tool tip never sees a table axis turn: the table axes of a
trunnion or rotary-table machine are seen only through points fixed on the table
(:mod:`vecpin.measurement.instruments.nest`). Their positions in the workpiece frame
are unknown to the fit (found with the model), so a plan only needs them roughly: to
judge what the nests tell (the information of their rows) and whether the tracker
sees them (line of sight).

:func:`nest_positions` is the one default placement: planning uses it for the plan and
the simulator for the nests of a simulated campaign. Nests stand on the table, evenly
around a circle :data:`NEST_EDGE` inside the table's edge (the table's radius from the
URDF geometry of the link that carries the workpiece frame, when it has a table face at
the workpiece frame's z = 0; without it at most 40 % of half the span of the tool tips
relative to the workpiece and 0.3 m), at heights of 20-80 mm above the face (different
heights: the nests also see tilts).
Frames: workpiece frame, metres.

Why at the edge: a validation run judges the tip relative to the table
(:mod:`vecpin.measurement.tableframe`): at each command the table's pose is registered on
the nests' readings and the tool's reading taken through it, so the tracker noise at the
tip is the tool reading's own plus what the registration adds. Registering n nests evenly
on a circle of radius r, each read with noise sigma per axis, moves a tip at ``lever``
from their centre by sigma sqrt((1 + k (lever / r)^2) / n) per axis, k = 1 for a lever in
the table's plane and 4/3 for one square to it (averaged over the three axes;
tests/test_nest_noise.py derives it and checks it against scipy's Kabsch). A tip stands
0.3-0.9 m from the nests, so the farther out the nests, the less noise at the tip.

No placement removes the tool reading's own noise, nor the part of the nests' that is
there at any radius: a table machine's validation run therefore reads the tool and each
nest :data:`VALIDATION_READS` times in a row at every command, the machine standing still
(one move to the command, a dwell per reading, no motion between the readings:
:mod:`~vecpin.planning.ncprogram`), and the mean of each point's readings is judged. That
divides the tracker's noise variance by the number of readings, not the machine's
positioning noise: the axes stand where they stopped for every reading.
"""
from __future__ import annotations

import re

import numpy as np

from vecpin.errors import InputError, MachineError
from vecpin.kinematics.machine import Machine
from vecpin.units import M_PER_MM, MM_PER_M
from vecpin.models.recorded import scrambled_halton   # scipy's qmc.Halton, without scipy.stats

MAX_NESTS = 20             # nests one plan or simulation places
MAX_REACH = 0.3            # m: farthest a default nest stands from the table centre
TABLE_SHARE = 0.8          # on a table narrower than 2 NEST_EDGE: nests on this share of its radius
NEST_EDGE = 0.02           # m: a default nest's centre this far inside the table's edge (its base on the table)
FACE_TOLERANCE = 0.005     # m: a solid whose top lies this close to the workpiece plane is the table
NEST_HEIGHTS = (0.02, 0.08)  # m: reflector centres above the table face
VALIDATION_READS = 4       # readings of the tool and of each nest at a table machine's validation command (at standstill)
_ID = re.compile(r"[A-Za-z0-9_.-]{1,16}")


def table_radius(machine: Machine) -> float | None:
    """Radius [m] of the largest circle about the workpiece origin inside the table face:
    the URDF solids on the link that carries the workpiece frame whose top lies in the
    workpiece frame's z = 0 plane (a cylinder along z, or a box), or None when the URDF
    has no such geometry."""
    if not machine.has_workpiece:
        return None
    from vecpin.planning.sightline import solids_from_urdf
    try:
        solids, _ = solids_from_urdf(machine)
    except MachineError:
        return None
    model = machine.model
    f = model.frames[model.getFrameId(machine.workpiece_link)]
    inv_wp = np.linalg.inv(f.placement.homogeneous)
    best = None
    for s in solids:
        if s.joint != f.parentJoint or s.kind not in ("cylinder", "box"):
            continue
        H = inv_wp @ s.placement              # the solid in the workpiece frame
        R, c = H[:3, :3], H[:3, 3]
        if abs(abs(R[2, 2]) - 1.0) > 1e-6:     # not lying flat on the face
            continue
        half_h = s.size[1] if s.kind == "cylinder" else s.size[2]
        if abs(c[2] + half_h) > FACE_TOLERANCE:
            continue
        if s.kind == "cylinder":
            r = s.size[0] - float(np.hypot(c[0], c[1]))
        else:
            # a box turned about z: the inscribed circle of its face, shifted by its centre
            r = float(min(s.size[0], s.size[1])) - float(np.hypot(c[0], c[1]))
        if r > 0 and (best is None or r > best):
            best = r
    return best


def nest_reach(machine: Machine) -> float:
    """The radius [m] of the default nests' circle about the workpiece origin: the table's
    radius from the URDF less :data:`NEST_EDGE` (the nests as far out as their bases stand
    on the table: the registration's noise at the tip falls with the radius), or without
    table geometry at most 40 % of half the span of the tool tips relative to the
    workpiece and :data:`MAX_REACH` (see the module text)."""
    table = table_radius(machine)
    if table is not None and table > 2 * NEST_EDGE:
        return table - NEST_EDGE
    q = machine.lower + scrambled_halton(machine.n_axes, 256, seed=0) * (machine.upper - machine.lower)
    rel = machine.tool_tip(q, 0.2, frame="workpiece")
    reach = min(MAX_REACH, 0.4 * 0.5 * float(np.ptp(rel[:, :2], axis=0).min()))
    return reach if table is None else min(reach, TABLE_SHARE * table)


def nest_positions(machine: Machine, n: int, seed: int = 0) -> dict[str, np.ndarray]:
    """n default nests {id: (3,) [m], workpiece frame}, ids "1", "2", ... (see the
    module text); the angles and heights come from a seeded rng of their own."""
    if n < 0 or n > MAX_NESTS or int(n) != n:
        raise InputError(f"`nests` {n}: a whole number of table nests, 0 .. {MAX_NESTS}")
    if n == 0:
        return {}
    rng = np.random.default_rng([seed, 14])
    reach = nest_reach(machine)
    out = {}
    for k in range(n):
        a = 2 * np.pi * (k + rng.uniform(0.0, 0.5)) / n
        out[str(k + 1)] = np.array([reach * np.cos(a), reach * np.sin(a), rng.uniform(*NEST_HEIGHTS)])
    return out


def parse_nest(text: str, option: str = "nest_mm") -> tuple[str, np.ndarray]:
    """'ID=X,Y,Z' (mm, workpiece frame) -> (id, (3,) [m]); errors name the parameter ``option``."""
    head, sep, tail = str(text).partition("=")
    nid = head.strip()
    try:
        xyz = np.array([float(v) for v in tail.split(",")]) if sep else np.zeros(0)
    except ValueError:
        xyz = np.zeros(0)
    if not sep or not _ID.fullmatch(nid) or xyz.size != 3 or not np.all(np.isfinite(xyz)):
        raise InputError(f"`{option}` '{text}': write ID=X,Y,Z, the nest's id (letters, digits, _ . -) and its "
                         "position in mm in the workpiece (table) frame, e.g. 1=120,0,40")
    if np.any(np.abs(xyz) > 10_000):
        raise InputError(f"`{option}` '{text}': a nest more than 10 m from the table origin; positions are mm")
    return nid, xyz * M_PER_MM


def check_nests(machine: Machine, nests: dict[str, np.ndarray], option: str = "nest_mm") -> None:
    """Nests make sense only on a machine with a table branch; ids are unique (the
    caller's dict) and few."""
    if nests and not machine.has_workpiece:
        raise InputError(f"`{option}`: machine '{machine.name}' has no table branch (no 'workpiece' link): a floor "
                         "tracker sees its tool tips directly; plan without nests")
    if len(nests) > MAX_NESTS:
        raise InputError(f"`{option}`: {len(nests)} nests; at most {MAX_NESTS}")


LINE_MM = 5.0    # nests within this [mm] of one line (or of a table axis' line) cannot register a turn about it


def check_nest_layout(machine: Machine, nests: dict[str, np.ndarray], option: str = "nest_mm") -> None:
    """Nests placed by the user (workpiece frame, m) that can register the table, refused
    naming the parameter ``option`` when not: one nest (a point gives no turn); positions
    that are all below 1 mm (metres typed for mm); three or more on one line; every nest on
    the line of a table rotary axis (its turn moves none of them); a nest beyond the table's
    edge (the URDF's table radius) or below its face."""
    if not nests or not machine.has_workpiece:
        return
    ids = list(nests)
    P = np.array([nests[k] for k in ids], float) * MM_PER_M
    where = "; ".join(f"{k} ({', '.join(f'{v:g}' for v in p)})" for k, p in zip(ids, P))
    if len(P) == 1:
        raise InputError(f"`{option}` {where} mm: one nest gives the table's place but not its turn; give 3 nests "
                         "not on one line")
    close = [(ids[i], ids[j]) for i in range(len(P)) for j in range(i) if np.linalg.norm(P[i] - P[j]) < LINE_MM]
    if close and np.abs(P).max() >= 1.0:
        raise InputError(f"`{option}` {where} mm: nests {close[0][1]} and {close[0][0]} stand within {LINE_MM:g} mm of "
                         "each other: two reflectors cannot share a place; give each nest its own place on the table")
    if np.ptp(P, axis=0).max() < 1e-6:
        raise InputError(f"`{option}` {where} mm: the nests stand at one place: give each nest its own place on the "
                         "table, in mm (the workpiece frame)")
    if np.abs(P).max() < 1.0:
        big = "; ".join(f"{k} ({', '.join(f'{v * 1000:g}' for v in p)})" for k, p in zip(ids, P))
        raise InputError(f"`{option}` {where} mm: every nest within 1 mm of the table origin: metres? Nest positions "
                         f"are mm in the workpiece frame ({big} if they were in metres)")
    if len(P) >= 3:
        off_line = np.linalg.svd(P - P.mean(axis=0), compute_uv=False)[1] / np.sqrt(len(P))
        if off_line < LINE_MM:
            raise InputError(f"`{option}` {where} mm: the nests lie on one line (within {LINE_MM:g} mm), so a turn "
                             "about it is not seen: place them around the table, not in a row")
    radius = table_radius(machine)
    for k, p in zip(ids, P):
        r = float(np.hypot(p[0], p[1]))
        if radius is not None and r > radius * MM_PER_M + LINE_MM:
            raise InputError(f"`{option}` {k} ({', '.join(f'{v:g}' for v in p)}) mm: {r:.0f} mm from the table's "
                             f"centre, beyond its edge (radius {radius * MM_PER_M:.0f} mm from the URDF): a nest "
                             "stands on the table")
        if p[2] < -LINE_MM:
            raise InputError(f"`{option}` {k} ({', '.join(f'{v:g}' for v in p)}) mm: below the table's face "
                             "(z < 0 in the workpiece frame): a nest stands on the table")
    _check_on_table_axes(machine, P, where, option)


def _check_on_table_axes(machine: Machine, P: np.ndarray, where: str, option: str) -> None:
    """Refuse nests that every table rotary axis' turn (90 deg, or its travel) from the
    middle of the travel leaves in place within :data:`LINE_MM`: they are on its line."""
    q0 = (machine.lower + machine.upper) / 2
    for a in machine.axes:
        if a.kind != "rotary" or a.side != "table":
            continue
        q1 = q0.copy()
        q1[a.index] = q0[a.index] + min(np.pi / 2, a.travel / 2)
        p = P * M_PER_MM
        moved = machine.workpiece_points(np.repeat(q1[None], len(p), 0), p, jacobian=False).xyz - \
            machine.workpiece_points(np.repeat(q0[None], len(p), 0), p, jacobian=False).xyz
        if np.linalg.norm(moved, axis=1).max() * MM_PER_M < LINE_MM:
            raise InputError(f"`{option}` {where} mm: every nest is on the axis of {a.name}, so its turn moves none of "
                             f"them and the nests cannot register it: place them away from {a.name}'s axis")


__all__ = ["VALIDATION_READS", "nest_positions", "nest_reach", "NEST_HEIGHTS", "table_radius", "parse_nest",
           "check_nests", "MAX_NESTS", "check_nest_layout"]
