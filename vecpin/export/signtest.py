"""The sign test: one check on the machine that tells whether a controller applies a
table with the sign vecpin wrote it with.

A table changes the position of its output axis by its correction ``t(p)`` at input
position ``p``. Move the input axis to two positions p1, p2 where the correction
differs most, read the output axis (an indicator or the tracker, along +output)
first with the table off, then with it on. The machine's own error is the same both
times and cancels:

    observed = [r_on(p2) - r_on(p1)] - [r_off(p2) - r_off(p1)]  =  t(p2) - t(p1)

when the controller applies the file as vecpin assumes, ``-(t(p2) - t(p1))`` when it
applies it with the opposite sign, about 0 when the table is not active, and a
multiple of it when a unit or magnification is wrong. The prediction comes from the
files as written (read back), so rounding and resampling are in it.

Files: an NC program in the controller's language (two stops, each position approached
from below), ``SIGNTEST_<T>.md`` (what to do), ``SIGNTEST_<T>.json`` (the prediction,
read by :func:`vecpin.workflows.tables.check_sign`) and ``SIGNTEST_<T>.csv`` (the form to fill in:
``compensation,command,reading``).
"""
from __future__ import annotations

import csv
import io
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vecpin.compensation.tables import CompensationTable, TableSet, table_name
from vecpin.errors import CampaignFileError, InputError
from vecpin.export.common import UserCommands, decimal
from vecpin.export.profile import ControllerProfile, load_option_json
from vecpin.fileio import OutputSet
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import read_text_file
from vecpin.planning import ncdialect as nc

FORMAT = "vecpin-sign-test"
VERSION = 1
APPROACH = {"mm": 5.0, "deg": 2.0}     # approach distance before each stop
FEED = 1000.0                           # mm/min or deg/min
WEAK = {"mm": 0.002, "deg": 0.0005}    # a smaller predicted shift is hard to see
PROGRAM_NAME = 24                       # characters of a Siemens program name (Programming Manual, Fundamentals 2.2.1);
                                        # Heidenhain shows 24-25 of a file name, Fanuc takes 32


def sign_tag(table: str) -> str:
    """The ``<T>`` of ``SIGNTEST_<T>``, the sign test's program and files: the table name
    (:func:`~vecpin.compensation.tables.table_name`) in capitals, '-' as '_' (a Siemens
    program name takes letters, digits and '_'), cut so that ``SIGNTEST_<T>`` keeps
    within :data:`PROGRAM_NAME` characters; the program's comment names the whole table."""
    return table.upper().replace("-", "_")[:PROGRAM_NAME - len("SIGNTEST_")].rstrip("_")


def find_table(tables: TableSet, machine: Machine, which: str) -> CompensationTable:
    """The table a ``sign_test`` value names: an axis (its pitch table) or a table
    name (output then input axis, e.g. 'yx')."""
    names = {a.lower(): a for a in machine.axis_names}
    key = which.strip().lower()
    if key in names:
        key = table_name(names[key], names[key])
    for t in tables.tables:
        if t.name == key:
            return t
    raise InputError(f"`sign_test` {which}: no such table in this set (an axis, e.g. X, for its pitch table, or a "
                     f"table: {', '.join(tables.names())})")


@dataclass
class SignTest:
    """The planned check (user units: mm or deg)."""

    controller: str
    machine: str
    table: str
    input_axis: str
    output_axis: str
    input_unit: str
    output_unit: str
    positions: tuple[float, float]
    corrections: tuple[float, float]
    files: list[str]
    sign_rule: str

    @property
    def predicted(self) -> float:
        return self.corrections[1] - self.corrections[0]

    def to_dict(self) -> dict:
        return {"format": FORMAT, "version": VERSION, "controller": self.controller, "machine": self.machine,
                "table": self.table, "input_axis": self.input_axis, "output_axis": self.output_axis,
                "input_unit": self.input_unit, "output_unit": self.output_unit,
                "positions": list(self.positions), "corrections": list(self.corrections),
                "predicted_shift": self.predicted, "files": self.files, "sign_rule": self.sign_rule,
                "meaning": "corrections: the amounts the controller should add to the output axis at the two input "
                           "positions (vecpin's convention); predicted_shift = the change of (reading at p2 - reading "
                           "at p1) when the table is switched on"}

    @classmethod
    def load(cls, path: str | Path) -> "SignTest":
        d = load_option_json(path, "test_path")
        if not isinstance(d, dict) or d.get("format") != FORMAT or d.get("version") != VERSION:
            raise InputError(f"`test_path` {path}: not a vecpin sign-test file (a SIGNTEST_<T>.json written with the tables)")
        try:
            return cls(d["controller"], d["machine"], d["table"], d["input_axis"], d["output_axis"], d["input_unit"],
                       d["output_unit"], tuple(float(x) for x in d["positions"]),
                       tuple(float(x) for x in d["corrections"]), list(d["files"]), d["sign_rule"])
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"`test_path` {path}: damaged sign-test file ({type(exc).__name__}: {exc})") from None


