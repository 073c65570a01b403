"""LinuxCNC volumetric compensation: the cross tables in a HAL component (``vecpin_vec.comp``).

A LinuxCNC ``COMP_FILE`` corrects a joint from its own commanded position only
(:mod:`vecpin.export.linuxcnc`), so the cross tables (straightness, squareness, the
errors of the rotary axes: a joint corrected from *another* joint's position) need
LinuxCNC's extension mechanism. vecpin writes them as a realtime HAL component for
``halcompile`` with the tables compiled in (C arrays: no file is opened in the servo
thread, so it also runs where realtime code cannot read files). It sits between motion
and the drives, per joint ``n``, with two functions in the servo thread:

* ``command``, after ``motion-controller``:
  ``motor-pos-cmd-out-n = joint.n.motor-pos-cmd + c_n`` (to the drive), with
  ``c_n = sum_i t_ni(joint.i.pos-cmd)``: each cross table read at the commanded joint
  position of its input (vecpin's eq. 15-16: tables at the programmed command), linear
  interpolation, end values held beyond the ends (as ``COMP_FILE`` and vecpin do);
* ``feedback``, after the function that reads the drives' feedback and before
  ``motion-command-handler``: ``motor-pos-fb-out-n = motor-pos-fb-n - c_n`` (to
  ``joint.n.motor-pos-fb``), ``c_n`` the correction of the command the drive last got,
  so motion sees the position it commanded: following error and DRO as without it.
  Run after motion instead, it would hand motion the feedback one servo period late:
  ``velocity * period`` more following error (0.5 mm at 500 mm/s and 1 ms). Never run,
  it leaves the feedback at 0: a following error on the first move.

Product terms (:mod:`vecpin.compensation.products`, a tilt fixed to a turning table): each
adds ``table(joint r) * factor(joint l)`` to joint ``o``'s ``c_o``; ``table`` a table over
the rotary joint ``r`` in ``o``'s units, ``factor`` a plain number over the linear joint
``l`` (a fixed ramp), both read like the cross tables. This is vecpin's own definition
(the component is vecpin's), checked on the real controller (tests/test_linuxcnc_real.py).
In the source: per term a comment ``/* product NAME: joint o (O) += table over joint r (R)
times factor over joint l (L) */``, then the table's and the factor's arrays
``vecpin_pt<k>`` and ``vecpin_pf<k>``, each after a comment ``/* product table|factor
NAME: joint .. from joint .., start S, step H, N points */``; the entries of
``vecpin_ptables`` and ``vecpin_pfactors`` (``{out, in, n, start, step, values}``) pair
them by index.

The pitch tables stay in the joints' ``COMP_FILE`` (added by motion to
``motor-pos-cmd``): the joint gets pitch plus cross, vecpin's full table set.
The correction only applies while ``enable`` is true (wire ``motion.is-all-homed``):
when it switches, ``c`` moves to its new value at ``max-slew`` units/s, then follows
the tables exactly (it is continuous in the commands). Why a HAL component and not a
kinematics module: vecpin's tables live in joint space (machine axis commands), where
the component acts; it works with trivkins and with every 5-axis kinematics module,
whose joints are the machine axes, and leaves the kinematics (tool-centre point) alone.

Joint positions are in the joints' machine units: mm and degrees (the INI's
``LINEAR_UNITS = mm``, ``ANGULAR_UNITS = degree``).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from vecpin.compensation.tables import CompensationTable, ProductTable, TableSet
from vecpin.errors import ControllerFileError
from vecpin.export.common import read_lines
from vecpin.kinematics.machine import Machine

COMPONENT = "vecpin_vec"
COMP_FILE = COMPONENT + ".comp"
HAL_FILE = COMPONENT + ".hal"
HAL_NAME = COMPONENT.replace("_", "-")        # halcompile turns '_' into '-' in HAL names
DEFAULT_SLEW = 1.0                            # units/s while the correction switches on or off

_PRODUCT = re.compile(r"^/\* product (?P<kind>table|factor) (?P<name>[\w*-]+): joint (?P<out>\d+) \((?P<oname>[^)]*)\) "
                      r"from joint (?P<inp>\d+) \((?P<iname>[^)]*)\), start (?P<start>\S+), step (?P<step>\S+), "
                      r"(?P<n>\d+) points \*/$")
_TABLE = re.compile(r"^/\* table (?P<name>[\w-]+): joint (?P<out>\d+) \((?P<oname>[^)]*)\) from joint (?P<inp>\d+) "
                    r"\((?P<iname>[^)]*)\), start (?P<start>\S+), step (?P<step>\S+), (?P<n>\d+) points \*/$")


def _number(v: float) -> str:
    """A C double literal that reads back to the same float (17 significant digits)."""
    s = repr(float(v))
    return s if ("." in s or "e" in s or "inf" in s or "nan" in s) else s + ".0"


def component_source(machine: Machine, tables: TableSet, joints: dict[str, int], n_joints: int) -> str:
    """The ``halcompile`` source of the component for the cross tables and product terms of
    ``tables`` (SI, vecpin convention), written in joint units (mm, deg); ``joints``: LinuxCNC
    joint number of every axis; ``n_joints``: the component's pin count (``[KINS] JOINTS``)."""
    cross = [t for t in tables.tables if not t.is_pitch]
    lines = [f'component {COMPONENT} "vecpin volumetric compensation of {machine.name}: cross tables between '
             'motion and the drives";',
             f'pin in float pos_cmd_#[{n_joints}] "joint.N.pos-cmd: commanded joint position (the tables\' input)";',
             f'pin in float motor_pos_cmd_#[{n_joints}] "joint.N.motor-pos-cmd (pitch COMP_FILE already added)";',
             f'pin out float motor_pos_cmd_out_#[{n_joints}] "to the drive: motor-pos-cmd + correction";',
             f'pin in float motor_pos_fb_#[{n_joints}] "the drive\'s position feedback";',
             f'pin out float motor_pos_fb_out_#[{n_joints}] "to joint.N.motor-pos-fb: feedback - correction";',
             f'pin out float correction_#[{n_joints}] "the correction applied [mm or deg]";',
             'pin in bit enable = 1 "apply the tables (wire motion.is-all-homed)";',
             f'param rw float max_slew = {DEFAULT_SLEW} "units/s while the correction switches on or off";',
             f'variable double applied[{n_joints}];',
             'variable int ramping = 1;',
             'variable int was_enabled = 0;',
             'function feedback fp "after the drives\' feedback is read, before motion-command-handler";',
             'function command fp "after motion-controller";',
             'license "GPL";',
             'author "vecpin";',
             ';;',
             "/* written by vecpin: one table per cross correction, values in the output joint's units at",
             "   start + k * step of the input joint; linear interpolation, end values held beyond the ends */",
             "typedef struct { int out, in, n; double start, step; const double *v; } vecpin_table;"]
    for k, t in enumerate(cross):
        ai, ao = machine.axis(t.input_axis), machine.axis(t.output_axis)
        start, step = float(ai.to_user(t.start)), float(ai.to_user(t.step))
        values = ao.to_user(t.values)
        lines.append(f"/* table {t.name}: joint {joints[t.output_axis]} ({ao.name}) from joint "
                     f"{joints[t.input_axis]} ({ai.name}), start {_number(start)}, step {_number(step)}, "
                     f"{len(values)} points */")
        body = ", ".join(_number(v) for v in values)
        lines.append(f"static const double vecpin_v{k}[{len(values)}] = {{{body}}};")
    entries = [f"{{{joints[t.output_axis]}, {joints[t.input_axis]}, {len(t.values)}, "
               f"{_number(machine.axis(t.input_axis).to_user(t.start))}, "
               f"{_number(machine.axis(t.input_axis).to_user(t.step))}, vecpin_v{k}}}" for k, t in enumerate(cross)]
    lines.append(f"#define VECPIN_N_TABLES {len(cross)}")
    lines.append("static const vecpin_table vecpin_tables[VECPIN_N_TABLES + 1] = {"
                 + ", ".join(entries + ["{0, 0, 0, 0.0, 0.0, 0}"]) + "};")
    lines += _product_source(machine, tables.products, joints)
    lines += [_FUNCTION.replace("N_JOINTS", str(n_joints)), ""]
    return "\n".join(lines)


