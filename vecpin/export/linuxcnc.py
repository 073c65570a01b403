"""LinuxCNC: pitch tables as ``[JOINT_n] COMP_FILE``, cross tables as a HAL component.

Every rule of the ``COMP_FILE`` below is read from the LinuxCNC source (github
LinuxCNC/linuxcnc @5c41560e) and checked on the real controller (tests/test_linuxcnc_real.py):

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
own position only: the cross tables go into the HAL component of
:mod:`vecpin.export.linuxcnc_hal` (``vecpin_vec.comp``), which adds them between motion
and the drives, so the joint gets vecpin's full table set. ``"limits":
{"max_cross_tables": 0}`` in the profile gives pitch tables only (no component). With
``COMP_FILE`` set, ``BACKLASH`` is not used (docs/src/config/ini-config.adoc:1109-1122).

Joints are numbered from 0 (``[JOINT_0]`` ...): a profile axis ``number`` is the joint
number; without numbers the joints follow the machine's axis order. ``"options":
{"ini": "machine.ini"}`` (relative to the profile) checks the numbers, the units and
the joint types against the machine's own INI file. The joint units are mm and degrees.
"""
from __future__ import annotations

import configparser
import re
from pathlib import Path

import numpy as np

from vecpin.compensation.limits import ControllerLimits
from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.errors import ControllerFileError, ControllerLimitError, InputError
from vecpin.export import linuxcnc_hal as hal
from vecpin.export.boundary import gauge_readme
from vecpin.export.common import ControllerFormat, ExportJob, equidistant, read_lines
from vecpin.export.profile import ControllerProfile
from vecpin.kinematics.machine import Machine

README = "README_LINUXCNC.md"
COMP_SIZE = 256     # EMCMOT_COMP_SIZE, src/emc/motion/motion.h:396
LINELEN = 255       # src/emc/linuxcnc.h:18; fgets reads at most LINELEN - 1 characters
MAX_JOINTS = 16     # EMCMOT_MAX_JOINTS, src/emc/motion/emcmotcfg.h

LIMITS = ControllerLimits(
    "linuxcnc", max_pitch_points=COMP_SIZE, max_cross_points=COMP_SIZE, products=True,
    source="LinuxCNC: COMP_FILE (one joint's own position, at most 256 entries, motion.h EMCMOT_COMP_SIZE) for "
           "pitch, vecpin's HAL component for cross tables and product terms (the same 256 points)")


def comp_file_name(axis: str) -> str:
    return f"comp_{axis}.txt"


def _file_type(profile: ControllerProfile) -> int:
    t = profile.option("comp_file_type", 0)
    if t not in (0, 1) or isinstance(t, bool):
        raise InputError(f"{profile.where}, options: 'comp_file_type' is 0 (actual positions) or 1 (trims), not {t!r}")
    return t


# ---------------------------------------------------------------------- joints
def joint_numbers(machine: Machine, profile: ControllerProfile) -> dict[str, int]:
    """LinuxCNC joint number (from 0) of every axis: the profile's ``number`` of every
    axis, or none given: the machine's axis order. Refused: some numbered and some not,
    a number twice, outside 0..15, or numbering that leaves joint 0 to no axis (counted
    from 1) unless the machine's INI (``options.ini``) confirms it."""
    given = {a: profile.axis(a).number for a in machine.axis_names if profile.axis(a).number is not None}
    if not given:
        return {a: k for k, a in enumerate(machine.axis_names)}
    where = f"{profile.where}, field 'axes.<axis>.number' (LinuxCNC joint)"
    missing = [a for a in machine.axis_names if a not in given]
    if missing:
        raise InputError(f"{where}: {', '.join(missing)} {'has' if len(missing) == 1 else 'have'} no joint number "
                         "while other axes have one: give every axis its joint number (from 0), or none (joints in "
                         f"the machine's axis order {', '.join(machine.axis_names)})")
    for a, n in given.items():
        if not 0 <= n < MAX_JOINTS:
            raise InputError(f"{where}: {a} has joint {n}; LinuxCNC joints are 0..{MAX_JOINTS - 1}")
    seen: dict[int, str] = {}
    for a, n in given.items():
        if n in seen:
            raise InputError(f"{where}: {seen[n]} and {a} are both joint {n}; each axis needs its own joint")
        seen[n] = a
    if 0 not in seen and _ini_path(profile) is None:
        first = min(seen)
        raise InputError(f"{where}: no axis is joint 0 ({seen[first]} is joint {first}): LinuxCNC counts joints "
                         "from 0 ([JOINT_0] is the first), so numbers counted from 1 put every table on the next "
                         "joint. Number the joints from 0, or give \"options\": {\"ini\": \"machine.ini\"} so vecpin "
                         "checks the numbers against the machine's INI file")
    return given