def plan_sign_test(table: CompensationTable, machine: Machine, controller: str, files: list[str],
                   sign_rule: str) -> SignTest:
    """Two input positions inside the travel (room to approach from below) where the
    table's correction differs most."""
    ai, ao = machine.axis(table.input_axis), machine.axis(table.output_axis)
    lo, hi = ai.lower_user, ai.upper_user
    margin = 0.02 * (hi - lo)
    lo_ok, hi_ok = lo + APPROACH[ai.unit] + margin, hi - margin
    if hi_ok <= lo_ok:
        raise InputError(f"`sign_test`: {ai.name} travels too little ({hi - lo:g} {ai.unit}) for the test")
    x = np.linspace(lo_ok, hi_ok, 2001)
    t = ao.to_user(table(ai.to_si(x)))
    i, j = int(np.argmin(t)), int(np.argmax(t))
    p1, p2 = sorted((round(float(x[i]), 3), round(float(x[j]), 3)))
    c = ao.to_user(table(ai.to_si(np.array([p1, p2]))))
    return SignTest(controller, machine.name, table.name, ai.name, ao.name, ai.unit, ao.unit, (p1, p2),
                    (float(c[0]), float(c[1])), files, sign_rule)


# ---------------------------------------------------------------------- programs
def _moves(st: SignTest) -> list[tuple[float, float]]:
    a = APPROACH[st.input_unit]
    return [(p - a, p) for p in st.positions]


# the sign test's controllers -> the NC program dialects of vecpin.planning.ncdialect
_NC = {"siemens": nc.SIEMENS, "fanuc": nc.FANUC, "linuxcnc": nc.GCODE}
_DIN = (["G71", "G17 G40 G90", "D0"], ["M30"],  # Beckhoff TwinCAT CNC (DIN 66025): G71 mm, D0 no tool offset
        "the program sets G71 (mm) G17 G40 G90 D0 and G53 (no zero offset, modal): check the units and the zero "
        "offset the next program needs")


def program(st: SignTest, dialect: str, address: str,
            retract: tuple[str, float] | None = None) -> tuple[str, str]:
    """(file name, text) of the NC program in the controller's language: units and a
    safety block first, every position in machine coordinates, each approached from
    below at the feed, a programmed stop at each reading, then what the program changed
    restored or named (see :mod:`vecpin.planning.ncdialect`). It moves the axis under
    test alone, after ``retract`` (address, safe machine position [mm]) has lifted the
    tool: a rotary axis tilts only with the tool lifted."""
    tag = sign_tag(st.table)
    moves = _moves(st)
    what = f"vecpin sign test of table {st.table}: read {st.output_axis} at each stop"
    lift = (f"{retract[0]} to {decimal(retract[1], 3)} mm first (machine coordinate, the tool lifted before "
            f"{st.input_axis} turns), then {st.input_axis} alone moves" if retract else f"{st.input_axis} alone moves")
    if dialect == "heidenhain":
        name = f"SIGNTEST_{tag}.H"
        lines = [f"BEGIN PGM SIGNTEST_{tag} MM", f"; {what}", f"; {lift}", "L M129"]
        if retract:
            lines.append(f"L {retract[0]}{retract[1]:+.3f} R0 FMAX M91")
        f = decimal(FEED, 1)
        for k, (a, p) in enumerate(moves, 1):
            lines += [f"L {address}{a:+.3f} R0 F{f} M91", f"L {address}{p:+.3f} R0 F{f} M91",
                      f"; reading {k}: {st.input_axis} at {decimal(p, 3)} {st.input_unit}", "STOP"]
        lines.append(f"END PGM SIGNTEST_{tag} MM")
        return name, "\n".join(f"{n} {ln}" for n, ln in enumerate(lines)) + "\n"
    d = _NC.get(dialect, nc.GCODE)  # DIN 66025 (Beckhoff) writes comments and G53 blocks as LinuxCNC
    name = {"siemens": f"SIGNTEST_{tag}.MPF", "linuxcnc": f"signtest_{tag.lower()}.ngc"}.get(dialect,
                                                                                          f"SIGNTEST_{tag}.NC")
    din = dialect not in _NC
    start, end, note = (_DIN if din else (nc.prologue(d), nc.epilogue(d), nc.restore_note(d)))
    mc = {"siemens": "SUPA", "fanuc": "G53: at rapid traverse to the first position, then G91 G01 at the feed"}
    head = [what, f"machine coordinates ({mc.get(dialect, 'G53')}), each position approached from below at "
            f"F{FEED:g}; {lift}", note]
    lines = [c for h in head for c in nc.comments(d, h)]
    blocks = list(start) + ([nc.rapid(d, [retract[0]], [retract[1]])] if retract else [])
    cur = None
    for k, (a, p) in enumerate(moves, 1):
        for x in (a, p):
            if d == nc.FANUC and cur is None:  # Fanuc's G53 always moves at rapid traverse
                blocks.append(nc.rapid(d, [address], [x]))
            else:
                blocks += nc.approach(d, [address], [x if cur is None else cur], [x], FEED)
            cur = x
        blocks.append(nc.stop(d, f"reading {k}: {st.input_axis} at {decimal(p, 3)} {st.input_unit}"))
    if din:
        blocks = [b.replace("G90 G53 G1", "G90 G53 G01") for b in blocks]
    blocks += end
    lines += [f"N{10 * (i + 1)} {b}" for i, b in enumerate(blocks)]
    if d == nc.FANUC:
        lines = ["%", "O9001"] + lines + ["%"]
    return name, "\n".join(lines) + "\n"


