"""NC programs that drive the machine through a plan and wait for the tracker.

Four dialects (Siemens 840D, Fanuc, plain G-code as LinuxCNC, HEIDENHAIN conversational;
the blocks of each in :mod:`vecpin.planning.ncdialect`). Every program is safe to run as
written:

* units and a safety block before the first move (mm; no tool length or radius
  compensation, no canned cycle, no TRAORI; absolute; feed per minute), and at the end
  the state restored where the dialect can (LinuxCNC ``M70`` / ``M72``), or the header
  says what stays changed;
* every positioning block in machine coordinates (``SUPA`` on Siemens, ``G53`` on Fanuc
  and LinuxCNC), whatever work offset is active: the campaign records machine (axis)
  coordinates, the URDF's, in mm and degrees;
* between two points the *retract axis* (the linear axis along the tool at zero rotary
  angles, usually Z; ``retract_axis``) first moves away from the work to a safe machine
  position (``safe_z_mm``, default the end of its travel away from the work; higher
  when a point is), then the other linear axes, then the rotary axes move to the next
  point's approach position, then the retract axis plunges to it; the tool is raised in
  the same way before each holder change (``M0``) and at the end;
* each point is reached as the plan's approach column says (from the approach position,
  the point minus sign times the approach distance per axis, at ``feed_mm_min``; the plan
  chooses it so that the retract axis comes from the side away from the work and the
  holder meets nothing: :mod:`~vecpin.planning.approaches`); given the machine's geometry
  (``sight``) every move is checked and the rotary axes swing to neutral where a tilted
  holder would collide (:mod:`~vecpin.planning.programroute`);
  then a dwell for the tool target and every table nest read there (``dwell_s`` plus
  ``nest_dwell_s`` per nest; the comment names the read order);
* a run that reads every point several times in a row (``reads``: a table machine's
  validation run, :data:`~vecpin.planning.nests.VALIDATION_READS`) reads them at one
  standstill: the machine moves to the point once, then a comment and a dwell per
  reading and nothing else between them (``dwell_s`` for the tool's first reading,
  ``nest_dwell_s`` for a nest's first, where the tracker turns to it, and
  ``read_dwell_s``, the tracker's reading time, for every further reading of a point);
* on a plan read from several tracker stations (template column ``station``), the
  header says where the tracker stands for which points, and the program stops (``M0``)
  before each further station's block for the tracker to move there (``stations``).

The header counts the points as the rows of the plan (tool targets and nests). Values
are written with 3 decimals (the plan's commands are on a 0.001 mm / 0.001 deg grid, so
the program visits exactly the template's commands); a Siemens axis address of more
than one character takes ``=`` (``X1=100.000``), as the 840D requires.
"""
from __future__ import annotations

import math
import re

import numpy as np

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.plantemplate import PlanTemplate, point_name
from vecpin.planning import ncdialect as nc
from vecpin.planning.programroute import Router, Visit, visits
from vecpin.planning.retract import retract_axis, safe_position
from vecpin.units import MM_PER_M

DIALECTS = {"siemens-840d": "MPF", "fanuc": "nc", "gcode": "ngc", "heidenhain": "H"}
READ_DWELL_S = 2.0  # s, ASSUMED: the tracker's stationary reading of a point it is locked on (no settling, no turning)
_FANUC_AXES = set("XYZABCUVW")
_GCODE_AXES = set("XYZABCUVW")