def _ini_path(profile: ControllerProfile) -> Path | None:
    ini = profile.option("ini", None)
    if ini is None:
        return None
    if not isinstance(ini, str) or not ini.strip():
        raise InputError(f"{profile.where}, options: 'ini' is the path of the machine's LinuxCNC INI file, not {ini!r}")
    path = Path(ini)
    if not path.is_absolute() and Path(profile.where).is_file():
        path = Path(profile.where).parent / path
    return path


def _read_ini(path: Path, where: str) -> configparser.ConfigParser:
    cp = configparser.ConfigParser(strict=False, interpolation=None, inline_comment_prefixes=("#",),
                                   comment_prefixes=("#", ";"))
    cp.optionxform = str
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
        cp.read_string(text, source=str(path))
    except OSError as exc:
        raise InputError(f"{where}, options 'ini': cannot read {path} ({exc.strerror})") from None
    except configparser.Error as exc:
        raise InputError(f"{where}, options 'ini': {path} is not an INI file ({exc.message.splitlines()[0]})") from None
    return cp


def ini_joints(profile: ControllerProfile) -> int | None:
    """[KINS] JOINTS of the profile's INI file (None: no INI given)."""
    path = _ini_path(profile)
    if path is None:
        return None
    return _joints_of(_read_ini(path, profile.where), path)


def _joints_of(cp: configparser.ConfigParser, path: Path) -> int:
    try:
        return int(cp.get("KINS", "JOINTS"))
    except (configparser.Error, ValueError):
        raise InputError(f"{path}: [KINS] JOINTS is missing or not a whole number") from None


def check_ini(machine: Machine, profile: ControllerProfile, joints: dict[str, int], kind: int) -> list[str]:
    """Refuse a joint numbering, unit or joint type that the machine's INI contradicts;
    notes for what the INI does not say. Nothing to check without ``options.ini``."""
    path = _ini_path(profile)
    if path is None:
        return ["joint numbers not checked against the machine's INI (give \"options\": {\"ini\": FILE} in the "
                "profile)"]
    cp, notes = _read_ini(path, profile.where), []
    n = _joints_of(cp, path)
    for a, j in joints.items():
        if j >= n:
            raise InputError(f"{path}: [KINS] JOINTS = {n}, but the profile puts {a} on joint {j}")
    units = {"LINEAR_UNITS": ("mm", "metric", "millimeter", "millimeters"),
             "ANGULAR_UNITS": ("deg", "degree", "degrees")}
    for key, ok in units.items():
        value = cp.get("TRAJ", key, fallback=None)
        if value is not None and value.strip().lower() not in ok:
            raise InputError(f"{path}: [TRAJ] {key} = {value.strip()}; vecpin's files are in mm and degrees")
    coords = _coordinates(cp.get("KINS", "KINEMATICS", fallback=""))
    for a, j in joints.items():
        facts = profile.axis(a)
        ax, letter = machine.axis(a), _letter(a, facts.nc_name, facts.program_name)
        jtype = cp.get(f"JOINT_{j}", "TYPE", fallback=None)
        want = "LINEAR" if ax.kind == "linear" else "ANGULAR"
        if jtype is not None and jtype.strip().upper() != want:
            raise InputError(f"{path}: [JOINT_{j}] TYPE = {jtype.strip()}, but the profile puts {a} ({ax.kind}) there")
        if coords is not None and j < len(coords) and letter and coords[j] != letter:
            raise InputError(f"{path}: trivkins coordinates={coords} make joint {j} axis {coords[j]}, but the "
                             f"profile puts {a} (axis letter {letter}) on joint {j}")
        ftype = cp.get(f"JOINT_{j}", "COMP_FILE_TYPE", fallback=None)
        if ftype is not None and ftype.strip() != str(kind):
            notes.append(f"{path}: [JOINT_{j}] COMP_FILE_TYPE = {ftype.strip()}; these files are type {kind}: set "
                         f"COMP_FILE_TYPE = {kind}")
    notes.append(f"joint numbers checked against {path.name}")
    return notes


