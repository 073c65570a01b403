"""The part's frame: where a machine's error is judged, and the frame compensation keeps.

**The part's frame.** A part is clamped to the table (the bed of a machine whose table does
not move) and set up by probing its origin and aligning one edge with the machine's motion:
a translation and a rotation about the spindle axis, nothing else. Every other rigid
motion of the working volume against the table (a tilt) is an error the part sees: a face
cut square to the spindle ends tilted against the face it was clamped on.
:func:`part_frame_errors` removes exactly what the set-up removes; the seed's volumetric
error (:func:`vecpin.measurement.registration.registered_errors`: the best rigid motion of
the whole volume removed) is the *shape* of the error, stated beside it.

**The machine's own reference frame.** Tracker data cannot tell where the table is: a
rigid motion of the whole volume is absorbed by the tracker's pose. Which rotation the
compensated machine keeps is therefore a definition, made here as a metrologist makes it:

* on a machine whose table stands still (a head or gantry machine: the bed was aligned to
  the motion of X and Y when the machine was commissioned), ISO 230-1's reference straight
  lines: the compensated machine moves its primary linear axis (X) along X's own mean line
  of motion, its XY plane keeps the plane of X's and Y's mean lines, and Z is square to it.
  The mean lines are least-squares slopes of the tip against each linear axis' command;
* on a machine whose table turns (trunnions, head-table, all-table machines), on arms and
  where several tool points are driven together, the mean orientation of the working volume
  relative to the table: its best-fit rotation. At no single pose are the table's lines
  representative of the whole volume, and keeping the mean orientation means the tables add
  no net turn of the volume;
* where the campaign read the table's face (nests at given heights), that face square to
  the spindle (:func:`vecpin.compensation.frame.on_the_table_face`).

:func:`reference_rotation` gives the rotation that takes a machine's tips into that frame.

Frames: every point here is the tool tip relative to the workpiece (the base frame on a
machine without a table branch), metres.
"""
from __future__ import annotations

import numpy as np

from vecpin.kinematics.so3 import exp3, log3

FRAME_TEXT = ("the part's frame: the tip relative to the table, the part set up by probing its origin and "
              "aligning an edge (a translation and a rotation about the spindle axis removed, nothing else)")


def spindle_axis(machine) -> np.ndarray:
    """The nominal tool direction (3,) at the machine's home (every axis at 0, or at the end of
    its travel nearest 0), in the workpiece frame: the axis a part is aligned about."""
    home = home_commands(machine)[None]
    return machine.kinematics(home, 0.0, jacobian=False, frame="workpiece").tool_dir[0]


def home_commands(machine) -> np.ndarray:
    """(n,) [m, rad]: every axis at 0, clipped to its travel."""
    return np.clip(np.zeros(machine.n_axes), machine.lower, machine.upper)