#: what an axis address is in each dialect's programs: (pattern, in words)
ADDRESSES = {"siemens": (r"[A-Z][A-Z0-9]{0,7}", "a capital letter (not F, G, M, N, O, P, S, T) with up to 7 more "
                                               "capitals or digits"),
             "din": (r"[A-Z][A-Z0-9]{0,7}", "capitals and digits, a capital first")}
LETTERS = (r"[XYZABCUVW]", "one of X Y Z A B C U V W")


def addresses(profile: ControllerProfile, axis_names: list[str]) -> dict[str, str]:
    """Each axis' address in the sign-test programs: the profile's ``program_name``, else
    the axis name."""
    return {a: profile.axis(a).program_name or a for a in axis_names}


def check_address(address: str, dialect: str, axis: str, where: str, others: dict[str, str] | None = None) -> None:
    """Refuse a program address the control would not read as an axis (a vendor joint
    name such as 'X_axis' taken as the address), or one that is another axis' address
    (``others``: axis -> address; issue 42: a sign test of X addressed as Z would move Z):
    ``where`` names the profile in the message."""
    taken = [o for o, adr in (others or {}).items() if o != axis and adr == address]
    if taken:
        raise InputError(f"{where}, field 'axes.{axis}.program_name': the sign-test program would address {axis} as "
                         f"'{address}', which is the address of axis {taken[0]}: the test would move {taken[0]}, not "
                         f"{axis}; give the address of {axis} in your part programs")
    pattern, words = ADDRESSES.get(dialect, LETTERS)
    if re.fullmatch(pattern, address) is None or (dialect == "siemens" and address[0] in "FGMNOPST"):
        raise InputError(f"{where}, field 'axes.{axis}.program_name': the sign-test program would address {axis} as "
                         f"'{address}', which is no {dialect} axis address ({words}); give the address your part "
                         f"programs use, e.g. \"program_name\": \"{axis[0].upper()}\"")


def sign_retract(machine: Machine, st: SignTest, profile: ControllerProfile, dialect: str) -> tuple[str, float] | None:
    """(address, safe machine position [mm]) of the retract axis that lifts the tool before
    a rotary axis under test turns (the end of its travel away from the work); None for a
    linear axis under test or a machine without one."""
    from vecpin.planning.ncprogram import retract_axis, safe_position
    if machine.axis(st.input_axis).kind != "rotary":
        return None
    try:
        r, up = retract_axis(machine)
    except InputError:
        return None
    name = machine.axes[r].name
    address = addresses(profile, machine.axis_names)[name]
    check_address(address, dialect, name, profile.where, addresses(profile, machine.axis_names))
    return address, safe_position(machine, r, up, None)


