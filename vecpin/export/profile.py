"""A machine's controller profile: the machine-side facts a controller file needs.

A compensation file that a controller accepts with the wrong axis, reference point
or unit silently makes the machine worse, so vecpin never guesses these facts: a
writer that needs one and does not find it stops with a message naming the axis,
the field and what the controller uses it for. The facts live in a small JSON file
(``profile``), one per machine and controller::

    {
     "format": "vecpin-controller-profile", "version": 1,
     "machine": "flow_xyzcb", "controller": "fanuc-30i",
     "axes": {
      "X": {"nc_name": "X1", "number": 1, "reference_position": 0.0, "detection_unit": 0.001},
      "C": {"nc_name": "C1", "number": 4, "reference_position": 0.0, "detection_unit": 0.001, "modulo": false}
     },
     "limits": {"max_cross_points": 500},
     "options": {"comp_file_type": 1}
    }

Positions and units are the NC's, in mm (linear) or degrees (rotary). vecpin's axis
commands are the NC's machine coordinates (a campaign records the commanded axis
positions), so a reference position is given in the same coordinates as the tables.

Axis fields (all optional; each format says which it needs):

================== ===================================================================
``nc_name``         the controller's name of the machine axis (Siemens ``X1``, Heidenhain
                    and Beckhoff axis names)
``general_name``    Siemens general axis name ``AXn`` (CEC tables use it when given)
``program_name``    the axis address in part programs (sign-test program; default: the
                    vecpin axis name, flagged in the instructions)
``number``          Fanuc controlled-axis number (``A<n>``), LinuxCNC joint number,
                    Beckhoff logical axis number
``reference_position``  NC machine coordinate of the reference point [mm or deg]
``modulo``          the NC treats this rotary axis as modulo (positions 0..360 deg)
``detection_unit``  detection unit [mm or deg] (Fanuc pitch data count in it)
``following``       a gantry axis driven by two motors (seed Section 2.5, the Master
                    Mill's X: AX1 leading, AX8 following): the *following* drive's facts
                    (the same fields; the axis' own facts are the leading drive's). Every
                    table that corrects the axis is written for both drives.
``drive_separation_mm``  [dx, dy, dz] from the leading to the following drive [mm],
                    machine base frame: with it a diagnosed gantry skew (a rotation
                    after the axis) becomes a differential table between the drives
================== ===================================================================

Every field is checked on load (:meth:`ControllerProfile.from_dict`), the message naming
the file and the field: names are plain (:data:`~vecpin.kinematics.axes.PLAIN_NAME`: they
become file names and NC words), numbers finite and in range, ``nc_name``,
``general_name`` and ``number`` unique over the axes and their following drives, unknown
fields and options refused with the known ones; :meth:`ControllerProfile.check_machine`
adds what needs the machine (axes, modulo, reference positions inside the travel).

A twin-drive axis::

      "X": {"nc_name": "X1", "number": 1, "reference_position": 0.0,
            "following": {"nc_name": "X2", "number": 8, "reference_position": 0.0},
            "drive_separation_mm": [0.0, 4200.0, 0.0]}
"""
from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from vecpin.errors import InputError
from vecpin.kinematics.axes import PLAIN_NAME

AXIS_MAP = "`axis_map`"  # where NC names came from when no profile file gave any

FORMAT = "vecpin-controller-profile"
VERSION = 1

AXIS_FIELDS = {
    "nc_name": str, "general_name": str, "program_name": str, "number": int,
    "reference_position": float, "modulo": bool, "detection_unit": float,
}
DRIVE_FIELDS = ("following", "drive_separation_mm")  # twin-drive axes (read by :func:`_drive_facts`)
TOP_FIELDS = {"format", "version", "machine", "controller", "axes", "limits", "options", "comment",
              "$schema"}  # $schema: the JSON Schema an editor checks the file with (vecpin/schemas)
OPTIONS = {"comp_file_type": int, "rotary_any_range": bool,  # LinuxCNC file type; Heidenhain rotary range
           "ini": Path}                                        # LinuxCNC: the machine's INI file (joints checked)
CASE_NOTE = ("names and the file names made of them are compared without case: Heidenhain, Fanuc and Siemens "
             "controllers read them without case (no vendor source at hand says otherwise), and LinuxCNC's, though "
             "its Linux file names and HAL pins are case-sensitive, would merge on the case-insensitive file systems "
             "configurations are copied through (Windows, macOS)")
NAME_FIELDS = ("nc_name", "general_name", "program_name")     # become file names and NC words: plain names
UNIQUE_FIELDS = ("nc_name", "general_name", "number")          # one machine drive each
MAX_NUMBER = 999



