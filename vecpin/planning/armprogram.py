"""Programs that drive a serial arm through a plan and wait for the tracker.

An arm (:func:`vecpin.kinematics.axes.is_arm`) has no linear axis to lift the tool
with, so its program visits every tool row of the template as three joint poses
(:mod:`vecpin.planning.armpose`): the *approach* pose (the pre-pose, ``clearance`` back
along the tool axis, same orientation), the *measure* pose (the template's command,
where the program dwells for the tracker) and the *retract* pose (the pre-pose again);
with ``approach`` none the measure pose alone. The joint moves between the poses are
the controller's joint interpolation; from the pre-pose to the measured pose the joint
move is short (a few degrees at most), so the holder runs out of the point nearly
along the tool axis. The move between two points is posed with the planner's geometry
and goes through *via* poses where the direct move would sweep the holder through the
arm (:mod:`vecpin.planning.armtransit`).

Two dialects (the plan's `dialect`; the NC dialects of
:mod:`vecpin.planning.ncprogram` do not apply):

* ``urscript``: Universal Robots URScript (the Script Manual, Module motion:
  ``movej(q, a=1.4, v=1.05, t=0, r=0)`` moves linear in joint space to the joint
  positions ``q`` [rad], ``a`` the leading joint's acceleration [rad/s^2], ``v`` its
  speed [rad/s]; Module internals: ``sleep(t)`` [s]; Module interfaces:
  ``popup(s, title, warning, error, blocking)``; comments after ``#``). One program
  ``def vecpin_plan(): ... end``; joint positions in radians with 9 decimals (the
  template's 0.001 deg grid kept); ``movej`` rather than ``movel``: a joint target is
  reached in exactly these joint positions, the campaign records them.
* ``joint-list``: a CSV any controller can import: one row per visited pose in
  order (``pose``, ``kind`` approach/measure/retract, ``point``, ``holder_mm``,
  ``dwell_s``, then every joint in degrees, column ``<joint>_deg``).

Times: a joint move takes ``d / v + v / a`` for the largest joint move ``d`` (a
trapezoid; ``2 sqrt(d / a)`` when it never reaches ``v``), at :data:`MOVE_SPEED`
between points and :data:`APPROACH_SPEED` on the approach and retract.
"""
from __future__ import annotations

import csv
import io
from dataclasses import dataclass

import numpy as np

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.plantemplate import PlanTemplate, point_name
from vecpin.planning.armpose import pre_poses
from vecpin.planning.programroute import rereads
from vecpin.planning.timing import CampaignTime
from vecpin.units import MM_PER_M

ARM_DIALECTS = ("urscript", "joint-list")
MOVE_SPEED = 0.5        # rad/s, ASSUMED: joint speed between points (URScript's default v is 1.05)
APPROACH_SPEED = 0.05   # rad/s, ASSUMED: joint speed of the approach and the retract
ACCELERATION = 0.5      # rad/s^2, ASSUMED: joint acceleration (URScript's default a is 1.4)


def arm_dialects(dialects: tuple[str, ...] | None, machine: Machine) -> tuple[str, ...]:
    """The arm programs to write: ``dialects`` (default: all of :data:`ARM_DIALECTS`);
    an NC dialect is refused with the arm's alternatives named."""
    if dialects is None:
        return ARM_DIALECTS
    bad = [d for d in dialects if d not in ARM_DIALECTS]
    if bad:
        raise InputError(f"`dialect` {', '.join(bad)}: {machine.name} is an arm (no linear axis), an NC program does "
                         f"not drive it; choose {' or '.join(ARM_DIALECTS)} (urscript: a Universal Robots program, "
                         "joint-list: joint positions in degrees for any controller)")
    return tuple(dialects)


def arm_program_name(dialect: str, run: str = "plan") -> str:
    """The file name of an arm program: ``plan.script`` / ``plan_joints.csv`` (``run``
    "plan") or ``validation.script`` / ``validation_joints.csv``."""
    return f"{run}.script" if dialect == "urscript" else f"{run}_joints.csv"


@dataclass
class Pose:
    """One pose the program visits: ``kind`` approach/measure/retract/via, the joint
    positions ``q`` (n,) [rad], the template ``row`` it belongs to, the dwell [s] and
    what is read there (measure poses)."""
    kind: str
    q: np.ndarray
    row: int
    dwell_s: float = 0.0
    reads: str = ""