def write_sign_test(out: OutputSet, st: SignTest, dialect: str, profile: ControllerProfile, notes: list[str],
                    commands: UserCommands = UserCommands(), machine: Machine | None = None) -> list[str]:
    """The program, instructions, prediction and CSV form of one sign test; ``commands``: how the
    instructions name the check (the caller's words); ``machine``: its axes (another axis'
    address is refused) and the retract axis lifted before a rotary axis turns
    (:func:`sign_retract`). An address the dialect does not read as an axis is refused
    (:func:`check_address`)."""
    p = profile.axis(st.input_axis)
    address = p.program_name or st.input_axis
    check_address(address, dialect, st.input_axis, profile.where,
                  addresses(profile, machine.axis_names) if machine is not None else None)
    retract = sign_retract(machine, st, profile, dialect) if machine is not None else None
    prog_name, prog = program(st, dialect, address, retract)
    tag = sign_tag(st.table)
    out.write_text(prog_name, prog)
    out.write_text(f"SIGNTEST_{tag}.json", json.dumps(st.to_dict(), indent=1) + "\n")
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["compensation", "command", "reading"])
    for state in ("off", "on"):
        for x in st.positions:
            w.writerow([state, decimal(x, 3), ""])
    out.write_text(f"SIGNTEST_{tag}.csv", buf.getvalue())
    weak = abs(st.predicted) < WEAK[st.output_unit]
    s = [f"# Sign test of table {st.table} ({st.controller})", "",
         f"Checks that the controller applies `{'`, `'.join(st.files)}` with the sign vecpin wrote "
         f"({st.sign_rule}).", "",
         f"1. Mount an indicator (or use the tracker) reading the **{st.output_axis}** position, positive when "
         f"{st.output_axis} moves in its + direction. Any zero.",
         f"2. With the compensation **off**, run `{prog_name}` (moves {st.input_axis} alone to "
         f"{decimal(st.positions[0], 3)} and {decimal(st.positions[1], 3)} {st.input_unit}, each approached from below"
         + (f", after lifting {retract[0]} to {decimal(retract[1], 3)} mm" if retract else
            "; the other axes stay where they stand: start with the tool clear of the work")
         + "). At each stop write a row "
         f"`off,<command>,<reading>` into `SIGNTEST_{tag}.csv` ({st.output_unit}). Repeat runs add rows.",
         "3. Load the files and switch the compensation **on** (reference the axis again where the control needs it).",
         f"   Other tables may stay active: only a table from {st.input_axis} to {st.output_axis} changes these "
         "readings. Run the program again and write rows `on,<command>,<reading>`.",
         f"4. {commands.sign_check.format(tag=tag)} says whether the sign is right.",
         "",
         f"Prediction: switching the table on changes (reading at {decimal(st.positions[1], 3)}) - (reading at "
         f"{decimal(st.positions[0], 3)}) by **{st.predicted:+.4f} {st.output_unit}** (corrections {st.corrections[0]:+.4f} and "
         f"{st.corrections[1]:+.4f}). The opposite sign gives {-st.predicted:+.4f}; about 0 means the table is not "
         "active; a multiple means a wrong unit or magnification.", ""]
    if address == st.input_axis and p.program_name is None:
        s.append(f"The program addresses the axis as `{address}` (vecpin's name): check it is the axis' address in "
                 "your part programs (profile field `program_name`).")
    if dialect in ("din", "linuxcnc", "fanuc"):
        s.append("Check that `G53` (machine coordinates) behaves on your control as the program assumes"
                 + (": on Fanuc it moves at rapid traverse, so the first move to the first position is a rapid one."
                    if dialect == "fanuc" else "."))
    if weak:
        s.append(f"Warning: the predicted shift is small ({st.predicted:+.4f} {st.output_unit}); use a resolution of "
                 "a tenth of it or better, and several runs.")
        notes.append(f"sign test {st.table}: the predicted shift is only {st.predicted:+.4f} {st.output_unit}")
    out.write_text(f"SIGNTEST_{tag}.md", "\n".join(s) + "\n")
    return [prog_name, f"SIGNTEST_{tag}.md", f"SIGNTEST_{tag}.json", f"SIGNTEST_{tag}.csv"]


# ---------------------------------------------------------------------- evaluation
@dataclass
class SignVerdict:
    """Outcome of a sign test: observed and predicted shift [output unit], their ratio,
    the 1-sigma of the observation from repeated readings (nan without repeats) and the
    verdict: 'right', 'reversed' or 'unclear'."""

    test: SignTest
    observed: float
    sigma: float
    verdict: str
    reason: str

    @property
    def ratio(self) -> float:
        return self.observed / self.test.predicted if self.test.predicted else math.nan

    def lines(self) -> list[str]:
        u = self.test.output_unit
        sig = f" +- {self.sigma:.4f}" if np.isfinite(self.sigma) else " (no repeated readings: scatter unknown)"
        return [f"sign test of table {self.test.table} ({self.test.controller}):",
                f"  predicted shift {self.test.predicted:+.4f} {u}, observed {self.observed:+.4f}{sig} {u}, "
                f"ratio {self.ratio:+.2f}",
                f"  sign {self.verdict.upper()}: {self.reason}"]