def load_option_json(path: str | Path, option: str):
    """The JSON content of a file given with the parameter ``option`` (a profile, a sign
    test); a missing or unreadable file is an InputError naming the parameter and the file."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"`{option}` {path}: no such file")
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"`{option}` {path}: not a JSON file ({exc})") from None
    except RecursionError:
        raise InputError(f"`{option}` {path}: nested too deeply to be a vecpin file") from None
    except OSError as exc:
        raise InputError(f"{option} {path}: cannot read the file ({exc.strerror})") from None

@dataclass(frozen=True)
class AxisProfile:
    """The controller's facts about one machine axis (None: not given)."""

    nc_name: str | None = None
    general_name: str | None = None
    program_name: str | None = None
    number: int | None = None
    reference_position: float | None = None
    modulo: bool | None = None
    detection_unit: float | None = None
    following: "AxisProfile | None" = None                        # the following drive of a twin-drive axis
    drive_separation_mm: tuple[float, float, float] | None = None  # leading -> following drive, base frame [mm]


@dataclass
class ControllerProfile:
    """Facts about one machine's controller; ``where`` names their source in messages."""

    axes: dict[str, AxisProfile] = field(default_factory=dict)
    limits: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)
    machine: str | None = None
    controller: str | None = None
    where: str = "controller profile (`profile`)"

    # ------------------------------------------------------------------ files
    @classmethod
    def load(cls, path: str | Path) -> "ControllerProfile":
        return cls.from_dict(load_option_json(path, "profile"), str(path))

    @classmethod
    def from_dict(cls, d: dict, where: str = "controller profile") -> "ControllerProfile":
        if not isinstance(d, dict) or d.get("format") != FORMAT:
            raise InputError(f"{where}: not a vecpin controller profile (\"format\" must be \"{FORMAT}\")")
        if d.get("version") != VERSION:
            raise InputError(f"{where}: profile version {d.get('version')!r} is not supported (this vecpin reads {VERSION})")
        unknown = sorted(set(d) - TOP_FIELDS)
        if unknown:
            raise InputError(f"{where}: unknown field '{unknown[0]}' (known: {', '.join(sorted(TOP_FIELDS))})")
        if "$schema" in d and (not isinstance(d["$schema"], str) or not d["$schema"].strip()):
            raise InputError(f"{where}, field '$schema': {d['$schema']!r}: the address of the JSON Schema an editor "
                             "checks the file with (a text), or leave the field out")
        axes = {}
        raw_axes = d.get("axes", {})
        if not isinstance(raw_axes, dict):
            raise InputError(f"{where}, field 'axes': an object of axis name -> facts")
        for name, facts in raw_axes.items():
            if not isinstance(facts, dict):
                raise InputError(f"{where}, field 'axes.{name}': an object of facts")
            values = _drive_facts(facts, f"{where}, field 'axes.{name}")
            for key, value in facts.items():
                if key in DRIVE_FIELDS or (value is None and key in AXIS_FIELDS):   # null: not given (a template's)
                    continue
                if key not in AXIS_FIELDS:
                    raise InputError(f"{where}, field 'axes.{name}.{key}': unknown (known: "
                                     f"{', '.join(list(AXIS_FIELDS) + list(DRIVE_FIELDS))})")
                values[key] = _typed(value, AXIS_FIELDS[key], f"{where}, field 'axes.{name}.{key}'")
            axes[name] = AxisProfile(**values)
        for key in ("limits", "options"):
            if not isinstance(d.get(key, {}), dict):
                raise InputError(f"{where}, field '{key}': an object of name -> value")
        for key in ("machine", "controller"):
            if d.get(key) is not None and (not isinstance(d[key], str) or not d[key].strip()):
                raise InputError(f"{where}, field '{key}': a non-empty text, not {d[key]!r}")
        options = dict(d.get("options", {}))
        for key, value in options.items():
            if key not in OPTIONS:
                raise InputError(f"{where}, field 'options.{key}': unknown option (known: {', '.join(sorted(OPTIONS))})")
            if value is None:                                              # null: not given (a template's)
                continue
            if OPTIONS[key] is Path:
                if not isinstance(value, str) or not value.strip() or any(ord(c) < 32 for c in value):
                    raise InputError(f"{where}, field 'options.{key}': a file path, not {value!r}")
            else:
                _typed(value, OPTIONS[key], f"{where}, field 'options.{key}'")
        options = {k: v for k, v in options.items() if v is not None}
        limits = dict(d.get("limits", {}))
        for key, value in limits.items():
            if isinstance(value, float) and not math.isfinite(value):
                raise InputError(f"{where}, field 'limits.{key}': a finite number, not {value!r}")
        prof = cls(axes, limits, options, d.get("machine"), d.get("controller"), where)
        prof.check_unique()
        return prof

    def to_dict(self) -> dict:
        axes = {a: _axis_dict(p) for a, p in self.axes.items()}
        out = {"format": FORMAT, "version": VERSION}
        if self.machine:
            out["machine"] = self.machine
        if self.controller:
            out["controller"] = self.controller
        out["axes"] = axes
        if self.limits:
            out["limits"] = self.limits
        if self.options:
            out["options"] = self.options
        return out

    # ------------------------------------------------------------------ facts
    def axis(self, name: str) -> AxisProfile:
        return self.axes.get(name, AxisProfile())

    def need(self, axis: str, key: str, controller: str, purpose: str):
        """The fact ``key`` of ``axis``, or an error saying where to give it."""
        value = getattr(self.axis(axis), key)
        if value is None:
            hint = (f"`axis_map` {axis}=NAME or " if key == "nc_name" else "")
            where = "a controller profile (`profile`)" if self.where == AXIS_MAP else f"the {self.where}"
            raise InputError(f"{controller} needs the {purpose} of axis {axis}: give {hint}\"{key}\" under "
                             f"axes.{axis} in {where}, e.g. {{\"axes\": {{\"{axis}\": {{\"{key}\": ...}}}}}} "
                             "(vecpin's profile command writes a template with every field)")
        return value

    def limit(self, name: str, default):
        return self.limits.get(name, default)

    def option(self, name: str, default):
        return self.options.get(name, default)

    def modulo_axes(self) -> list[str]:
        return [a for a, p in self.axes.items() if p.modulo]

    def check_machine(self, machine, controller: str) -> None:
        """Every profile axis exists on the machine; machine and controller names agree."""
        if self.machine and self.machine != machine.name:
            raise InputError(f"{self.where}: the profile is for machine '{self.machine}', the model for '{machine.name}'")
        if self.controller and self.controller != controller:
            raise InputError(f"{self.where}: the profile is for controller '{self.controller}', not '{controller}' "
                             "(`controller`)")
        for a in self.axes:
            if a not in machine.axis_names:
                raise InputError(f"{self.where}, field 'axes.{a}': machine {machine.name} has no axis '{a}' "
                                 f"(axes: {', '.join(machine.axis_names)})")
        for a, p in self.axes.items():
            if p.modulo and machine.axis(a).kind != "rotary":
                raise InputError(f"{self.where}, field 'axes.{a}.modulo': only rotary axes are modulo, {a} is linear")
            for drive, facts in ((f"axes.{a}", p), (f"axes.{a}.following", p.following)):
                if facts is not None and facts.reference_position is not None:
                    _check_reference(machine.axis(a), facts.reference_position, bool(p.modulo),
                                     f"{self.where}, field '{drive}.reference_position'")
        for a, p in self.axes.items():
            if (p.following or p.drive_separation_mm) and machine.axis(a).kind != "linear":
                raise InputError(f"{self.where}, field 'axes.{a}.following': twin drives belong to a linear (gantry) "
                                 f"axis, {a} is rotary")
            if p.drive_separation_mm and not p.following:
                raise InputError(f"{self.where}, field 'axes.{a}.drive_separation_mm': give the following drive "
                                 f"('following') of {a} too")
        self.check_unique()

    def check_unique(self) -> None:
        """No two drives (axes and following drives) share an nc_name, general_name, program_name
        or number; names compared without case (:data:`CASE_NOTE`: the controllers read them so)."""
        for key in UNIQUE_FIELDS + ("program_name",):
            seen: dict = {}
            for a, p in self.axes.items():
                for drive, facts in ((a, p), (f"{a} (following drive)", p.following)):
                    n = None if facts is None else getattr(facts, key)
                    if n is None:
                        continue
                    k = n.casefold() if isinstance(n, str) else n
                    if k in seen:
                        other, first = seen[k]
                        case = "" if first == n else f" and {first!r}, which differ only by case ({CASE_NOTE})"
                        which = f"'axes.{other.split(' ')[0]}.{key}' and 'axes.{a}.{key}'"
                        raise InputError(f"{self.where}, fields {which}: axes {other} and {drive} both have {key} "
                                         f"{n!r}{case}; each machine axis (and drive) needs its own")
                    seen[k] = (drive, n)

    def with_axis_map(self, axis_map: dict[str, str]) -> "ControllerProfile":
        """A copy with NC axis names from ``axis_map`` (they win over the file)."""
        if not axis_map:
            return self
        axes = dict(self.axes)
        for a, n in axis_map.items():
            if not PLAIN_NAME.fullmatch(n):
                raise InputError(f"`axis_map` {a}={n}: {_PLAIN}")
            axes[a] = dataclasses.replace(self.axis(a), nc_name=n)
        where = self.where if self.axes or self.limits else AXIS_MAP
        return dataclasses.replace(self, axes=axes, where=where)

    def axis_by_nc_name(self, name: str) -> str | None:
        """The vecpin axis whose nc_name or general_name is ``name``."""
        for a, p in self.axes.items():
            if name in (p.nc_name, p.general_name):
                return a
        return None

    def axis_by_number(self, number: int) -> str | None:
        for a, p in self.axes.items():
            if p.number == number:
                return a
        return None