def arm_poses(machine: Machine, template: PlanTemplate, clearance: float, dwells: tuple[float, float, float],
              reads: int = 1) -> list[Pose]:
    """The poses of the program in order: per tool row its approach, measure and retract
    pose (``clearance`` [m] > 0; the measure pose alone at 0); the nest rows and the
    further readings of a point (:func:`~vecpin.planning.programroute.rereads`) read at the
    measure pose before them (``dwells`` [s]: the tool target's reading, a nest's, a
    further reading of a point)."""
    n = len(template)
    is_nest = np.zeros(n, bool) if template.instrument is None else template.instrument == "nest"
    again = rereads(template, reads)
    rows = np.flatnonzero(~(is_nest | again))
    pre, why = pre_poses(machine, template.q[rows], clearance)
    if np.any(why != ""):
        k = int(np.flatnonzero(why != "")[0])
        raise InputError(f"point {point_name(template.point[rows[k]])}: no approach pose {clearance * MM_PER_M:g} "
                         f"mm back along the tool axis ({why[k]}); plan it again or leave the row out")
    out: list[Pose] = []
    for i, row in enumerate(rows):
        end = rows[i + 1] if i + 1 < len(rows) else n
        dwell, what = dwells[0], [f"the tool target as {point_name(template.point[row])}"]
        for k in range(row + 1, end):
            dwell += dwells[2] if again[k] else dwells[1]
            what.append(f"{'again' if again[k] else 'table nest ' + str(template.target[k])} as "
                        f"{point_name(template.point[k])}")
        if clearance > 0:
            out.append(Pose("approach", pre[i], int(row)))
        out.append(Pose("measure", template.q[row], int(row), dwell, ", ".join(what)))
        if clearance > 0:
            out.append(Pose("retract", pre[i], int(row)))
    return out


def _move_time(d: float, v: float, a: float = ACCELERATION) -> float:
    """Time [s] of a joint move whose leading joint travels ``d`` [rad] (trapezoid)."""
    return d / v + v / a if d >= v * v / a else 2.0 * np.sqrt(d / a)


def arm_time(template: PlanTemplate, poses: list[Pose], holder_change_s: float) -> CampaignTime:
    """The campaign's time [s] as the arm program runs ``poses``: moves between points
    at :data:`MOVE_SPEED`, approaches and retracts at :data:`APPROACH_SPEED`, dwells,
    holder changes."""
    moves = approach = dwell = 0.0
    changes, prev, tool = 0, None, None
    backed_off = any(p.kind == "approach" for p in poses)
    for p in poses:
        L = float(template.tool[p.row])
        if tool is not None and abs(L - tool) > 1e-9 and p.kind != "retract":
            changes += 1
        tool = L
        if prev is not None:
            d = float(np.max(np.abs(p.q - prev)))
            if p.kind in ("approach", "via") or not backed_off:  # a move between points
                moves += _move_time(d, MOVE_SPEED)
            else:
                approach += _move_time(d, APPROACH_SPEED)
        dwell += p.dwell_s
        prev = p.q
    return CampaignTime(moves, approach, dwell, changes, holder_change_s)


def arm_route(machine: Machine, template: PlanTemplate, clearance: float, dwells: tuple[float, float, float],
              reads: int = 1, sight=None) -> tuple[list[Pose], list[str]]:
    """(the poses of :func:`arm_poses` with the via poses that keep the moves between points
    clear of the machine (``sight``: the planner's geometry; None: not checked), the moves
    no via pose frees)."""
    poses = arm_poses(machine, template, clearance, dwells, reads)
    if sight is None:
        return poses, []
    from vecpin.planning.armtransit import free_transits
    return free_transits(machine, template, poses, sight)