def _entry(machine: Machine, t: CompensationTable, out: int, joints: dict[str, int], array: str) -> str:
    ai = machine.axis(t.input_axis)
    return (f"{{{out}, {joints[t.input_axis]}, {len(t.values)}, {_number(ai.to_user(t.start))}, "
            f"{_number(ai.to_user(t.step))}, {array}}}")


def _product_source(machine: Machine, products: list[ProductTable], joints: dict[str, int]) -> list[str]:
    """The C arrays of the product terms (module docstring): per term its table over the rotary
    joint (output joint's units) and its factor over the linear joint (a plain number)."""
    lines, tabs, facs = [], [], []
    for k, p in enumerate(products):
        t, f = p.table, p.factor
        ao, ar, al = machine.axis(t.output_axis), machine.axis(t.input_axis), machine.axis(f.input_axis)
        o = joints[ao.name]
        lines.append(f"/* product {p.name}: joint {o} ({ao.name}) += table over joint {joints[ar.name]} ({ar.name}) "
                     f"times factor over joint {joints[al.name]} ({al.name}) */")
        for kind, tab, values, arr in (("table", t, ao.to_user(t.values), f"vecpin_pt{k}"),
                                       ("factor", f, np.asarray(f.values, float), f"vecpin_pf{k}")):
            ai = machine.axis(tab.input_axis)
            lines.append(f"/* product {kind} {p.name}: joint {o} ({ao.name}) from joint {joints[ai.name]} "
                         f"({ai.name}), start {_number(ai.to_user(tab.start))}, step {_number(ai.to_user(tab.step))}, "
                         f"{len(values)} points */")
            lines.append(f"static const double {arr}[{len(values)}] = {{{', '.join(_number(v) for v in values)}}};")
        tabs.append(_entry(machine, t, o, joints, f"vecpin_pt{k}"))
        facs.append(_entry(machine, f, o, joints, f"vecpin_pf{k}"))
    end = ["{0, 0, 0, 0.0, 0.0, 0}"]
    return lines + [f"#define VECPIN_N_PRODUCTS {len(products)}",
                    "static const vecpin_table vecpin_ptables[VECPIN_N_PRODUCTS + 1] = {" + ", ".join(tabs + end)
                    + "};",
                    "static const vecpin_table vecpin_pfactors[VECPIN_N_PRODUCTS + 1] = {" + ", ".join(facs + end)
                    + "};"]