def read_check(path: str | Path, st: SignTest) -> dict[tuple[str, int], list[float]]:
    """Readings per (state, position index) from a sign-test CSV."""
    path = Path(path)
    text = read_text_file(path, encoding="utf-8")
    rows = [r for r in csv.reader(io.StringIO(text))]
    body = [(no, r) for no, r in enumerate(rows, 1) if r and any(c.strip() for c in r)
            and not r[0].lstrip().startswith("#")]
    if not body or [c.strip() for c in body[0][1]] != ["compensation", "command", "reading"]:
        raise CampaignFileError(path, "the header must be compensation,command,reading", body[0][0] if body else 1)
    out: dict[tuple[str, int], list[float]] = {}
    for no, r in body[1:]:
        if len(r) != 3:
            raise CampaignFileError(path, f"{len(r)} fields, expected 3", no)
        state = r[0].strip().lower()
        if state not in ("off", "on"):
            raise CampaignFileError(path, f"'{r[0]}' is neither off nor on", no, "compensation")
        try:
            cmd = float(r[1])
        except ValueError:
            raise CampaignFileError(path, f"'{r[1]}' is not a number", no, "command") from None
        if not r[2].strip():
            continue  # a row of the form not filled in
        try:
            reading = float(r[2])
        except ValueError:
            raise CampaignFileError(path, f"'{r[2]}' is not a number", no, "reading") from None
        hits = [k for k, p in enumerate(st.positions) if abs(cmd - p) <= 1e-3]
        if not hits:
            raise CampaignFileError(path, f"command {cmd:g} is neither test position "
                                    f"({decimal(st.positions[0], 3)}, {decimal(st.positions[1], 3)} {st.input_unit})", no, "command")
        out.setdefault((state, hits[0]), []).append(reading)
    for state in ("off", "on"):
        for k, p in enumerate(st.positions):
            if (state, k) not in out:
                raise CampaignFileError(path, f"no reading with compensation {state} at {decimal(p, 3)} {st.input_unit}")
    return out


def evaluate_sign_test(st: SignTest, readings: dict[tuple[str, int], list[float]]) -> SignVerdict:
    """Judge the sign from the readings (see the module docstring)."""
    mean = {k: float(np.mean(v)) for k, v in readings.items()}
    observed = (mean[("on", 1)] - mean[("on", 0)]) - (mean[("off", 1)] - mean[("off", 0)])
    dev = [x - mean[k] for k, v in readings.items() for x in v]
    dof = sum(len(v) - 1 for v in readings.values())
    sigma = math.nan
    if dof > 0:
        s2 = float(np.sum(np.square(dev))) / dof
        sigma = math.sqrt(s2 * sum(1.0 / len(v) for v in readings.values()))
    pred = st.predicted
    u = st.output_unit
    noise = 3 * sigma if np.isfinite(sigma) else 0.0
    if abs(pred) <= noise:
        return SignVerdict(st, observed, sigma, "unclear", f"the readings scatter too much (3 sigma {noise:.4f} {u}) "
                           f"for a predicted shift of {pred:+.4f} {u}: more runs or a finer indicator")
    tol = max(0.3 * abs(pred), noise)
    d_right, d_rev = abs(observed - pred), abs(observed + pred)
    if d_right <= tol and d_right < d_rev:
        return SignVerdict(st, observed, sigma, "right", "the controller applies the table as written")
    if d_rev <= tol and d_rev < d_right:
        return SignVerdict(st, observed, sigma, "reversed", "the controller applies the table with the opposite "
                           "sign: negate the values (and report it: vecpin's sign convention for this controller is "
                           "wrong)")
    ratio = observed / pred
    if abs(ratio) < 0.3:
        why = "the shift is much smaller than predicted: is the table active (enabled, axis referenced)?"
    elif abs(ratio) > 1.3:
        why = f"the shift is {ratio:+.1f} x the prediction: check units, magnification and detection unit"
    else:
        why = f"the shift is {ratio:+.2f} x the prediction: neither the sign nor its opposite within 30%"
    return SignVerdict(st, observed, sigma, "unclear", why)