def nc_axis_names(machine: Machine, dialect: str, axis_map: dict[str, str] | None = None) -> list[str]:
    """NC address of every axis (chain order): the URDF joint name unless mapped."""
    axis_map = axis_map or {}
    names = [axis_map.get(a.name, a.name) for a in machine.axes]
    for a, nm in zip(machine.axes, names):
        ok = (re.fullmatch(r"[A-Z][A-Z0-9]{0,7}", nm) is not None and nm[0] not in "FGMNOPST") if dialect == "siemens-840d" \
            else nm in (_FANUC_AXES if dialect == nc.FANUC else _GCODE_AXES)
        if not ok:
            allowed = "a capital letter (not F, G, M, N, O, P, S, T) with up to 7 more capitals or digits" \
                if dialect == "siemens-840d" else "one of X Y Z A B C U V W"
            raise InputError(f"axis '{a.name}' has no valid {dialect} address ('{nm}' is not {allowed}): "
                             f"give `axis_map` {a.name}=NCNAME")
    if len(set(names)) != len(names):
        raise InputError(f"NC axis names {', '.join(names)} repeat: every axis needs its own address (`axis_map`)")
    return names




def check_program_options(dwell_s: float, feed_mm_min: float, nest_dwell_s: float = 15.0,
                          read_dwell_s: float = READ_DWELL_S) -> None:
    """The dwells [s] and the approach feed [mm/min] are finite and > 0 (names the option)."""
    if not (math.isfinite(dwell_s) and dwell_s > 0):
        raise InputError(f"`dwell_s` {dwell_s}: the dwell is a time in seconds > 0")
    if not (math.isfinite(nest_dwell_s) and nest_dwell_s > 0):
        raise InputError(f"`nest_dwell_s` {nest_dwell_s}: the dwell per table nest is a time in seconds > 0")
    check_read_dwell(read_dwell_s)
    if not (math.isfinite(feed_mm_min) and feed_mm_min > 0):
        raise InputError(f"`feed_mm_min` {feed_mm_min}: the approach feed is mm/min > 0")


def check_read_dwell(read_dwell_s: float) -> None:
    """The dwell per further reading of a point [s] is finite and > 0 (names the option)."""
    if not (math.isfinite(read_dwell_s) and read_dwell_s > 0):
        raise InputError(f"`read_dwell_s` {read_dwell_s:g}: the dwell per further reading of a point is a time in "
                         "seconds > 0")


def readings(template: PlanTemplate, v: Visit,
             dwells: tuple[float, float, float]) -> list[tuple[int, float, str, bool]]:
    """(row, dwell [s], what is read, a further reading?) of every reading at the standstill
    ``v``, in order; ``dwells`` [s]: (the tool target's first reading, a nest's first
    reading, every further reading of a point, ``v.again``)."""
    dwell_s, nest_dwell_s, read_dwell_s = dwells
    out = []
    for k, again in zip([v.row, *v.after], [False, *v.again]):
        nest = template.instrument is not None and template.instrument[k] == "nest"
        what = f"table nest {template.target[k]}" if nest else "the tool target"
        name = point_name(template.point[k])
        if again:
            out.append((k, read_dwell_s, f"read {what} again as {name}, the machine standing still", True))
        else:
            out.append((k, nest_dwell_s if nest else dwell_s, f"read {what} as {name}", False))
    return out


def retract_travel_mm(machine: Machine, template: PlanTemplate, steps: np.ndarray, safe_z_mm: float | None = None,
                      retract: str | None = None, sight=None) -> float:
    """How far the retract axis travels in the lifts and plunges between points [mm] (and
    in the swings' lifts and descents where ``sight`` makes the program swing, see
    :class:`~vecpin.planning.programroute.Router`)."""
    router = Router(machine, template, steps, sight, safe_z_mm=safe_z_mm, retract=retract)
    r, total, cur = router.r, 0.0, None
    q_of = {v.row: v.q for v in router.route}
    for s in router.steps():
        if s.axes == [r] and cur is not None:
            total += abs(s.to[r] - cur)
        cur = float(q_of[s.row][r]) if s.what == "plunge" else (float(s.to[r]) if np.isfinite(s.to[r]) else cur)
    return total


def station_where(k: int, stations: list | None) -> str:
    """'tracker station K+1' of station id ``k``, with its position when ``stations``
    (positions (3,) [m], machine base frame, by station id) gives it."""
    at = (" at " + ", ".join(f"{round(v * MM_PER_M) + 0:.0f}" for v in stations[k]) + " mm (machine base frame)"
          if stations is not None and k < len(stations) else "")
    return f"tracker station {k + 1}{at}"