_FUNCTION = r"""
static double vecpin_lookup(const vecpin_table *t, double x) {
    double u = (x - t->start) / t->step;
    int k;
    if (!(u > 0.0)) return t->v[0];
    if (u >= t->n - 1) return t->v[t->n - 1];
    k = (int)u;
    return t->v[k] + (u - k) * (t->v[k + 1] - t->v[k]);
}

/* before motion: the drive's feedback less the correction of the command it last got */
FUNCTION(feedback) {
    int j;
    for (j = 0; j < N_JOINTS; j++) {
        motor_pos_fb_out(j) = motor_pos_fb(j) - applied[j];
    }
}

/* after motion: the correction at the new command, added to it on the way to the drive */
FUNCTION(command) {
    double target[N_JOINTS];
    double dmax = max_slew * fperiod;
    int j, k, done = 1;
    if (enable != was_enabled) ramping = 1;
    was_enabled = enable;
    for (j = 0; j < N_JOINTS; j++) target[j] = 0.0;
    if (enable)
        for (k = 0; k < VECPIN_N_TABLES; k++)
            target[vecpin_tables[k].out] += vecpin_lookup(&vecpin_tables[k], pos_cmd(vecpin_tables[k].in));
    if (enable)
        for (k = 0; k < VECPIN_N_PRODUCTS; k++) {  /* product terms: table(joint r) * factor(joint l) */
            const vecpin_table *t = &vecpin_ptables[k], *f = &vecpin_pfactors[k];
            target[t->out] += vecpin_lookup(t, pos_cmd(t->in)) * vecpin_lookup(f, pos_cmd(f->in));
        }
    for (j = 0; j < N_JOINTS; j++) {
        double d = target[j] - applied[j];
        if (ramping && d > dmax) { applied[j] += dmax; done = 0; }
        else if (ramping && d < -dmax) { applied[j] -= dmax; done = 0; }
        else applied[j] = target[j];
        correction(j) = applied[j];
        motor_pos_cmd_out(j) = motor_pos_cmd(j) + applied[j];
    }
    if (done) ramping = 0;
}"""


