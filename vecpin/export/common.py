"""What every controller format shares: the format description, the export job,
number formatting and line-numbered reading.

A :class:`ControllerFormat` is data plus two functions: ``write(job)`` puts the
controller's files into the job's :class:`~vecpin.fileio.OutputSet` and returns
their names; ``read(folder, machine, profile)`` parses them back into a
:class:`~vecpin.compensation.tables.TableSet` in vecpin's convention (SI; a table
value is the increment added to the command of the output axis, i.e. the
correction, minus the error). Readers raise
:class:`~vecpin.errors.ControllerFileError` naming file and line.
"""
from __future__ import annotations

import dataclasses
import functools
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from vecpin.compensation.limits import ControllerLimits
from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.errors import ControllerFileError, InputError
from vecpin.export.profile import ControllerProfile
from vecpin.fileio import OutputSet
from vecpin.kinematics.machine import Machine


@dataclass
class ExportJob:
    """One export: the tables (SI, vecpin convention), the machine, its controller
    profile and limits, the model (for formats that export its error functions), the
    output set, the table points, ``notes`` for the user (removed constants,
    warnings), which the command prints, and ``constants``: per axis, the correction
    [m or rad] a pitch table could not carry (zero at the reference point), which the
    user may set as a reference-point shift."""

    tables: TableSet
    machine: Machine
    profile: ControllerProfile
    limits: ControllerLimits
    out: OutputSet
    model: object | None = None
    points: int = 1024
    notes: list[str] = field(default_factory=list)
    constants: dict[str, float] = field(default_factory=dict)
    commands: "UserCommands" = field(default_factory=lambda: UserCommands())
    gauge_effect: dict | None = None   # model-predicted error with the gauge-line change entered / not / flipped


@dataclass(frozen=True)
class UserCommands:
    """How the files' READMEs tell the user to ask vecpin for a sign test (``sign_test``)
    and to judge its readings (``sign_check``, with ``{tag}`` for the table's tag): the
    caller's own words, so a README names the command-line commands when the command
    line wrote it and the Python calls (the default) when a script did."""

    sign_test: str = "`make_tables(model, out_dir, controller, sign_test=\"AXIS\")`"
    sign_check: str = "`check_sign(\"SIGNTEST_{tag}.json\", \"SIGNTEST_{tag}.csv\", machine)`"
    pitch_only: str = "`make_tables(model, out_dir, controller, max_tables=0)`"   # pitch tables fitted alone


def constant_note(axis, value_user: float, file: str, datum: str, datum_file: str) -> str:
    """The note for a constant a pitch table cannot carry, written as a reference-point datum."""
    return (f"{axis.name}: the correction at the reference point ({value_user:+.4f} {axis.unit}) is not in {file} (the "
            f"table is zero there): it is the new reference point value {datum} in {datum_file}; without it "
            f"{axis.name} keeps this error everywhere")


def modulo_warnings(job: "ExportJob") -> None:
    """A note for every rotary axis that travels a turn or more with tables over its whole
    travel and no word on whether the NC treats it as modulo (then its tables must be)."""
    for a in job.machine.axes:
        if a.kind != "rotary" or a.upper_user - a.lower_user < 360.0 - 1e-6:
            continue
        if job.profile.axis(a.name).modulo is None and not any(t.modulo for t in job.tables.tables
                                                               if t.input_axis == a.name):
            job.notes.append(f"warning: {a.name} travels {a.upper_user - a.lower_user:g} deg and its tables cover the "
                             f"whole travel; if the NC treats {a.name} as a modulo axis, its tables must be modulo "
                             f"(0..360): set \"modulo\": true for {a.name} in the profile (or `modulo_axes` {a.name})")


def new_reference_position(reference_user: float, correction_user: float) -> float:
    """The reference point's machine coordinate [mm or deg] that adds ``correction`` to
    every command of the axis.

    A controller sets the axis' machine coordinate to the reference point value when it
    references; commanding ``q`` then moves the axis ``q - value`` from the reference
    point. Lowering the value by ``c`` moves it ``c`` further at every command: the
    constant ``c`` of the axis' correction table, which a table zero at the reference
    point cannot carry (Siemens MD34100 REFP_SET_POS, Fanuc parameter 1240: both "the
    machine coordinate of the reference point")."""
    return float(reference_user) - float(correction_user)


def with_constants(tables: TableSet, constants: dict[str, float]) -> TableSet:
    """``tables`` with each axis' constant [SI] added to its pitch table (a reference
    point datum read back from the files)."""
    out = [CompensationTable(t.input_axis, t.output_axis, t.start, t.step,
                             t.values + (constants.get(t.input_axis, 0.0) if t.is_pitch else 0.0), t.modulo)
           for t in tables.tables]
    return TableSet(list(tables.axis_names), out, tables.gauge_offset_change, tables.source, list(tables.drives),
                    list(tables.products))