def station_notes(template: PlanTemplate, stations: list | None) -> list[str]:
    """Header lines saying where the tracker stands for which points: one per station of
    a plan read from several (``stations``: see :func:`station_where`), none on a plan
    read from one."""
    st = template.stations
    if not np.any(st != 0):
        return []
    out = []
    for k in np.unique(st):
        rows = np.flatnonzero(st == k)
        out.append(f"{station_where(int(k), stations)}: points {point_name(template.point[rows[0]])} to "
                   f"{point_name(template.point[rows[-1]])}"
                   + (" (the program stops before them for the tracker to move)" if k else ""))
    return out


def program_header(dialect: str, machine: Machine, template: PlanTemplate, names: list[str], moves: tuple,
                   times: tuple[float, float, float, float], title: str = "", stations: list | None = None,
                   reads: int = 1) -> list[str]:
    """The program's header lines (comments): what it measures, in which coordinates, how
    it moves between the points (``moves``: retract axis index, its safe position [mm],
    the other linear and the rotary axis indices), what it does at each (``times``:
    dwell [s], dwell per nest [s], approach feed [mm/min], dwell per further reading [s];
    ``reads``: readings of every point at its standstill) and where the tracker stands
    (:func:`station_notes`)."""
    r, safe, others, rotary = moves
    dwell_s, nest_dwell_s, feed_mm_min, read_dwell_s = times
    is_nest = np.zeros(len(template), bool) if template.instrument is None else template.instrument == "nest"
    tools = np.unique(np.round(template.tool, 9))
    n_tool, n_nest = len(template) - int(is_nest.sum()), int(is_nest.sum())
    mc = {nc.SIEMENS: "SUPA", nc.HEIDENHAIN: "M91"}.get(dialect, "G53")
    tlc = {nc.SIEMENS: "D0", nc.HEIDENHAIN: "no TOOL CALL; M91 blocks do not compensate it"}.get(dialect, "G49")
    sweep = " ".join(names[j] for j in others) or "-"
    rot = " ".join(names[j] for j in rotary)
    return [f"vecpin measurement plan {title}".strip(),
            f"{len(template)} points, one per row of the plan: {n_tool} tool target points"
            + (f" and {n_nest} table nest points read at their dwells" if n_nest else ""),
            f"machine {machine.name}, target holder lengths " + ", ".join(f"{t * MM_PER_M:.3f} mm" for t in tools),
            f"axis positions in machine coordinates ({mc} in every positioning block): the URDF axis coordinates, "
            "mm and degrees, whatever work offset is active",
            f"no tool length compensation ({tlc}), no TRAORI / G43.4 / M128: the plan commands axes, not the tool tip",
            f"between points: {names[r]} retracts to {safe:.3f} mm (machine coordinate, the plan's safe height) or higher, then "
            f"{sweep} move, then {rot or 'no rotary axis'}, then {names[r]} plunges to the approach position",
            f"each point: from its approach position at F{feed_mm_min:g} to the point, then a dwell of {dwell_s:g} s "
            f"for the tool target and {nest_dwell_s:g} s per table nest read there"
            + (f"; the tool target and every nest read {reads} times in a row, the machine standing still: a dwell of "
               f"{read_dwell_s:g} s (the tracker's reading time) per further reading and no motion between the readings"
               if reads > 1 else ""),
            *station_notes(template, stations),
            nc.restore_note(dialect),
            "run it first at a reduced rapid override and watch the moves"]