def _header(machine: Machine, template: PlanTemplate, clearance: float, title: str,
            left: list[str] | None = None, radius: float | None = None) -> list[str]:
    tools = np.unique(np.round(template.tool, 9))
    joints = ", ".join(a.name for a in machine.axes)
    return [f"vecpin measurement plan {title}".strip(),
            f"{len(template)} points, one per row of the plan; machine {machine.name} (an arm), target holder lengths "
            + ", ".join(f"{t * MM_PER_M:.3f} mm" for t in tools) + f" along the tool axis of {machine.tool_links[0]}",
            f"joint positions of {joints}: the URDF's joint coordinates, which must be the controller's "
            "(zero and sign)"] + ([f"target holder checked as a cylinder of radius {radius * MM_PER_M:.3f} mm"]
                                  if radius is not None else []) + [
            (f"each point: a joint move to its approach pose, {clearance * MM_PER_M:g} mm back along the tool axis "
             "with the measured orientation, then a slow joint move to the point, the dwell, and back to the approach "
             "pose"
             if clearance > 0 else "each point: a joint move straight to it, then the dwell"),
            f"joint speed {MOVE_SPEED:g} rad/s between points, {APPROACH_SPEED:g} rad/s on the approach and retract, "
            f"acceleration {ACCELERATION:g} rad/s^2 (ASSUMED, careful values)",
            ("the moves between points are the controller's joint interpolation, each posed with the arm's geometry "
             "every 2 deg and the area between (the holder clear of it; via poses first where the direct move is "
             "not): run it first at a reduced speed and watch the moves" if left is not None else
             "the moves between points are the controller's joint interpolation: run it first at a reduced speed and "
             "watch the moves")] + [f"WARNING: the move {m}: no route frees it: jog it by hand"
                                    for m in left or []]


def write_urscript(machine: Machine, template: PlanTemplate, poses: list[Pose], clearance: float,
                   title: str = "", left: list[str] | None = None, radius: float | None = None) -> str:
    """The URScript program visiting ``poses`` (see the module text; ``left``: the moves
    between points checked and not freed, None: not checked; ``radius`` [m]: the holder's
    radius they were checked with)."""
    out = [f"# {h}" for h in _header(machine, template, clearance, title, left, radius)]
    out.append("def vecpin_plan():")
    tool = None
    for p in poses:
        L = float(template.tool[p.row])
        if p.kind != "retract" and (tool is None or abs(L - tool) > 1e-9):
            msg = f"mount the target holder of {L * MM_PER_M:.3f} mm (flange to target centre), then continue"
            out += [f"  # holder length {L * MM_PER_M:.3f} mm",
                    f'  popup("{msg}", title="vecpin", blocking=True)']
            tool = L
        q = ", ".join(f"{v:.9f}" for v in p.q)
        v = APPROACH_SPEED if p.kind not in ("approach", "via") and clearance > 0 else MOVE_SPEED
        name = point_name(template.point[p.row])
        out.append(f"  movej([{q}], a={ACCELERATION:g}, v={v:g})  # {p.kind} {name}")
        if p.kind == "measure":
            out += [f"  # read {p.reads}", f"  sleep({p.dwell_s:.1f})"]
    out.append("end")
    return "\n".join(out) + "\n"


def write_joint_list(machine: Machine, template: PlanTemplate, poses: list[Pose]) -> str:
    """The joint-list CSV of ``poses``: one row per visited pose (see the module text)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["pose", "kind", "point", "holder_mm", "dwell_s"] + [f"{a.name}_deg" for a in machine.axes])
    for k, p in enumerate(poses, 1):
        w.writerow([k, p.kind, point_name(template.point[p.row]), f"{template.tool[p.row] * MM_PER_M:.3f}",
                    f"{p.dwell_s:.1f}"] + [f"{v:.6f}" for v in np.degrees(p.q)])
    return buf.getvalue()


def write_arm_program(dialect: str, machine: Machine, template: PlanTemplate, clearance: float, *,
                      dwell_s: float = 4.0, nest_dwell_s: float = 15.0, read_dwell_s: float = 2.0, reads: int = 1,
                      title: str = "", sight=None, route: tuple[list[Pose], list[str]] | None = None,
                      radius: float | None = None) -> str:
    """The ``dialect`` program (:data:`ARM_DIALECTS`) of ``template`` with the approach
    ``clearance`` [m] (0: none) and the dwells [s] of :func:`arm_poses`; ``sight``: the
    planner's geometry the moves between points are kept clear of (:func:`arm_route`;
    ``route``: its result, computed once for several dialects, ``radius`` [m] the holder's
    radius it was checked with)."""
    poses, left = route or arm_route(machine, template, clearance, (dwell_s, nest_dwell_s, read_dwell_s), reads, sight)
    if sight is not None:
        radius = sight.holder_radius
    if dialect == "urscript":
        return write_urscript(machine, template, poses, clearance, title, left if (sight or route) else None, radius)
    return write_joint_list(machine, template, poses)
