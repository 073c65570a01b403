"""LinuxCNC ``[JOINT_n] COMP_FILE``: screw (pitch) compensation per joint. Pitch only.

Every rule below is read from the LinuxCNC source (github LinuxCNC/linuxcnc @5c41560e):

* one line per entry, ``nominal forward reverse``, whitespace separated, read with
  ``fgets`` (255 characters) and ``sscanf("%lf %lf %lf")``; the loader **stops at the
  first line that does not start with three numbers** without an error, so a comment
  may only come last (src/emc/motion/usrmotintf.cc:634-680);
* ``COMP_FILE_TYPE = 0`` (the INI default): columns are the actual positions reached
  when the joint is commanded to ``nominal`` moving forward / in reverse; the stored
  trims are ``nominal - actual``. ``COMP_FILE_TYPE = 1``: columns are the trims
  themselves (usrmotintf.cc:662-674, src/emc/ini/inijoint.cc:182-184);
* nominals strictly increasing ("compensation values must increase"), at most
  ``EMCMOT_COMP_SIZE`` = 256 entries per joint (src/emc/motion/command.c:1956-1989,
  motion.h:396); below the first and above the last entry the end trims hold
  (motion.c:938-952);
* the trim is added to the motor command: ``motor_pos_cmd = pos_cmd + trim``
  (control.c:1705-1726, 2046-2047), looked up at the commanded joint position, the
  forward trim when moving forward and the reverse one when moving back.

So a trim is vecpin's table value (the correction) and a type-0 "actual" column is
``nominal - correction`` (= nominal + error). A COMP_FILE compensates a joint from its
own position only: cross tables cannot be written (the controller's limits say
``cross_tables=False``, so only pitch tables are chosen). With ``COMP_FILE`` set,
``BACKLASH`` is not used (docs/src/config/ini-config.adoc:1109-1122). The joint's
units are its machine units: the files are in mm and degrees, so the joint must be too.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from vecpin.compensation.limits import ControllerLimits
from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.errors import ControllerFileError, ControllerLimitError, InputError
from vecpin.export.common import ControllerFormat, ExportJob, equidistant, read_lines
from vecpin.export.profile import ControllerProfile
from vecpin.kinematics.machine import Machine
from vecpin.units import MM_PER_M

README = "README_LINUXCNC.md"
COMP_SIZE = 256     # EMCMOT_COMP_SIZE, src/emc/motion/motion.h:396
LINELEN = 255       # src/emc/linuxcnc.h:18; fgets reads at most LINELEN - 1 characters

LIMITS = ControllerLimits(
    "linuxcnc", cross_tables=False, max_pitch_points=COMP_SIZE,
    source="LinuxCNC COMP_FILE: one joint's own position, at most 256 entries (motion.h EMCMOT_COMP_SIZE)")


def comp_file_name(axis: str) -> str:
    return f"comp_{axis}.txt"


def _file_type(profile: ControllerProfile) -> int:
    t = profile.option("comp_file_type", 0)
    if t not in (0, 1) or isinstance(t, bool):
        raise InputError(f"{profile.where}, options: 'comp_file_type' is 0 (actual positions) or 1 (trims), not {t!r}")
    return t


def check(machine: Machine, profile: ControllerProfile, limits: ControllerLimits, modulo_axes=()) -> None:
    _file_type(profile)
    if modulo_axes:
        raise InputError(f"linuxcnc: {', '.join(modulo_axes)} would get modulo tables, but a COMP_FILE has no modulo "
                         "(the trim is looked up at the raw joint position): leave out --modulo and \"modulo\": true")


def write(job: ExportJob) -> list[str]:
    """``comp_<AXIS>.txt`` per joint and ``README_LINUXCNC.md``."""
    m, kind = job.machine, _file_type(job.profile)
    job.limits.check_tables(job.tables)
    names = []
    for t in job.tables.tables:
        a = m.axis(t.input_axis)
        if t.modulo:
            raise ControllerLimitError(f"linuxcnc: the table of {a.name} is modulo, but a COMP_FILE has no modulo "
                                       "(looked up at the raw joint position): make the tables without --modulo")
        nominal, trim = a.to_user(t.positions), a.to_user(t.values)
        cols = (trim, trim) if kind == 1 else (nominal - trim, nominal - trim)
        lines = [f"{x:.6f} {f:.6f} {r:.6f}" for x, f, r in zip(nominal, *cols)]
        what = "trims (added to the command)" if kind == 1 else "actual positions reached (trim = nominal - actual)"
        lines.append(f"# vecpin {m.name} joint {a.name}, COMP_FILE_TYPE = {kind}: nominal, forward and reverse "
                     f"{what}, {a.unit}; the loader stops at the first line that is not 3 numbers, so this "
                     "comment stays last")
        name = comp_file_name(a.name)
        job.out.write_text(name, "\n".join(lines) + "\n")
        names.append(name)
    job.out.write_text(README, _readme(job, kind))
    return names + [README]


def _readme(job: ExportJob, kind: int) -> str:
    m = job.machine
    s = [f"# Compensation for {m.name} (LinuxCNC)", "",
         "Pitch (screw) compensation only: a LinuxCNC `COMP_FILE` corrects a joint from its own commanded position,",
         "so cross tables (straightness, squareness, rotary-axis errors) cannot be loaded this way.", "",
         "Add to the machine's INI file, per joint:", "", "```ini"]
    for t in job.tables.tables:
        n = job.profile.axis(t.input_axis).number
        s += [f"[JOINT_{n}]" if n is not None else f"# the [JOINT_n] section of axis {t.input_axis}",
              f"COMP_FILE = {comp_file_name(t.input_axis)}", f"COMP_FILE_TYPE = {kind}", ""]
    s += ["```", "",
          "- Type 0 (the INI default) lists the actual position reached at each nominal; type 1 the trims added to",
          "  the command (`\"options\": {\"comp_file_type\": 1}` in the profile). Both hold the same correction.",
          "- Units: mm and degrees; the joints' machine units must be the same (`LINEAR_UNITS = mm`).",
          "- With `COMP_FILE` set, `BACKLASH` is not used; forward and reverse columns are equal here.",
          "- Below the first and above the last nominal the end values hold. At most 256 lines per joint.",
          "- Joint = axis on trivial kinematics; on other kinematics the file belongs to the joint.",
          f"- Gauge line: change the tool length offset by {job.tables.gauge_offset_change * MM_PER_M:+.4f} mm.", ""]
    return "\n".join(s)


# ---------------------------------------------------------------------- reader
def read_comp_file(path: Path, kind: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(nominal, forward trim, reverse trim) as LinuxCNC loads them. Raises where
    LinuxCNC would silently drop data (numbers after the line where it stops), and
    where it would refuse an entry (not increasing, more than 256)."""
    path = Path(path)
    lines = read_lines(path, "latin-1")
    rows, stop = [], None
    for no, raw in enumerate(lines, 1):
        if len(raw) >= LINELEN - 1:
            raise ControllerFileError(path, f"line longer than {LINELEN - 2} characters: LinuxCNC reads it as two", no)
        parts = raw.split()
        try:
            nums = [float(p) for p in parts[:3]] if len(parts) >= 3 else None
        except ValueError:
            nums = None
        if nums is None or not np.all(np.isfinite(nums)):
            if stop is None:
                stop = no
            continue
        if stop is not None:
            raise ControllerFileError(path, f"LinuxCNC stops reading at line {stop} (not three numbers), so this entry "
                                      "and those after it would be ignored", no)
        if rows and nums[0] <= rows[-1][1][0]:
            raise ControllerFileError(path, f"nominal {nums[0]:g} does not increase (LinuxCNC: 'compensation values "
                                      "must increase')", no)
        rows.append((no, nums))
    if not rows:
        raise ControllerFileError(path, "no entry: the first line is not three numbers", 1)
    if len(rows) > COMP_SIZE:
        raise ControllerFileError(path, f"{len(rows)} entries, LinuxCNC holds {COMP_SIZE} per joint",
                                  rows[COMP_SIZE][0])
    a = np.array([r[1] for r in rows])
    nominal = a[:, 0]
    if kind == 0:
        return nominal, nominal - a[:, 1], nominal - a[:, 2]
    return nominal, a[:, 1], a[:, 2]