def twin_axes(profile: "ControllerProfile") -> list[str]:
    """The axes the profile gives a following drive."""
    return [a for a, p in profile.axes.items() if p.following is not None]


def _drive_facts(facts: dict, where: str) -> dict:
    """``following`` (an axis' facts) and ``drive_separation_mm`` (3 numbers) of one axis."""
    out = {}
    if "following" in facts:
        f = facts["following"]
        if not isinstance(f, dict):
            raise InputError(f"{where}.following': an object of the following drive's facts (nc_name, number, ...)")
        vals = {}
        for key, value in f.items():
            if key not in AXIS_FIELDS or key == "modulo":
                raise InputError(f"{where}.following.{key}': unknown (known: "
                                 f"{', '.join(k for k in AXIS_FIELDS if k != 'modulo')})")
            vals[key] = _typed(value, AXIS_FIELDS[key], f"{where}.following.{key}'")
        out["following"] = AxisProfile(**vals)
    if "drive_separation_mm" in facts:
        v = facts["drive_separation_mm"]
        if (not isinstance(v, list) or len(v) != 3 or any(isinstance(x, bool) or not isinstance(x, (int, float))
                                                          or not math.isfinite(x) or abs(x) > 1e6 for x in v)):
            raise InputError(f"{where}.drive_separation_mm': [dx, dy, dz] in mm from the leading to the following "
                             f"drive, machine base frame: three finite numbers of at most 1e6 mm, not {v!r}")
        out["drive_separation_mm"] = tuple(float(x) for x in v)
    return out