@dataclass(frozen=True)
class ControllerFormat:
    """A controller's table format.

    ``limits``: defaults (a profile may override them); ``check``: raises before any
    heavy work when the profile lacks a fact the writer needs (given the modulo axes); ``files``, ``sign``,
    ``source``, ``to_check``: the controller table of docs/compensation.md; ``dialect``: the NC
    language of the sign-test program; ``main_files``: file names ``read`` needs."""

    name: str
    title: str
    limits: ControllerLimits
    write: Callable[[ExportJob], list[str]]
    read: Callable[[Path, Machine, ControllerProfile], TableSet] | None
    check: Callable[[Machine, ControllerProfile, ControllerLimits, list], None]
    files: str
    sign: str
    source: str
    to_check: str
    dialect: str = "din"
    needs_model: bool = False
    extra_limits: dict = field(default_factory=dict)

    def extra_limit(self, profile: ControllerProfile, name: str):
        """A format-specific limit: the profile's value or the format's default."""
        value = profile.limit(name, self.extra_limits[name])
        if isinstance(value, bool) or not isinstance(value, (int, float)) or value <= 0:
            raise InputError(f"{profile.where}, limits: '{name}' must be a number > 0, not {value!r}")
        return value

    def limits_for(self, profile: ControllerProfile) -> ControllerLimits:
        """The limits with the profile's overrides (``"limits": {...}``); names that are
        neither table limits nor this format's own (``extra_limits``) are errors."""
        unknown = sorted(k for k in profile.limits if k not in _TABLE_LIMITS and k not in self.extra_limits)
        if unknown:
            raise InputError(f"{profile.where}, limits: '{unknown[0]}' is not a limit of {self.name} (known: "
                             f"{', '.join(sorted(_TABLE_LIMITS | set(self.extra_limits)))})")
        values = {k: v for k, v in profile.limits.items() if k in _TABLE_LIMITS}
        limits = self.limits.overridden(values, f"{profile.where}, limits") if values else self.limits
        if limits.resampled and self.read is not None:   # the subset search judges its best sets as written
            limits = dataclasses.replace(limits, hold=functools.partial(held_as_written, self, profile, limits))
        return limits


_TABLE_LIMITS = {"max_cross_tables", "max_cross_points", "max_pitch_points", "no_circular", "forbid_output"}


def held_as_written(fmt: ControllerFormat, profile: ControllerProfile, limits: ControllerLimits, tables: TableSet,
                    machine: Machine) -> TableSet:
    """``tables`` as ``fmt``'s controller will hold them: its files written into a
    temporary folder and read back with its reader (the controller's grid and value
    resolution, the constants its reference point data carry), the gauge-line change
    kept. A set the format cannot write raises as the writer does."""
    with tempfile.TemporaryDirectory(prefix="vecpin-held-") as tmp:
        with OutputSet(tmp) as out:
            fmt.write(ExportJob(tables, machine, profile, limits, out))
        back = fmt.read(Path(tmp), machine, profile)
    back.gauge_offset_change = tables.gauge_offset_change
    return back


def no_check(machine: Machine, profile: ControllerProfile, limits: ControllerLimits, modulo_axes=()) -> None:
    """For formats that need no machine-side fact."""


# ---------------------------------------------------------------------- numbers
def decimal(v: float, decimals: int = 6) -> str:
    """Shortest decimal with a point, at most ``decimals`` places: 0.003, -200.0, 0.0."""
    s = f"{float(v):.{decimals}f}".rstrip("0")
    if s.endswith("."):
        s += "0"
    if s in ("-0.0", ""):
        s = "0.0"
    return s


def signed(v: float, decimals: int = 4) -> str:
    """Fixed decimals with an explicit sign: +0.0120, -200.0000 (zero: +0.0000)."""
    s = f"{float(v):+.{decimals}f}"
    return "+" + s[1:] if s.startswith("-") and float(s) == 0 else s


def to_float(text: str, path, line: int, what: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise ControllerFileError(path, f"{what} '{text}' is not a number", line) from None
    if not np.isfinite(v):
        raise ControllerFileError(path, f"{what} '{text}' is not a finite number", line)
    return v


def to_int(text: str, path, line: int, what: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise ControllerFileError(path, f"{what} '{text}' is not a whole number", line) from None


def read_lines(path: Path, encoding: str = "utf-8") -> list[str]:
    """The file's lines (no line ends); a missing or undecodable file is a ControllerFileError."""
    path = Path(path)
    if not path.is_file():
        raise ControllerFileError(path, "no such file")
    try:
        return path.read_text(encoding=encoding).splitlines()
    except UnicodeDecodeError as exc:
        raise ControllerFileError(path, f"not a text file ({exc.reason} at byte {exc.start})") from None


def equidistant(path, positions: np.ndarray, line: int | None, what: str = "positions",
                tol: float | None = None) -> tuple[float, float]:
    """(start, step) of equally spaced ascending positions (within ``tol``, default a
    millionth of the step); otherwise a ControllerFileError."""
    positions = np.asarray(positions, float)
    if len(positions) < 2:
        raise ControllerFileError(path, f"a table needs at least 2 {what}", line)
    d = np.diff(positions)
    if np.any(d <= 0):
        k = int(np.argmax(d <= 0))
        raise ControllerFileError(path, f"{what} must increase: {positions[k + 1]:g} follows {positions[k]:g}", line)
    step = (positions[-1] - positions[0]) / (len(positions) - 1)
    tol = 1e-6 * max(abs(step), 1.0) if tol is None else tol
    if np.abs(positions - (positions[0] + step * np.arange(len(positions)))).max() > tol:
        raise ControllerFileError(path, f"{what} are not equally spaced (vecpin tables are; steps {d.min():g} .. "
                                  f"{d.max():g})", line)
    return float(positions[0]), float(step)