def _letter(axis: str, nc_name: str | None, program_name: str | None) -> str | None:
    """The axis letter (X, Y, Z, A, B, C, U, V, W) of an axis: its NC name, its address in
    part programs (a vendor's joint name such as 'X_axis' has its letter there) or its own
    name, the first of them that is a letter (None: none is)."""
    for name in (nc_name, program_name, axis):
        if name and len(name) == 1 and name.upper() in "XYZABCUVW":
            return name.upper()
    return None


def _coordinates(kinematics: str) -> str | None:
    """The joint letters of a trivkins line (``trivkins coordinates=XYZAC``; the default
    XYZABCUVW), None for other kinematics (their joints are the module's)."""
    parts = kinematics.split()
    if not parts or parts[0] != "trivkins":
        return None
    for p in parts[1:]:
        m = re.fullmatch(r"coordinates=([A-Za-z]+)", p)
        if m:
            return m.group(1).upper()
    return "XYZABCUVW"


def check(machine: Machine, profile: ControllerProfile, limits: ControllerLimits, modulo_axes=()) -> None:
    kind = _file_type(profile)
    if modulo_axes:
        raise InputError(f"linuxcnc: {', '.join(modulo_axes)} would get modulo tables, but a COMP_FILE has no modulo "
                         "(the trim is looked up at the raw joint position): leave out `modulo_axes` and \"modulo\": true")
    check_ini(machine, profile, joint_numbers(machine, profile), kind)


def write(job: ExportJob) -> list[str]:
    """``comp_<AXIS>.txt`` per joint (pitch), ``vecpin_vec.comp`` + ``vecpin_vec.hal``
    (cross tables, when there are any) and ``README_LINUXCNC.md``."""
    m, kind = job.machine, _file_type(job.profile)
    job.limits.check_tables(job.tables)
    joints = joint_numbers(m, job.profile)
    job.notes += [n for n in check_ini(m, job.profile, joints, kind) if not n.startswith("joint numbers checked")]
    names = []
    for t in job.tables.tables:
        a = m.axis(t.input_axis)
        if t.modulo:
            raise ControllerLimitError(f"linuxcnc: the table of {a.name} is modulo, but a COMP_FILE has no modulo "
                                       "(looked up at the raw joint position): make the tables without `modulo_axes`")
        if not t.is_pitch:
            continue
        nominal, trim = a.to_user(t.positions), a.to_user(t.values)
        cols = (trim, trim) if kind == 1 else (nominal - trim, nominal - trim)
        lines = [f"{x:.6f} {f:.6f} {r:.6f}" for x, f, r in zip(nominal, *cols)]
        what = "trims (added to the command)" if kind == 1 else "actual positions reached (trim = nominal - actual)"
        lines.append(f"# vecpin {m.name} joint {joints[a.name]} ({a.name}), COMP_FILE_TYPE = {kind}: nominal, "
                     f"forward and reverse {what}, {a.unit}; the loader stops at the first line that is not 3 "
                     "numbers, so this comment stays last")
        name = comp_file_name(a.name)
        job.out.write_text(name, "\n".join(lines) + "\n")
        names.append(name)
    n_joints = ini_joints(job.profile) or max(joints.values()) + 1
    cross = any(not t.is_pitch for t in job.tables.tables) or bool(job.tables.products)
    for p in job.tables.products:
        if p.table.modulo or p.factor.modulo:
            raise ControllerLimitError(f"linuxcnc: product term {p.name} is modulo, but the component reads its tables "
                                       "at the raw joint position: make the tables without `modulo_axes`")
    if cross:
        job.out.write_text(hal.COMP_FILE, hal.component_source(m, job.tables, joints, n_joints))
        job.out.write_text(hal.HAL_FILE, "\n".join(_hal_header(m) + hal.hal_lines(joints, n_joints)) + "\n")
        names += [hal.COMP_FILE, hal.HAL_FILE]
    job.out.write_text(README, _readme(job, kind, joints, cross))
    return names + [README]