def hal_lines(joints: dict[str, int], n_joints: int, drive_cmd: dict[int, str] | None = None,
              drive_fb: dict[int, str] | None = None) -> list[str]:
    """HAL commands that load the component, add its two functions to the servo thread
    and wire its motion side; the drive side (``motor-pos-cmd-out-N`` -> drive command,
    drive feedback -> ``motor-pos-fb-N``) is given by ``drive_cmd`` / ``drive_fb`` pins
    per joint, or left as comments. ``feedback`` goes first in the thread (position 1):
    right where no function reads the drives' feedback; where one does (a Mesa card's
    ``read``, a stepgen's ``capture-position``), its position must be the one after it."""
    out = [f"loadrt {COMPONENT}",
           "# feedback: after the function that reads the drives' feedback, before motion-command-handler. Position 1",
           "# is the first in the thread: where a function reads the feedback (hm2 ...read, stepgen.capture-position),",
           "# give the position after it (halcmd show thread servo-thread lists them), or motion gets the feedback",
           "# one servo period late (more following error at speed).",
           f"addf {HAL_NAME}.0.feedback servo-thread 1",
           f"addf {HAL_NAME}.0.command servo-thread",
           f"net vecpin-all-homed motion.is-all-homed => {HAL_NAME}.0.enable"]
    for n in range(n_joints):
        p = f"{HAL_NAME}.0"
        out += [f"net vecpin-j{n}-pos-cmd joint.{n}.pos-cmd => {p}.pos-cmd-{n}",
                f"net vecpin-j{n}-motor-cmd joint.{n}.motor-pos-cmd => {p}.motor-pos-cmd-{n}",
                f"net vecpin-j{n}-motor-fb {p}.motor-pos-fb-out-{n} => joint.{n}.motor-pos-fb"]
        if drive_cmd and n in drive_cmd:
            out.append(f"net vecpin-j{n}-drive-cmd {p}.motor-pos-cmd-out-{n} => {drive_cmd[n]}")
        else:
            out.append(f"# net vecpin-j{n}-drive-cmd {p}.motor-pos-cmd-out-{n} => <joint {n}'s drive command pin>")
        if drive_fb and n in drive_fb:
            out.append(f"net vecpin-j{n}-drive-fb {drive_fb[n]} => {p}.motor-pos-fb-{n}")
        else:
            out.append(f"# net vecpin-j{n}-drive-fb <joint {n}'s drive feedback pin> => {p}.motor-pos-fb-{n}")
    return out


