"""A model's errors as ISO 230-1 component errors, per axis position.

ISO 230-1 names a component error ``E`` + error direction + moving axis: for a linear
axis X ``EXX`` (positioning), ``EYX``, ``EZX`` (straightness), ``EAX``, ``EBX``,
``ECX`` (roll, pitch, yaw: rotations about X, Y, Z); for a rotary axis C ``EXC``,
``EYC``, ``EZC``, ``EAC``, ``EBC``, ``ECC`` (Heidenhain iTNC 530 HSCI technical
manual p.666; ISG/Beckhoff TF5280 parameter list). Error = actual - nominal.

What vecpin exports:

* **6-DoF model** - its error functions: the translation and rotation of each axis'
  error transform (Paper I eq. 3-6), turned from the axis' moving frame into the
  machine's X, Y, Z directions, with the other axes at 0 (or their nearest travel
  end). Reference point: the origin of the axis' moving (URDF joint) frame. Position
  and squareness errors (``X0C``, ``C0Y`` ...) are not separate: they sit in the
  constants and linear trends of these functions.
* **AP model** - its axis perturbations: the error of axis J's command as a function
  of axis I's position. Where J is linear and parallel to a machine direction D, that
  is the ISO component ``E<D><I>`` (a displacement of J's carriage along D), and
  where J = I is rotary it is the angular positioning error ``E<R><I>``; the other
  perturbations (a rotary axis' angle as a function of another axis) have no ISO
  230-1 component and are exported as ``Q<J><I>`` (in the unit of axis J).

Files: the neutral ``ISO230_<AXIS>.csv`` (comma separated, mm and degrees, units in
the column names, ``#`` comment lines first) and the ISG CSV of Beckhoff's volumetric
compensation (whitespace separated, ``//`` comments, mm and rad; TF5280 "ISG CSV
format").
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vecpin.compensation.limits import ControllerLimits
from vecpin.compensation.tables import TABLE_NAME_SEPARATOR, joined_axes
from vecpin.errors import ControllerFileError, InputError
from vecpin.export.common import ControllerFormat, ExportJob, no_check, read_lines, to_float
from vecpin.kinematics.machine import Machine
from vecpin.units import DEG_PER_RAD, MM_PER_M, RAD_PER_DEG, M_PER_MM

DIRECTIONS = "XYZ"
ROTATIONS = "ABC"  # about X, Y, Z


@dataclass
class ComponentErrors:
    """Component errors of one axis: ``errors[name]`` [m or rad] at ``positions`` [m or rad]."""

    axis: str
    kind: str
    positions: np.ndarray
    errors: dict[str, np.ndarray] = field(default_factory=dict)
    model_kind: str = ""


def _q_output(name: str, machine: Machine) -> str:
    """Output axis J of a 'Q<J><I>' column (axis names longer than a letter and digits
    joined by '_': :func:`~vecpin.compensation.tables.joined_axes`; run together, as
    files before it wrote them, read too)."""
    for a in sorted(machine.axis_names, key=len, reverse=True):
        rest = name[1:]
        tail = rest[len(a):]
        joined = tail.startswith(TABLE_NAME_SEPARATOR) and tail[len(TABLE_NAME_SEPARATOR):] in machine.axis_names
        if rest.startswith(a) and (tail in machine.axis_names or joined):
            return a
    raise InputError(f"column {name}: not Q<output axis><input axis>")


def _base_frames(machine: Machine, axis: str, q: np.ndarray) -> np.ndarray:
    """(N,3,3) orientation of the axis' moving frame in the base frame."""
    return machine.joint_frames(q, axis)[:, :3, :3]


def _grid(machine: Machine, axis: str, points: int) -> np.ndarray:
    """(points, n) commands: the axis over its travel, the others at 0 or their nearest travel end."""
    a = machine.axis(axis)
    q = np.tile(np.clip(0.0, machine.lower, machine.upper), (points, 1))
    q[:, a.index] = np.linspace(a.lower, a.upper, points)
    return q


def _direction_letter(v: np.ndarray, letters: str) -> tuple[str, float] | None:
    """('X', +1) when v is parallel to a base direction, else None."""
    k = int(np.argmax(np.abs(v)))
    if abs(abs(v[k]) - 1.0) < 1e-9:
        return letters[k], float(np.sign(v[k]))
    return None


