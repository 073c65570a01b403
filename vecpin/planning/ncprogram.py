"""NC programs that drive the machine through a plan and wait for the tracker.

Three dialects, each using only: absolute positioning in mm (Siemens ``G90 G71 G94``,
Fanuc ``G90 G21 G94``, plain ``G90 G21 G94``), rapid moves ``G0``, the final approach
at a feed ``G1 ... F``, a dwell for the tracker (Siemens ``G4 F<s>`` in a block of its
own, Fanuc ``G04 P<ms>``, plain G-code as LinuxCNC ``G4 P<s>``), a programmed stop
``M0`` where the target holder (tool length) changes, and the end ``M30`` (plain: ``M2``).
Comments: Siemens ``; ...``, Fanuc and plain ``( ... )`` (Fanuc in capitals).

Every point is reached as the plan's approach says: a rapid move to the approach
position (the point minus the approach distance on every axis, for ``below``), then
``G1`` to the point, then the dwell. Axis words carry the machine's axis positions in
the URDF's axis coordinates (mm, degrees): the program assumes a work offset at the
URDF zero and no tool length or tool-centre-point transformation (TRAORI, G43.4).
Values are written with 3 decimals (the plan's commands are on a 0.001 mm / 0.001 deg
grid, so the program visits exactly the template's commands); a Siemens axis address of
more than one character takes ``=`` (``X1=100.000``), as the 840D requires for extended
addresses.
"""
from __future__ import annotations

import math
import re

import numpy as np

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.plantemplate import PlanTemplate, point_name
from vecpin.units import MM_PER_M

DIALECTS = {"siemens-840d": "MPF", "fanuc": "nc", "gcode": "ngc"}
_FANUC_AXES = set("XYZABCUVW")
_GCODE_AXES = set("XYZABCUVW")


def nc_axis_names(machine: Machine, dialect: str, axis_map: dict[str, str] | None = None) -> list[str]:
    """NC address of every axis (chain order): the URDF joint name unless mapped."""
    axis_map = axis_map or {}
    names = [axis_map.get(a.name, a.name) for a in machine.axes]
    for a, nm in zip(machine.axes, names):
        ok = (re.fullmatch(r"[A-Z][A-Z0-9]{0,7}", nm) is not None and nm[0] not in "FGMNOPST") if dialect == "siemens-840d" \
            else nm in (_FANUC_AXES if dialect == "fanuc" else _GCODE_AXES)
        if not ok:
            allowed = "a capital letter (not F, G, M, N, O, P, S, T) with up to 7 more capitals or digits" \
                if dialect == "siemens-840d" else "one of X Y Z A B C U V W"
            raise InputError(f"axis '{a.name}' has no valid {dialect} address ('{nm}' is not {allowed}): "
                             f"give --axis-map {a.name}=NCNAME")
    if len(set(names)) != len(names):
        raise InputError(f"NC axis names {', '.join(names)} repeat: every axis needs its own address (--axis-map)")
    return names


def _words(machine: Machine, names: list[str], q: np.ndarray) -> str:
    """Axis words; an address longer than one letter takes '=' (Siemens: ``X1=100.0``)."""
    q_user = machine.to_user(q[None])[0]
    return " ".join(f"{n}{'=' if len(n) > 1 else ''}{v:.3f}" for n, v in zip(names, q_user))


def check_program_options(dwell_s: float, feed_mm_min: float) -> None:
    """The dwell [s] and the approach feed [mm/min] are finite and > 0 (names the option)."""
    if not (math.isfinite(dwell_s) and dwell_s > 0):
        raise InputError(f"--dwell {dwell_s}: the dwell is a time in seconds > 0")
    if not (math.isfinite(feed_mm_min) and feed_mm_min > 0):
        raise InputError(f"--feed {feed_mm_min}: the approach feed is mm/min > 0")