def read_component(path: Path, machine: Machine, joints: dict[str, int],
                   empty_ok: bool = False) -> list[CompensationTable]:
    """The cross tables of a ``vecpin_vec.comp`` (SI), from its table comments and arrays;
    raises where the comment and the array disagree or a joint is not the profile's, and
    where it has no table (``empty_ok``: it has product terms, :func:`read_products`)."""
    path = Path(path)
    by_joint = {n: a for a, n in joints.items()}
    tables = []
    for no, m, arr in _commented_arrays(path, _TABLE, r"vecpin_v\d+"):
        if arr is None:
            raise ControllerFileError(path, "a table comment without its array on the next line", no)
        values = np.array([float(v) for v in arr.group(2).split(",")])
        n = int(m.group("n"))
        if len(values) != n or int(arr.group(1)) != n:
            raise ControllerFileError(path, f"table {m.group('name')}: {len(values)} values, the comment says {n}",
                                      no + 1)
        _check_joints(path, m, by_joint, no)
        tables.append(_commented_table(machine, m, values, si=True))
    if not tables and not empty_ok:
        raise ControllerFileError(path, "no table in the component")
    return tables


def _commented_arrays(path: Path, comment: re.Pattern, array: str):
    """(line number, the comment's match, the next line's array match or None) for each line of the
    component matching ``comment``; ``array``: the pattern of the array's name (its length and values
    are the match's groups 1 and 2)."""
    lines = read_lines(path, "utf-8")
    pattern = re.compile(r"^static const double " + array + r"\[(\d+)\] = \{(.*)\};$")
    for no, ln in enumerate(lines, 1):
        m = comment.match(ln.strip())
        if m:
            yield no, m, pattern.match((lines[no] if no < len(lines) else "").strip())


def _commented_table(machine: Machine, m: re.Match, values: np.ndarray, si: bool) -> CompensationTable:
    """The table a comment (``iname``, ``oname``, ``start``, ``step`` in user units) and its array's
    ``values`` describe; the values in the output axis' user units turned to SI where ``si``."""
    ai, ao = machine.axis(m.group("iname")), machine.axis(m.group("oname"))
    return CompensationTable(ai.name, ao.name, float(ai.to_si(float(m.group("start")))),
                             float(ai.to_si(float(m.group("step")))), ao.to_si(values) if si else values)


def _check_joints(path: Path, m: re.Match, by_joint: dict[int, str], no: int) -> None:
    """A table or product comment's output and input joints (``out``/``oname``, ``inp``/``iname``) are
    the profile's (``by_joint``: joint number -> axis), else :class:`ControllerFileError` at line ``no``."""
    for j, name in ((int(m.group("out")), m.group("oname")), (int(m.group("inp")), m.group("iname"))):
        if by_joint.get(j) != name:
            raise ControllerFileError(path, f"joint {j} is {name} in the file but "
                                      f"{by_joint.get(j, 'no axis')} in the profile", no)


def read_products(path: Path, machine: Machine, joints: dict[str, int]) -> list[ProductTable]:
    """The product terms of a ``vecpin_vec.comp`` (SI tables, plain factors): each term's table and
    factor from their comments and arrays; raises where a term lacks one of them, a factor's
    output is not its table's, or a joint is not the profile's."""
    path = Path(path)
    by_joint = {n: a for a, n in joints.items()}
    found: dict[str, dict[str, CompensationTable]] = {}
    for no, m, arr in _commented_arrays(path, _PRODUCT, r"vecpin_p[tf]\d+"):
        n = int(m.group("n"))
        if arr is None or int(arr.group(1)) != n or len(arr.group(2).split(",")) != n:
            raise ControllerFileError(path, f"product {m.group('kind')} {m.group('name')}: no array of {n} values on "
                                      "the next line", no)
        _check_joints(path, m, by_joint, no)
        values = np.array([float(v) for v in arr.group(2).split(",")])
        found.setdefault(m.group("name"), {})[m.group("kind")] = _commented_table(machine, m, values,
                                                                                  si=m.group("kind") == "table")
    out = []
    for name, parts in found.items():
        if set(parts) != {"table", "factor"}:
            raise ControllerFileError(path, f"product {name} has no {({'table', 'factor'} - set(parts)).pop()}")
        out.append(ProductTable(parts["table"], parts["factor"]))
    return out