def read(folder: Path, machine: Machine, profile: ControllerProfile) -> TableSet:
    """Every ``comp_<AXIS>.txt`` in ``folder`` as a pitch table (type from the profile, default 0)."""
    folder, kind = Path(folder), _file_type(profile)
    tables = []
    for a in machine.axes:
        path = folder / comp_file_name(a.name)
        if not path.exists():
            continue
        nominal, fwd, rev = read_comp_file(path, kind)
        if np.abs(fwd - rev).max() > 5e-7:
            k = int(np.argmax(np.abs(fwd - rev)))
            raise ControllerFileError(path, f"forward and reverse trims differ at nominal {nominal[k]:g}: vecpin tables "
                                      "do not depend on the direction", k + 1)
        start, step = equidistant(path, nominal, 1, "nominal positions")
        tables.append(CompensationTable(a.name, a.name, float(a.to_si(start)), float(a.to_si(step)), a.to_si(fwd)))
    if not tables:
        raise ControllerFileError(folder, f"no comp_<AXIS>.txt file for the axes {', '.join(machine.axis_names)}")
    return TableSet(machine.axis_names, tables, 0.0)


FORMAT = ControllerFormat(
    "linuxcnc", "LinuxCNC", LIMITS, write, read, check,
    files="`comp_<AXIS>.txt` per joint (`[JOINT_n] COMP_FILE`), `README_LINUXCNC.md` (INI lines)",
    sign="type 1: trim added to the motor command = correction; type 0: actual position = nominal - correction "
         "(CERTAIN, source code)",
    source="LinuxCNC source @5c41560e: usrmotintf.cc:634-680, command.c:1956-1989, control.c:1705-1726, motion.h:396, "
           "docs ini-config.adoc:1109-1145",
    to_check="COMP_FILE_TYPE in the INI matches the file, joint units mm/deg, the joint = axis mapping",
    dialect="linuxcnc")