def _hal_header(m: Machine) -> list[str]:
    return [f"# vecpin volumetric compensation of {m.name}: cross tables between motion and the drives.",
            f"# Build once as root: halcompile --install {hal.COMP_FILE}",
            "# Add this file after the machine's HAL files (HALFILE = ...). Take joint.N.motor-pos-cmd and",
            "# joint.N.motor-pos-fb off the drive nets of the machine's HAL files: the drive gets",
            f"# {hal.HAL_NAME}.0.motor-pos-cmd-out-N, its feedback goes to {hal.HAL_NAME}.0.motor-pos-fb-N",
            "# (the commented lines below)."]


def _readme(job: ExportJob, kind: int, joints: dict[str, int], cross: bool) -> str:
    m = job.machine
    s = [f"# Compensation for {m.name} (LinuxCNC)", "",
         "Pitch tables: `COMP_FILE` per joint (LinuxCNC corrects a joint from its own commanded position)."]
    s += (["Cross tables (a joint corrected from another joint's position: straightness, squareness, rotary-axis",
           f"errors): the HAL component `{hal.COMP_FILE}`, which adds them between motion and the drives; the joint",
           "gets both, vecpin's full table set."] if cross else
          ["No cross tables in this set (pitch only): the straightness, squareness and rotary-axis errors stay."])
    if job.tables.products:
        s += ["", f"Product terms {' '.join(p.name for p in job.tables.products)} (a tilt fixed to the turning table): "
              "the component adds, per term, its table over the rotary joint times its factor (a fixed ramp, a plain "
              f"number) over the linear joint to the output joint (`{hal.COMP_FILE}`'s header says how it holds them)."]
    s += ["", "Add to the machine's INI file, per joint (joints count from 0):", "", "```ini"]
    for t in job.tables.tables:
        if t.is_pitch:
            s += [f"[JOINT_{joints[t.input_axis]}]", f"COMP_FILE = {comp_file_name(t.input_axis)}",
                  f"COMP_FILE_TYPE = {kind}", ""]
    if cross:
        s += ["[HAL]", f"HALFILE = {hal.HAL_FILE}    # after the machine's own HAL files", ""]
    s += ["```", "", "Joints: " + ", ".join(f"{a} = joint {n}" for a, n in joints.items()) + ".", ""]
    if cross:
        s += ["## The HAL component", "",
              f"1. Build and install it once, as root: `halcompile --install {hal.COMP_FILE}` (package",
              "   `linuxcnc-uspace-dev`). The tables are compiled in: new tables, new build.",
              "2. In the machine's HAL files, take `joint.N.motor-pos-cmd` and `joint.N.motor-pos-fb` off the drive",
              f"   nets; `{hal.HAL_FILE}` connects them to the component. Connect the component to the drives:",
              f"   `{hal.HAL_NAME}.0.motor-pos-cmd-out-N` is the drive's command (e.g. `pid.N.command`, a stepgen's",
              f"   `position-cmd`), the drive's feedback goes to `{hal.HAL_NAME}.0.motor-pos-fb-N` (the commented",
              f"   lines of `{hal.HAL_FILE}`; on a simulated machine the one drives the other).",
              f"3. The component has two functions. `{hal.HAL_NAME}.0.command` runs after `motion-controller` (last",
              f"   in the thread). `{hal.HAL_NAME}.0.feedback` must run after the function that reads the drives'",
              "   feedback (a Mesa card's `read`, a stepgen's `capture-position`) and before `motion-command-handler`:",
              f"   `{hal.HAL_FILE}` puts it first in the servo thread (position 1), right where no function reads the",
              "   feedback; otherwise change the 1 to the position after that function (`halcmd show thread",
              "   servo-thread` lists them), or motion gets the feedback one servo period late (0.5 mm more following",
              "   error at 500 mm/s and 1 ms).",
              "4. The correction applies once every joint is homed (`motion.is-all-homed`) and fades in at",
              f"   `max-slew` = {hal.DEFAULT_SLEW:g} mm/s (or deg/s); `{hal.HAL_NAME}.0.correction-N` shows it. Motion sees",
              "   the position it commanded: following error and DRO are as without compensation.",
              "",
              "Tested on LinuxCNC 2.9 (Debian `linuxcnc-uspace`, POSIX non-realtime) with trivkins, by vecpin's tests",
              "(tests/test_linuxcnc_real.py): the corrections the controller applies equal vecpin's tables to 1e-6,",
              "and, with the sample configurations' following-error limits, motion's following error stays 0 (a",
              "simulated drive that follows exactly), at rest and while moving.", ""]
    s += ["## Notes", "",
          "- Type 0 (the INI default) lists the actual position reached at each nominal; type 1 the trims added to",
          "  the command (`\"options\": {\"comp_file_type\": 1}` in the profile). Both hold the same correction.",
          "- Units: mm and degrees; the joints' machine units must be the same (`LINEAR_UNITS = mm`).",
          "- With `COMP_FILE` set, `BACKLASH` is not used; forward and reverse columns are equal here.",
          "- Below the first and above the last nominal the end values hold. At most 256 lines per joint.",
          "- The tables act on joints (machine axes), so they serve trivkins and the 5-axis kinematics modules alike.",
          "", "## Gauge line", "", *gauge_readme("linuxcnc", job.tables.gauge_offset_change, job.gauge_effect), ""]
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
    """Every ``comp_<AXIS>.txt`` in ``folder`` as a pitch table (type from the profile,
    default 0), and the cross tables of ``vecpin_vec.comp`` when it is there."""
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
    products = []
    if (folder / hal.COMP_FILE).exists():
        joints = joint_numbers(machine, profile)
        products = hal.read_products(folder / hal.COMP_FILE, machine, joints)
        tables += hal.read_component(folder / hal.COMP_FILE, machine, joints, empty_ok=bool(products))
    if not tables:
        raise ControllerFileError(folder, f"no comp_<AXIS>.txt file for the axes {', '.join(machine.axis_names)}")
    return TableSet(machine.axis_names, tables, 0.0, products=products)


FORMAT = ControllerFormat(
    "linuxcnc", "LinuxCNC", LIMITS, write, read, check,
    files="`comp_<AXIS>.txt` per joint (`[JOINT_n] COMP_FILE`, pitch), `vecpin_vec.comp` + `vecpin_vec.hal` (HAL "
          "component for the cross tables, `halcompile --install`), `README_LINUXCNC.md` (INI and HAL lines)",
    sign="type 1: trim added to the motor command = correction; type 0: actual position = nominal - correction; "
         "HAL component: correction added to motor-pos-cmd (CERTAIN: LinuxCNC source, and the real controller in the "
         "tests)",
    source="LinuxCNC source @5c41560e: usrmotintf.cc:634-680, command.c:1956-1989, control.c:1705-1726, motion.h:396, "
           "docs ini-config.adoc:1109-1145; LinuxCNC 2.9 run in tests/test_linuxcnc_real.py",
    to_check="COMP_FILE_TYPE in the INI matches the file, joint units mm/deg, joints numbered from 0 (options.ini "
             "checks them), the component's drive nets",
    dialect="linuxcnc")