def approach_note(machine: Machine, steps: np.ndarray, retract_name: str, sight=None) -> str:
    """The header line on the approach and the clearance the moves were checked with."""
    st = machine.to_user(np.asarray(steps, float)[None])[0]
    lin = [v for a, v in zip(machine.axes, st) if a.kind == "linear"]
    rot = [v for a, v in zip(machine.axes, st) if a.kind == "rotary"]
    dist = " / ".join([f"{max(lin):g} mm"] * bool(lin) + [f"{max(rot):g} deg"] * bool(rot))
    checked = ("where a tilted holder would meet the machine at the safe height, the rotary axes turn to neutral "
               "at the highest free height before the transit and back after it; " if sight is not None else "") + (
               f"every move was posed with the machine's {sight.geometry} geometry and the target holder's axis "
               "(gauge line to target centre) is clear of it: the area it sweeps on a move of linear axes, positions "
               "every 2 deg on a move of a rotary axis, moves taken as straight lines in axis space"
               if sight is not None else "the moves were not checked against the machine's geometry")
    return (f"approach clearance {dist}: each point from its approach position that far away on the axes the plan's "
            f"approach column names, {retract_name} always from the side away from the work, so no rapid passes a "
            f"point toward the work; {checked}")


def write_program(dialect: str, machine: Machine, template: PlanTemplate, steps: np.ndarray, *, dwell_s: float = 4.0,
                  nest_dwell_s: float = 15.0, feed_mm_min: float = 1000.0, safe_z_mm: float | None = None,
                  retract: str | None = None, axis_map: dict[str, str] | None = None, program_number: int = 1000,
                  title: str = "", stations: list | None = None, reads: int = 1,
                  read_dwell_s: float = READ_DWELL_S, sight=None) -> str:
    """The NC program text visiting ``template``'s rows in order (see the module docstring).

    ``steps`` (n,) [m, rad]: approach distance per axis; ``dwell_s`` [s] at every point for
    the tool target, ``nest_dwell_s`` [s] more per table nest read there; ``feed_mm_min``
    [mm/min] for the final approach; ``safe_z_mm`` [mm] the retract axis' safe machine
    position (default: the end of its travel away from the work); ``retract``: the
    retract axis' name (default: found from the kinematics); ``stations``: the tracker
    stations' positions (3,) [m], machine base frame, by station id (a plan read from
    several, :func:`station_notes`); ``reads``: the template reads every point that many
    times in a row, at one standstill (:func:`~vecpin.planning.programroute.rereads`; a comment and a dwell per reading,
    ``read_dwell_s`` [s] for every further reading); ``sight``: a
    :class:`~vecpin.planning.sightline.SightLine` whose geometry every move is checked
    with (:class:`~vecpin.planning.programroute.Router`: the rotary axes swing to neutral
    where a tilted holder would meet it; a program no swing frees is refused)."""
    if dialect not in DIALECTS:
        raise InputError(f"unknown NC dialect '{dialect}' ({', '.join(DIALECTS)})")
    check_program_options(dwell_s, feed_mm_min, nest_dwell_s, read_dwell_s)
    names = nc_axis_names(machine, dialect, axis_map)
    r, up = retract_axis(machine, retract)
    safe = safe_position(machine, r, up, safe_z_mm)
    others = [a.index for a in machine.axes if a.kind == "linear" and a.index != r]
    rotary = [a.index for a in machine.axes if a.kind == "rotary"]
    app = template.approach if template.approach is not None else np.zeros_like(template.q)
    moves = _moves_by_row(Router(machine, template, steps, sight, safe_z_mm=safe_z_mm, retract=retract,
                                 reads=reads))

    def comment(text: str) -> str:
        return nc.nc_comment(dialect, text)

    def move(idx: list[int], values) -> str:
        return nc.rapid(dialect, [names[j] for j in idx], [float(values[j]) for j in idx])

    out: list[str] = []
    pgm = program_name(dialect, "validation" if program_number == 1001 else "plan").split(".")[0]
    if dialect == nc.FANUC:
        out += ["%", f"O{program_number:04d} {comment('vecpin measurement plan')}"]
    if dialect == nc.HEIDENHAIN:
        out.append(f"BEGIN PGM {pgm} MM")
    head = program_header(dialect, machine, template, names, (r, safe, others, rotary),
                          (dwell_s, nest_dwell_s, feed_mm_min, read_dwell_s), title, stations, reads)
    head.append(approach_note(machine, steps, names[r], sight))
    out += [c for h in head for c in nc.comments(dialect, h)] + nc.prologue(dialect)
    route, end = visits(machine, template, steps, r, up, safe, reads)
    current_tool, current_station = None, 0
    for v in route:
        i = v.row
        mine = moves.get(i, [])
        first = next((k for k, s in enumerate(mine) if s.what not in ("lift", "swing")), len(mine))
        out += [move(s.axes, s.to) for s in mine[:first]]   # lifted (the rotary axes neutral where they swing)
        if template.stations[i] != current_station:
            current_station = int(template.stations[i])
            where = station_where(current_station, stations)
            out.append(comment(where))
            out.append(nc.stop(dialect, f"move the tracker: {where}, lock on the target, then cycle start"))
        L = float(template.tool[i])
        if current_tool is None or abs(L - current_tool) > 1e-9:
            msg = f"mount the target holder of {L * MM_PER_M:.3f} mm (gauge line to target centre), then cycle start"
            out.append(comment(f"holder length change: {L * MM_PER_M:.3f} mm" if current_tool is not None else
                               f"holder length {L * MM_PER_M:.3f} mm"))
            out.append(nc.stop(dialect, msg))
            current_tool = L
        out.append(comment(point_name(template.point[i])))
        out += [move(s.axes, s.to) for s in mine[first:]]
        if np.any(app[i] != 0):
            out += nc.approach(dialect, names, list(v.a), list(v.q), feed_mm_min)
        out += _reads_at(dialect, template, v, (dwell_s, nest_dwell_s, read_dwell_s))
    if end is not None:
        out.append(move([r], {r: end}))
    out += nc.epilogue(dialect)
    if dialect == nc.FANUC:
        out.append("%")
    if dialect == nc.HEIDENHAIN:  # every block numbered, from 0
        out.append(f"END PGM {pgm} MM")
        out = [f"{k} {b}" for k, b in enumerate("\n".join(out).split("\n"))]
    return "\n".join(out) + "\n"