def _axis_dict(p: AxisProfile) -> dict:
    out = {k: v for k, v in dataclasses.asdict(p).items() if v is not None and k not in DRIVE_FIELDS}
    if p.following is not None:
        out["following"] = _axis_dict(p.following)
    if p.drive_separation_mm is not None:
        out["drive_separation_mm"] = list(p.drive_separation_mm)
    return out


_PLAIN = ("not a plain name: NC axis names become file names and NC words, so they take letters, digits, '_' and "
          "'-' only (at most 64, starting with a letter, digit or '_')")


def _typed(value, kind, where: str):
    """``value`` as ``kind``; numbers finite (a reference position within +-1e6 mm, a
    detection unit > 0, a number 0..MAX_NUMBER), names plain (:data:`PLAIN_NAME`)."""
    key = where.rstrip("'").rsplit(".", 1)[-1]
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(f"{where}: a finite number, not {value!r}")
        if key == "detection_unit" and not 0 < value <= 1:
            raise InputError(f"{where}: the detection unit in mm or deg, > 0 and at most 1, not {value!r}")
        if abs(value) > 1e6:
            raise InputError(f"{where}: {value!r} is beyond any machine's travel (mm or deg)")
        return float(value)
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"{where}: a whole number, not {value!r}")
        if key == "number" and not 0 <= value <= MAX_NUMBER:
            raise InputError(f"{where}: an axis number 0..{MAX_NUMBER}, not {value!r}")
        return value
    if kind is bool:
        if not isinstance(value, bool):
            raise InputError(f"{where}: true or false, not {value!r}")
        return value
    if not isinstance(value, str) or not value.strip():
        raise InputError(f"{where}: a non-empty text, not {value!r}")
    if not PLAIN_NAME.fullmatch(value):
        raise InputError(f"{where}: {value!r} is {_PLAIN}")
    return value


def _check_reference(axis, value: float, modulo: bool, where: str) -> None:
    """A reference position inside the axis' travel (a modulo axis: or 0..360 deg)."""
    tol = 1e-6 * max(1.0, axis.upper_user - axis.lower_user)
    if axis.lower_user - tol <= value <= axis.upper_user + tol or (modulo and 0 <= value <= 360):
        if axis.kind == "linear" and 0 < abs(value) <= 1.0 and axis.lower_user <= value * 1000 <= axis.upper_user:
            import warnings

            from vecpin.errors import VecpinWarning
            warnings.warn(VecpinWarning(f"{where}: {value:g} mm, a reference point within 1 mm of {axis.name}'s zero, "
                                        f"where {value * 1000:g} mm would lie in its travel too: metres? Reference "
                                        "positions are mm (NC machine coordinates); the tables are written with "
                                        f"{value:g} mm"), stacklevel=2)
        return
    raise InputError(f"{where}: {value:g} {axis.unit} is outside the travel of {axis.name} "
                     f"({axis.lower_user:g} .. {axis.upper_user:g} {axis.unit}); give the NC machine coordinate of the "
                     "reference point")