def write_program(dialect: str, machine: Machine, template: PlanTemplate, steps: np.ndarray, *, dwell_s: float = 4.0,
                  feed_mm_min: float = 1000.0, axis_map: dict[str, str] | None = None, program_number: int = 1000,
                  title: str = "") -> str:
    """The NC program text visiting ``template``'s rows in order.

    ``steps`` (n,) [m, rad]: approach distance per axis; ``dwell_s`` [s] at every point;
    ``feed_mm_min`` [mm/min] for the final approach."""
    if dialect not in DIALECTS:
        raise InputError(f"unknown NC dialect '{dialect}' ({', '.join(DIALECTS)})")
    check_program_options(dwell_s, feed_mm_min)
    names = nc_axis_names(machine, dialect, axis_map)
    siemens, fanuc = dialect == "siemens-840d", dialect == "fanuc"

    def comment(text: str) -> str:
        if siemens:
            return f"; {text}"
        text = text.replace("(", "[").replace(")", "]")
        return f"({text.upper() if fanuc else text})"

    def dwell() -> str:
        if siemens:
            return f"G4 F{dwell_s:.1f}"
        if fanuc:
            return f"G04 P{int(round(dwell_s * 1000))}"
        return f"G4 P{dwell_s:.1f}"

    g0, g1 = ("G00", "G01") if fanuc else ("G0", "G1")
    out: list[str] = []
    if fanuc:
        out += ["%", f"O{program_number:04d} {comment('vecpin measurement plan')}"]
    is_nest = np.zeros(len(template), bool) if template.instrument is None else template.instrument == "nest"
    tools = np.unique(np.round(template.tool, 9))
    head = [f"vecpin measurement plan {title}".strip(),
            f"machine {machine.name}: {len(template) - int(is_nest.sum())} points, target holder lengths "
            + ", ".join(f"{t * MM_PER_M:.3f} mm" for t in tools),
            "axis positions in the URDF axis coordinates, mm and degrees; work offset at the URDF zero;",
            "no tool length compensation, no TRAORI / G43.4 (the plan commands axes, not the tool tip)",
            f"each point: rapid to its approach position, {g1} at F{feed_mm_min:g} to the point, dwell {dwell_s:g} s",
            "moves between points are direct: check them for collisions before running"]
    out += [comment(h) for h in head]
    out.append("G90 G71 G94" if siemens else "G90 G21 G94")
    feed = f"F{feed_mm_min:.0f}." if fanuc else f"F{feed_mm_min:g}"
    current_tool = None
    app = template.approach
    for i in range(len(template)):
        if is_nest[i]:
            continue  # read at the dwell of the tool row before it, see below
        L = float(template.tool[i])
        if current_tool is None or abs(L - current_tool) > 1e-9:
            msg = (f"mount the target holder of {L * MM_PER_M:.3f} mm (gauge line to target centre), "
                   "then cycle start")
            out.append(comment(f"holder length change: {L * MM_PER_M:.3f} mm" if current_tool is not None else
                               f"holder length {L * MM_PER_M:.3f} mm"))
            out.append(f"M0 {comment(msg)}" if not fanuc else f"M00 {comment(msg)}")
            current_tool = L
        q = template.q[i]
        sign = app[i] if app is not None else np.zeros(machine.n_axes)
        name = point_name(template.point[i])
        out.append(comment(name))
        if np.any(sign != 0):
            out.append(f"{g0} {_words(machine, names, q - sign * steps)}")
            out.append(f"{g1} {_words(machine, names, q)} {feed}")
        else:
            out.append(f"{g0} {_words(machine, names, q)}")
        j = i + 1
        while j < len(template) and is_nest[j]:
            j += 1
        if j > i + 1:
            out.append(comment("then read table nests " + ", ".join(
                f"{template.target[k]} as {point_name(template.point[k])}" for k in range(i + 1, j))))
        out.append(dwell())
    out.append("M30" if dialect != "gcode" else "M2")
    if fanuc:
        out.append("%")
    return "\n".join(out) + "\n"


def program_name(dialect: str) -> str:
    """The file name of a dialect's program."""
    return {"siemens-840d": "PLAN_840D.MPF", "fanuc": "O1000.nc", "gcode": "plan.ngc"}[dialect]