def _moves_by_row(router: Router) -> dict[int, list]:
    """The positioning moves into each tool row's point (:meth:`Router.steps`, the final
    lift left out), by row."""
    moves: dict[int, list] = {}
    for s in router.steps():
        if s.what != "final lift":
            moves.setdefault(s.row, []).append(s)
    return moves


def _reads_at(dialect: str, template: PlanTemplate, v: Visit, dwells: tuple[float, float, float]) -> list[str]:
    """The blocks of the readings at the standstill ``v``: one comment and one dwell for all
    of them when each point is read once; a comment and a dwell [s] per reading when a
    point is read again there (:func:`readings`, ``dwells`` [s]), no motion between them."""
    if not v.again.any():
        read = f"read the tool target as {point_name(template.point[v.row])}"
        if v.after:
            read += ", then the table nests in this order: " + ", ".join(
                f"{template.target[k]} as {point_name(template.point[k])}" for k in v.after)
        return [nc.nc_comment(dialect, read), nc.dwell(dialect, dwells[0] + dwells[1] * len(v.after))]
    return [b for _, sec, what, _ in readings(template, v, dwells)
            for b in (nc.nc_comment(dialect, what), nc.dwell(dialect, sec))]


def program_name(dialect: str, run: str = "plan") -> str:
    """The file name of a dialect's program: of the plan (``run`` "plan") or of its
    validation run ("validation"; Fanuc program number 1001)."""
    if run == "validation":
        return {"siemens-840d": "VALID_840D.MPF", "fanuc": "O1001.nc", "gcode": "validation.ngc",
                "heidenhain": "VALID.H"}[dialect]
    return {"siemens-840d": "PLAN_840D.MPF", "fanuc": "O1000.nc", "gcode": "plan.ngc", "heidenhain": "PLAN.H"}[dialect]