def component_errors(model, points: int = 101) -> list[ComponentErrors]:
    """The model's component errors on ``points`` positions over each axis' travel (SI)."""
    model._check_fitted()
    m = model.machine
    out = []
    if model.kind == "6dof":
        for a in m.axes:
            q = _grid(m, a.name, points)
            vals = model.error_values(q, model.b_)[:, a.index, :]       # (N, 6) in the moving frame
            R = _base_frames(m, a.name, q)
            d, e = np.einsum("nij,nj->ni", R, vals[:, :3]), np.einsum("nij,nj->ni", R, vals[:, 3:])
            errs = {f"E{D}{a.name}": d[:, k] for k, D in enumerate(DIRECTIONS)}
            errs |= {f"E{A}{a.name}": e[:, k] for k, A in enumerate(ROTATIONS)}
            out.append(ComponentErrors(a.name, a.kind, q[:, a.index], errs, "6dof"))
        return out
    if model.kind == "ap":
        c, coef = model.split(model.b_)
        home = np.clip(0.0, m.lower, m.upper)[None]
        for a in m.axes:
            q = _grid(m, a.name, points)
            B = model.bases[a.index].values(q[:, a.index])[:, 1:]
            errs = {}
            for j, aj in enumerate(m.axes):
                f = B @ coef[:B.shape[1], a.index, j] + (c[j] if j == a.index else 0.0)
                axis_dir = _base_frames(m, aj.name, home)[0] @ np.array(aj.direction)
                if aj.kind == "linear":
                    hit = _direction_letter(axis_dir, DIRECTIONS)
                elif j == a.index:
                    hit = _direction_letter(axis_dir, ROTATIONS)
                else:
                    hit = None
                if hit is None:
                    errs[f"Q{joined_axes(aj.name, a.name)}"] = f
                else:
                    errs[f"E{hit[0]}{a.name}"] = hit[1] * f
            out.append(ComponentErrors(a.name, a.kind, q[:, a.index], errs, "ap"))
        return out
    raise InputError(f"ISO 230-1 export: no component errors for a '{model.kind}' model")


def _is_angle(name: str, machine: Machine) -> bool:
    if name.startswith("Q"):
        return machine.axis(_q_output(name, machine)).kind == "rotary"
    return name[1] in ROTATIONS


# ---------------------------------------------------------------------- neutral CSV
def neutral_name(axis: str) -> str:
    return f"ISO230_{axis}.csv"


def write_neutral(comp: ComponentErrors, machine: Machine, title: str) -> str:
    """Text of ``ISO230_<AXIS>.csv``: mm and degrees, units in the column names."""
    a = machine.axis(comp.axis)
    names = list(comp.errors)
    cols = [f"{a.name}_{a.unit}"] + [f"{n}_{'deg' if _is_angle(n, machine) else 'mm'}" for n in names]
    what = ("6-DoF model error functions: translation and rotation of the axis' error transform, turned into the "
            "machine's X, Y, Z directions; reference point: the origin of the axis' moving frame; other axes at 0"
            if comp.model_kind == "6dof" else
            "AP model axis perturbations: E<D><I> = error of the linear axis moving along D (or the rotary axis' own "
            "angular error) as a function of axis I; Q<J><I> = error of rotary axis J's angle as a function of I "
            "(no ISO 230-1 component)")
    lines = [f"# vecpin ISO 230-1 component errors of axis {a.name}, {title}",
             "# error = actual - nominal; E<direction><axis>; translations in mm, rotations in deg about X (A), Y (B), "
             "Z (C), positive by the right-hand rule",
             f"# {what}", ",".join(cols)]
    pos = a.to_user(comp.positions)
    vals = [comp.errors[n] * (DEG_PER_RAD if _is_angle(n, machine) else MM_PER_M) for n in names]
    for k in range(len(pos)):
        lines.append(",".join([f"{pos[k]:.6f}"] + [f"{v[k]:.12g}" for v in vals]))
    return "\n".join(lines) + "\n"


def _table_lines(path: Path, comment: str) -> tuple[int, str, list[tuple[int, str]]]:
    """The header (its line number from 1, its text) and the lines after it (number, text) of a
    one-table text file; blank lines and lines starting with ``comment`` passed over."""
    body = [(no, ln) for no, ln in enumerate(read_lines(path), 1) if ln.strip() and not ln.lstrip().startswith(comment)]
    if not body:
        raise ControllerFileError(path, "no header line", 1)
    return body[0][0], body[0][1], body[1:]


def _numbers(path: Path, rows: list[tuple[int, str]], cols: list[str], sep: str | None, head_no: int) -> np.ndarray:
    """(rows, columns) of the numbers in ``rows`` (line number, text), cells split at ``sep``
    (None: white space) and named by ``cols``; a wrong cell count, a cell that is not a
    finite number or no row at all is refused naming the line."""
    out, cells = [], "fields" if sep else "values"
    for no, ln in rows:
        parts = ln.split(sep)
        if len(parts) != len(cols):
            raise ControllerFileError(path, f"{len(parts)} {cells}, the header has {len(cols)}", no)
        out.append([to_float(p, path, no, cols[k]) for k, p in enumerate(parts)])
    if not out:
        raise ControllerFileError(path, "no rows", head_no)
    return np.array(out)