def about_axis(nominal: np.ndarray, actual: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R (3,3), t (3,)): the rotation about ``axis`` and the translation minimising
    sum |R nominal_i + t - actual_i|^2 (closed form: the angle from the two sums of the
    centred points' products in the plane square to the axis)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    P, Q = nominal - nominal.mean(0), actual - actual.mean(0)
    P_perp = P - np.outer(P @ a, a)
    phi = np.arctan2(np.einsum("ij,ij->", Q, np.cross(a, P)), np.einsum("ij,ij->", Q, P_perp))
    R = exp3(phi * a)
    return R, actual.mean(0) - R @ nominal.mean(0)


def part_frame_errors(nominal: np.ndarray, actual: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """(N,3) errors [same unit] of ``actual`` points after the part's set-up: the
    translation and the rotation about ``axis`` (the spindle) that best put the nominal
    points on them are removed, nothing else (:data:`FRAME_TEXT`)."""
    nominal, actual = np.asarray(nominal, float), np.asarray(actual, float)
    R, t = about_axis(nominal, actual, axis)
    return actual - (nominal @ R.T + t)


# ------------------------------------------------------------------ the reference frame
def _regressors(machine, q: np.ndarray, tool: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """Columns [1, each linear axis' command, sin and cos of each rotary, the tool length]
    and the column of each linear axis (-1 when it does not move in ``q``)."""
    cols, where = [np.ones(len(q))], []
    for a in machine.axes:
        x = q[:, a.index]
        if a.kind == "linear":
            moves = np.ptp(x) > 1e-9 * max(a.travel, 1e-9)
            where.append(len(cols) if moves else -1)
            if moves:
                cols.append(x - x.mean())
        else:
            where.append(-1)
            for f in (np.sin, np.cos):
                c = f(x)
                if np.ptp(c) > 1e-9:
                    cols.append(c - c.mean())
    tool = np.broadcast_to(np.asarray(tool, float), (len(q),))
    if np.ptp(tool) > 1e-9:
        cols.append(tool - tool.mean())
    return np.column_stack(cols), where


def mean_lines(machine, q: np.ndarray, tool, points: np.ndarray) -> dict[str, np.ndarray]:
    """{linear axis: (3,) the least-squares slope of ``points`` (N,3) [m] against its
    command [m/m]}: the direction of the axis' mean line of motion (ISO 230-1's reference
    straight line), the other axes' positions and the tool length held apart by the same
    regression. Axes that do not move in ``q`` are left out."""
    X, where = _regressors(machine, q, tool)
    coef = np.linalg.lstsq(X, points, rcond=None)[0]
    return {a.name: coef[w] for a, w in zip(machine.axes, where) if w >= 0}


def reference_axes(machine, lines: dict[str, np.ndarray], spindle: np.ndarray) -> tuple[str, str] | None:
    """(primary, secondary): the two linear axes whose nominal mean lines span the plane
    square to the spindle (X and Y where they exist: the axes named so first, then by
    travel); None when the machine has no such pair (an arm, a machine with one axis
    square to its spindle)."""
    s = np.asarray(spindle, float) / np.linalg.norm(spindle)
    ok = [n for n, u in lines.items() if np.linalg.norm(u) > 0.5 and abs(u @ s) / np.linalg.norm(u) < 0.5]
    ok.sort(key=lambda n: ({"X": 0, "Y": 1}.get(n.upper(), 2), -machine.axis(n).travel))
    for i, first in enumerate(ok):
        u1 = lines[first] / np.linalg.norm(lines[first])
        for second in ok[i + 1:]:
            u2 = lines[second] / np.linalg.norm(lines[second])
            if np.linalg.norm(np.cross(u1, u2)) > 0.5:
                return first, second
    return None


def table_turns(machine) -> bool:
    """True when a rotary axis moves the table (the workpiece frame turns with it)."""
    return any(machine.axis(a).kind == "rotary" for a in getattr(machine, "table_axes", []))


def uses_lines(machine, spindle: np.ndarray | None = None) -> bool:
    """True when the machine's reference frame is ISO 230-1's reference lines (its table
    stands still and two linear axes move square to the spindle); False: the mean orientation
    (also where several tool points are driven together: each has lines of its own)."""
    if table_turns(machine) or len(getattr(machine, "tool_links", ())) > 1:
        return False
    spindle = spindle_axis(machine) if spindle is None else spindle
    home = home_commands(machine)
    J = machine.kinematics(home[None], 0.0, jacobian=True, frame="workpiece").jacobian[0]
    lines = {a.name: J[:, a.index] for a in machine.axes if a.kind == "linear"}
    return reference_axes(machine, lines, spindle) is not None


def reference_rotation(machine, q: np.ndarray, tool, nominal: np.ndarray, actual: np.ndarray,
                       spindle: np.ndarray | None = None) -> tuple[np.ndarray, str]:
    """(R (3,3), how): the rotation that takes ``actual`` tips (N,3) [m] into the
    machine's own reference frame (:mod:`the module text <vecpin.measurement.partframe>`),
    about their centroid: in it the primary axis' mean line runs along its nominal
    direction and the plane of the primary and secondary mean lines is the nominal one.
    ``nominal``: the nominal tips of the same commands ``q`` and tools; ``q`` should hold the
    rotary axes at home. A machine whose table turns, or without two linear axes square to
    the spindle (:func:`uses_lines`), keeps the best-fit rotation of the whole volume
    (``q`` then spans the volume). ``how`` says which, in words."""
    q = np.atleast_2d(np.asarray(q, float))
    nominal, actual = np.asarray(nominal, float), np.asarray(actual, float)
    spindle = spindle_axis(machine) if spindle is None else spindle
    nom_lines = mean_lines(machine, q, tool, nominal)
    pair = _line_pair(machine, nom_lines, spindle)
    if pair is None:
        from vecpin.measurement.registration import rigid_registration
        R = rigid_registration(actual, nominal)[0]
        why = ("the table turns" if table_turns(machine) else "several tool points" if len(
            getattr(machine, "tool_links", ())) > 1 else "no two linear axes move square to the spindle")
        return R, f"the mean orientation of the working volume relative to the table, its best-fit rotation ({why})"
    p, s = pair
    u1, u2 = (nom_lines[n] / np.linalg.norm(nom_lines[n]) for n in pair)
    c = actual.mean(0)
    R = np.eye(3)
    centred = mean_lines(machine, q, tool, actual - c)   # the regression is linear: turned points, turned lines
    for _ in range(3):  # the condition is linear in a small rotation: twice reaches 1e-12 rad
        lines = {n: v @ R.T for n, v in centred.items()}
        a1, a2 = (lines[n] / np.linalg.norm(lines[n]) for n in pair)
        A, b = _line_conditions(u1, u2, a1, a2, a1, a2)
        w = np.linalg.solve(A, b)
        R = exp3(w) @ R
        if np.abs(w).max() < 1e-13:
            break
    return R, (f"ISO 230-1 reference lines: {p} along {p}'s mean line of motion, the {p}{s} plane that of {p} and "
               f"{s}, the third direction square to it (the bed is aligned to them when the machine is commissioned)")


def _line_pair(machine, nom_lines: dict, spindle: np.ndarray) -> tuple[str, str] | None:
    """The primary and secondary axis of the reference lines, or None where the frame is the
    volume's mean orientation (:func:`uses_lines`): one decision for the exact turn and its
    linearisation."""
    return reference_axes(machine, nom_lines, spindle) if uses_lines(machine, spindle) else None


def _line_conditions(u1: np.ndarray, u2: np.ndarray, a1: np.ndarray, a2: np.ndarray, d1: np.ndarray,
                     d2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A (3,3), b (3,) or (S,3)): the reference lines' conditions on a small turn w, A w = b.
    A small w turns a line direction a into a + w x a; wanted: the primary line along its
    nominal u1 (its components along e2 = n x u1 and n = u1 x u2 vanish) and the secondary
    without a component along n. ``a1``, ``a2``: the lines the turn acts on; ``d1``, ``d2``:
    the components to cancel (the lines themselves, or their small changes)."""
    n = np.cross(u1, u2)
    n /= np.linalg.norm(n)
    e2 = np.cross(n, u1)
    A = np.array([np.cross(a1, e2), np.cross(a1, n), np.cross(a2, n)])
    return A, -np.stack([d1 @ e2, d1 @ n, d2 @ n], axis=-1)


def rotation_angle(R: np.ndarray) -> float:
    """The angle [rad] of a rotation matrix."""
    return float(np.linalg.norm(log3(np.asarray(R, float))))


def net_rotation(nominal: np.ndarray, compensated: np.ndarray) -> float:
    """The angle [rad] by which a compensated working volume is turned: the best-fit
    rotation of its tips ``compensated`` (N,3) [m], given in the reference frame of the
    machine before compensation, against the ``nominal`` tips of the same commands. Tables
    that keep the machine's frame turn it by no more than what they cannot follow."""
    from vecpin.measurement.registration import rigid_registration
    return rotation_angle(rigid_registration(np.asarray(compensated, float), np.asarray(nominal, float))[0])


def reference_rotation_changes(machine, q: np.ndarray, tool, nominal: np.ndarray, changes: np.ndarray,
                               spindle: np.ndarray | None = None) -> np.ndarray:
    """(S, 3) small rotations [rad] that take tips ``nominal + changes[s]`` back into their
    own reference frame, for tips (N,3) [m] already in theirs (``nominal``: their mean lines
    are the nominal directions) and small ``changes`` (S, N, 3) [m]: the linearisation of
    :func:`reference_rotation`, for many machines at once (e.g. draws from a model's
    parameter uncertainty). A machine without two linear axes square to the spindle: the
    linearised best-fit rotation of the volume."""
    q = np.atleast_2d(np.asarray(q, float))
    dE = np.asarray(changes, float)
    spindle = spindle_axis(machine) if spindle is None else spindle
    nom_lines = mean_lines(machine, q, tool, nominal)
    pair = _line_pair(machine, nom_lines, spindle)
    if pair is None:   # best-fit rotation: minus the least-squares rotation the changes make about the centroid
        r = nominal - nominal.mean(0)
        B = -np.cross(r[:, :, None], np.eye(3)[None], axis=1)            # (N,3,3): w -> w x r
        G = np.einsum("nij,nik->jk", B, B)
        return -np.linalg.solve(G, np.einsum("nij,sni->sj", B, dE - dE.mean(axis=1, keepdims=True)).T).T
    X, where = _regressors(machine, q, tool)
    C = np.linalg.pinv(X)                                                 # (k, N)
    u1, u2 = (nom_lines[n] / np.linalg.norm(nom_lines[n]) for n in pair)
    i1, i2 = (where[machine.axis(p).index] for p in pair)
    ds1, ds2 = np.einsum("n,sni->si", C[i1], dE), np.einsum("n,sni->si", C[i2], dE)   # (S,3) slope changes
    A, b = _line_conditions(u1, u2, u1, u2, ds1, ds2)
    return np.linalg.solve(A, b.T).T


def part_motion_basis(points: np.ndarray, spindle: np.ndarray) -> np.ndarray:
    """(3N, 4) orthonormal basis of the displacements of ``points`` (N,3) [m] a part's
    set-up absorbs: the three translations and a small rotation about ``spindle`` through
    the points' centroid. Projecting a stacked error vector orthogonally to it is the
    linearised :func:`part_frame_errors`."""
    s = np.asarray(spindle, float) / np.linalg.norm(spindle)
    r = points - points.mean(axis=0)
    B = np.zeros((len(points), 3, 4))
    B[:, :, :3] = np.eye(3)
    B[:, :, 3] = np.cross(s, r)
    return np.linalg.qr(B.reshape(-1, 4))[0]


class RunReference:
    """How the points of one run (a tracker's readings, or tips relative to the table) are
    taken into the machine's reference frame: the run's best rigid registration onto the
    nominal tips (``R0``, ``t0``: points ≈ R0 nominal + t0), then the turn ``R1`` about
    ``centre`` into the reference frame of the run itself (:func:`reference_rotation`).
    Called on the points of a later run from the same tracker place, it judges that run
    in this run's frame: a turn of the working volume between the runs stays in its figures."""

    def __init__(self, machine, q: np.ndarray, tool, nominal: np.ndarray, points: np.ndarray):
        from vecpin.measurement.registration import rigid_registration
        q = np.atleast_2d(np.asarray(q, float))
        tool = np.broadcast_to(np.asarray(tool, float), (len(q),))
        self.R0, self.t0 = rigid_registration(nominal, points)
        in_machine = (np.asarray(points, float) - self.t0) @ self.R0
        self.centre = in_machine.mean(axis=0)
        self.R1, self.how = reference_rotation(machine, q, tool, nominal, in_machine)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """``points`` (N,3) [m] of this run's frame (the same tracker place) in the reference frame."""
        return ((np.asarray(points, float) - self.t0) @ self.R0 - self.centre) @ self.R1.T + self.centre

    def turn_of(self, nominal: np.ndarray, points: np.ndarray) -> float:
        """The angle [rad] of the best rigid registration of ``points`` (in this run's frame)
        onto ``nominal``, once taken into the reference frame: a few mrad means the tracker was
        moved between the runs (no table turns a volume that far)."""
        from vecpin.measurement.registration import rigid_registration
        return rotation_angle(rigid_registration(np.asarray(nominal, float), self(points))[0])