def read_neutral(path: Path, machine: Machine) -> ComponentErrors:
    """Parse ``ISO230_<AXIS>.csv`` back (SI)."""
    head_no, head, rows = _table_lines(path, "#")
    cols = [c.strip() for c in head.split(",")]
    parsed = []
    for c in cols:
        if "_" not in c:
            raise ControllerFileError(path, f"column '{c}' has no unit (NAME_mm or NAME_deg)", head_no)
        name, unit = c.rsplit("_", 1)
        if unit not in ("mm", "deg"):
            raise ControllerFileError(path, f"column '{c}': unit '{unit}' is not mm or deg", head_no)
        parsed.append((name, unit))
    axis = parsed[0][0]
    try:
        a = machine.axis(axis)
    except Exception as exc:
        raise ControllerFileError(path, str(exc), head_no) from None
    data = _numbers(path, rows, cols, ",", head_no)
    errs = {name: data[:, k] * (RAD_PER_DEG if unit == "deg" else M_PER_MM)
            for k, (name, unit) in enumerate(parsed) if k > 0}
    kind = "6dof" if not any(n.startswith("Q") for n in errs) else "ap"
    return ComponentErrors(a.name, a.kind, a.to_si(data[:, 0]), errs, kind)


# ---------------------------------------------------------------------- ISG CSV (Beckhoff TF5280)
def write_isg(comp: ComponentErrors, machine: Machine, title: str) -> str:
    """ISG CSV text: header of names, whitespace separated rows, mm / rad, argument mm or deg."""
    a = machine.axis(comp.axis)
    names = [n for n in comp.errors if not n.startswith("Q")]
    lines = [f"// vecpin {title}: ISO 230-1 component errors of {a.name} (mm, rad; argument {a.name} in {a.unit})",
             " ".join([a.name] + names)]
    pos = a.to_user(comp.positions)
    vals = [comp.errors[n] * (1.0 if n[1] in ROTATIONS else MM_PER_M) for n in names]
    for k in range(len(pos)):
        lines.append(" ".join([f"{pos[k]:.6f}"] + [f"{v[k]:.9g}" for v in vals]))
    return "\n".join(lines) + "\n"


def read_isg(path: Path, machine: Machine) -> ComponentErrors:
    """Parse an ISG CSV file of one axis (one header, no file breaks) back (SI)."""
    head_no, head, rows = _table_lines(path, "//")
    cols = head.split()
    try:
        a = machine.axis(cols[0])
    except Exception as exc:
        raise ControllerFileError(path, f"first column: {exc}", head_no) from None
    for c in cols[1:]:
        if len(c) < 3 or c[0] != "E" or c[1] not in DIRECTIONS + ROTATIONS or c[2:] != a.name:
            raise ControllerFileError(path, f"column '{c}' is not a component error of {a.name} (E<X..C>{a.name})",
                                      head_no)
    breaks = [no for no, ln in rows if ln.strip().startswith("#")]
    if breaks:
        raise ControllerFileError(path, "a file break (#): vecpin reads one table per file", breaks[0])
    data = _numbers(path, rows, cols, None, head_no)
    errs = {c: data[:, k] * (1.0 if c[1] in ROTATIONS else M_PER_MM) for k, c in enumerate(cols) if k > 0}
    return ComponentErrors(a.name, a.kind, a.to_si(data[:, 0]), errs, "")


# ---------------------------------------------------------------------- format
def write(job: ExportJob) -> list[str]:
    if job.model is None:
        raise InputError("iso230: the export needs the model (its error functions), not only tables")
    title = f"machine {job.machine.name}, {job.model.kind} model order {job.model.order}"
    names = []
    for comp in component_errors(job.model, min(job.points, 1001)):
        name = neutral_name(comp.axis)
        job.out.write_text(name, write_neutral(comp, job.machine, title))
        names.append(name)
    if job.model.kind == "ap":
        job.notes.append("iso230: an AP model has axis perturbations, not ISO 230-1 component errors; the files name "
                         "the ones that are components (E..) and export the others as Q<J><I> (see the file header)")
    return names


def read_components(folder: Path, machine: Machine) -> list[ComponentErrors]:
    """Every ``ISO230_<AXIS>.csv`` in ``folder``."""
    out = [read_neutral(Path(folder) / neutral_name(a.name), machine)
           for a in machine.axes if (Path(folder) / neutral_name(a.name)).exists()]
    if not out:
        raise ControllerFileError(folder, "no ISO230_<AXIS>.csv file")
    return out


LIMITS = ControllerLimits("iso230", source="ISO 230-1 component errors: no controller limit")

FORMAT = ControllerFormat(
    "iso230", "ISO 230-1 component errors (neutral)", LIMITS, write, None, no_check,
    files="`ISO230_<AXIS>.csv` per axis (component errors EXX, EYX, ... in mm and deg)",
    sign="error = actual - nominal (not a correction); rotations right-handed about X, Y, Z",
    source="ISO 230-1 naming as in Heidenhain iTNC 530 HSCI TM p.666 and Beckhoff TF5280 parameter lists",
    to_check="the receiving tool's reference point and sign convention (6-DoF: origin of each axis' moving frame)",
    needs_model=True)
