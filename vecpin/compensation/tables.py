"""Compensation tables: what a controller loads (Paper I eq. 13-16; Paper II eq. 1-2).

A table maps the position of an *input* axis i to an increment of the command of an
*output* axis o, by linear interpolation between equally spaced points (eq. 14); the
compensated command is ``q_c = q + t(q)`` with ``t_o(q) = sum_i t_oi(q_i)`` (eq. 15-16).
Beyond the first and last points the end values hold (as the controllers do). A table
on a rotary input may be *modulo*: it covers one turn and repeats.

Tables live in SI (m or rad, in the unit of the output axis); files are mm/deg. A
:class:`TableSet` also carries the change of the controller's gauge-line offset
``T_offset`` [m], and the :class:`TwinDrive` axes: a gantry axis driven by two motors
whose *differential* table moves the drives apart and so turns the beam (seed Section
2.5; the tables of the axis itself are the mean of its two drives).
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vecpin.errors import MachineError, VecpinError
from vecpin.fileio import write_text
from vecpin.kinematics.machine import Machine
from vecpin.kinematics.so3 import exp3
from vecpin.units import MM_PER_M, M_PER_MM


NC_AXIS = re.compile(r"[a-z][0-9]*")  # an NC-style axis name, lower case: a letter and digits (x, x2, a1)
TABLE_NAME_SEPARATOR = "_"


def table_name(output_axis: str, input_axis: str) -> str:
    """The name of the table of ``output_axis`` (corrected) from ``input_axis`` (read),
    lower case. NC-style names (a letter and optional digits: X, Y, X2, A1) run together
    as in the seed ('zx' = Z from X, 'yx2'): one letter starts each, so the two are told
    apart. Other names (a vendor's joints: 'x_axis', 'c_axis') are joined by '_'
    ('x_axis_c_axis'), which every place a table name goes takes: the sign test's program
    (Siemens program names: letters, digits, '_'; Heidenhain and Fanuc file names), the
    LinuxCNC component's comments, the READMEs, the generic JSON and CSV."""
    return joined_axes(output_axis, input_axis).lower()


def joined_axes(first: str, second: str) -> str:
    """Two axis names in one name, case kept: run together when both are NC-style (a
    letter and optional digits), else joined by '_' (see :func:`table_name`)."""
    nc = NC_AXIS.fullmatch(first.lower()) and NC_AXIS.fullmatch(second.lower())
    return first + second if nc else first + TABLE_NAME_SEPARATOR + second


def table_names(axis_names) -> list[str]:
    """Every (output, input) pair's :func:`table_name`, output axis by output axis (the
    pitch tables on the diagonal); refuses (MachineError) axes whose pairs share a name,
    which a table set could not tell apart."""
    names = [table_name(o, i) for o in axis_names for i in axis_names]
    pairs = [(o, i) for o in axis_names for i in axis_names]
    seen: dict[str, tuple[str, str]] = {}
    for name, pair in zip(names, pairs):
        if name in seen:
            raise MachineError(f"the tables of {seen[name][0]} from {seen[name][1]} and of {pair[0]} from {pair[1]} "
                               f"would both be named '{name}' (names are lower case, axes joined by "
                               f"'{TABLE_NAME_SEPARATOR}'): rename an axis joint in the URDF")
        seen[name] = pair
    return names


def cross_table_axes(axis_names) -> dict[str, tuple[str, str]]:
    """Every cross table's :func:`table_name` -> its (output, input) axis names, output
    axis by output axis: what a table name stands for, kept where the name is made (a
    name is never parsed back into its axes: vendor axis names hold the separator)."""
    return {table_name(o, i): (o, i) for o in axis_names for i in axis_names if o != i}


@dataclass
class CompensationTable:
    """One table: ``values[k]`` [m or rad of the output axis] at input position
    ``start + k * step`` [m or rad of the input axis]."""

    input_axis: str
    output_axis: str
    start: float
    step: float
    values: np.ndarray
    modulo: bool = False

    @property
    def name(self) -> str:
        """Output then input axis (:func:`table_name`), e.g. 'zx' = Z corrected from X."""
        return table_name(self.output_axis, self.input_axis)

    @property
    def positions(self) -> np.ndarray:
        return self.start + self.step * np.arange(len(self.values))

    @property
    def end(self) -> float:
        return self.start + self.step * (len(self.values) - 1)

    @property
    def is_pitch(self) -> bool:
        return self.input_axis == self.output_axis

    def __call__(self, q_in: np.ndarray) -> np.ndarray:
        """Interpolated increments for input positions (eq. 14)."""
        q = np.asarray(q_in, float)
        if self.modulo:
            period = self.step * (len(self.values) - 1)
            q = self.start + np.mod(q - self.start, period)
        return np.interp(q, self.positions, self.values)


@dataclass
class ProductTable:
    """A table multiplied by a factor table (Siemens ``$AN_CEC_MULT_BY_TABLE``): adds
    ``table(q_R) * factor(q_L)`` to the command of ``table.output_axis``. ``table``: input R (a
    rotary table axis), values [m or rad of the output]; ``factor``: input L (a linear axis),
    output the same axis, values dimensionless (a fixed ramp, -1 .. 1 over L's measured range).
    A tilt fixed to a turning table is, in machine axes, such a product (Δz = a(C) x + b(C) y)."""

    table: CompensationTable
    factor: CompensationTable

    @property
    def name(self) -> str:
        """'zc*x': Z corrected by a table of C times a ramp of X."""
        return product_name(self.table.output_axis, self.table.input_axis, self.factor.input_axis)

    def __call__(self, q_table: np.ndarray, q_factor: np.ndarray) -> np.ndarray:
        return self.table(q_table) * self.factor(q_factor)


def product_name(output_axis: str, table_axis: str, factor_axis: str) -> str:
    """The name of a product term: the table's :func:`table_name`, '*', the factor's input axis (lower case)."""
    return f"{table_name(output_axis, table_axis)}*{factor_axis.lower()}"


@dataclass
class TwinDrive:
    """A linear (gantry) axis driven by two motors, and the differential table between them.

    The leading drive moves by the axis' tables plus ``d(q)``, the following drive by
    the axis' tables minus ``d(q)``, with ``d`` the sum of the ``differential`` tables
    [m] (each on its own input axis): the beam's centre follows the axis' tables and the
    beam turns. With ``s`` the separation from the leading to the following drive and
    ``x`` the axis direction (base frame), the drives at ``-s/2`` and ``+s/2`` from the
    beam's centre, a turn ``phi`` about ``w`` moves a drive at ``r`` by ``phi (w x r) . x``
    along the axis; the only turn that moves the drives along the axis is about
    ``w = (s x x) / |s x x|``, and ``-2 d = phi |s x x|`` gives
    ``phi = -2 d / |s x x|``. The beam turns about the origin of the axis' joint frame
    (the beam's centre: the URDF places the axis there, the drives symmetric about it).
    """

    axis: str
    following: str                      # vecpin's name of the following drive (e.g. X2)
    separation: np.ndarray | None       # (3,) [m], base frame, leading -> following; None: not known
    differential: list[CompensationTable] = field(default_factory=list)

    def offset(self, q: np.ndarray, axis_names: list[str]) -> np.ndarray:
        """d(q) (N,) [m]: the leading drive's share of the differential at commands q."""
        q = np.atleast_2d(np.asarray(q, float))
        idx = {a: k for k, a in enumerate(axis_names)}
        out = np.zeros(len(q))
        for t in self.differential:
            out += t(q[:, idx[t.input_axis]])
        return out

    def turn(self, machine: Machine, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(rotation vectors (N,3) [rad], pivots (N,3) [m]) of the beam at commands q
        (base frame): ``phi w`` about the origin of the axis' joint frame."""
        q = np.atleast_2d(np.asarray(q, float))
        F = machine.joint_frames(q, self.axis)
        if not self.differential or self.separation is None:
            return np.zeros((len(q), 3)), F[:, :3, 3]
        x = F[:, :3, :3] @ np.asarray(machine.axis(self.axis).direction, float)     # (N,3) axis direction
        sx = np.cross(np.asarray(self.separation, float)[None], x)                   # s x x
        n2 = np.einsum("pi,pi->p", sx, sx)
        if np.any(n2 <= 0):
            raise VecpinError(f"twin drives of {self.axis}: the drive separation is parallel to the axis, so a "
                              "differential between the drives cannot turn the beam")
        d = self.offset(q, machine.axis_names)
        return (-2.0 * d / n2)[:, None] * sx, F[:, :3, 3]

    def to_dict(self, machine: Machine) -> dict:
        ax = machine.axis(self.axis)
        return {"axis": self.axis, "following": self.following,
                "separation_mm": None if self.separation is None else [float(v) * MM_PER_M for v in self.separation],
                "differential": [_table_to_dict(t, machine.axis(t.input_axis), ax) for t in self.differential]}

    @classmethod
    def from_dict(cls, d: dict, machine: Machine) -> "TwinDrive":
        ax = machine.axis(d["axis"])
        sep = d.get("separation_mm")
        return cls(ax.name, str(d["following"]), None if sep is None else np.asarray(sep, float) * M_PER_MM,
                   [_table_from_dict(e, machine) for e in d.get("differential", [])])


def _table_to_dict(t: "CompensationTable", ai, ao) -> dict:
    return {"name": t.name, "input_axis": t.input_axis, "output_axis": t.output_axis,
            "input_unit": ai.unit, "output_unit": ao.unit, "modulo": t.modulo,
            "start": float(ai.to_user(t.start)), "step": float(ai.to_user(t.step)),
            "points": len(t.values), "values": [float(v) for v in ao.to_user(t.values)]}


def _table_from_dict(e: dict, machine: Machine) -> "CompensationTable":
    ai, ao = machine.axis(e["input_axis"]), machine.axis(e["output_axis"])
    return CompensationTable(ai.name, ao.name, float(ai.to_si(e["start"])), float(ai.to_si(e["step"])),
                             ao.to_si(np.array(e["values"], float)), bool(e["modulo"]))


def _factor_to_dict(t: "CompensationTable", ai) -> dict:
    return {"input_axis": t.input_axis, "output_axis": t.output_axis, "input_unit": ai.unit, "output_unit": "1",
            "modulo": t.modulo, "start": float(ai.to_user(t.start)), "step": float(ai.to_user(t.step)),
            "points": len(t.values), "values": [float(v) for v in t.values]}


def _factor_from_dict(e: dict, machine: Machine) -> "CompensationTable":
    ai = machine.axis(e["input_axis"])
    return CompensationTable(ai.name, machine.axis(e["output_axis"]).name, float(ai.to_si(e["start"])),
                             float(ai.to_si(e["step"])), np.array(e["values"], float), bool(e["modulo"]))


@dataclass
class TableSet:
    """Tables of one machine plus the gauge-line offset change [m] and the twin-drive
    axes with their differential tables (:class:`TwinDrive`; none on most machines)."""

    axis_names: list[str]
    tables: list[CompensationTable] = field(default_factory=list)
    gauge_offset_change: float = 0.0
    source: str = ""
    drives: list[TwinDrive] = field(default_factory=list)
    products: list[ProductTable] = field(default_factory=list)

    def names(self) -> list[str]:
        return [t.name for t in self.tables]

    def table(self, name: str) -> CompensationTable:
        for t in self.tables:
            if t.name == name.lower():
                return t
        raise KeyError(name)

    def increments(self, q: np.ndarray) -> np.ndarray:
        """t(q) (N, n) [m, rad] (eq. 16)."""
        q = np.atleast_2d(np.asarray(q, float))
        out = np.zeros_like(q)
        idx = {a: k for k, a in enumerate(self.axis_names)}
        for t in self.tables:
            out[:, idx[t.output_axis]] += t(q[:, idx[t.input_axis]])
        for p in self.products:
            out[:, idx[p.table.output_axis]] += p(q[:, idx[p.table.input_axis]], q[:, idx[p.factor.input_axis]])
        return out

    def apply(self, q: np.ndarray) -> np.ndarray:
        """Compensated commands q + t(q) (eq. 15)."""
        q = np.atleast_2d(np.asarray(q, float))
        return q + self.increments(q)

    def subset(self, names) -> "TableSet":
        keep = {n.lower() for n in names}
        return TableSet(list(self.axis_names), [t for t in self.tables if t.name in keep or t.is_pitch],
                        self.gauge_offset_change, self.source, list(self.drives),
                        [p for p in self.products if p.name in keep])

    def turn_tips(self, machine: Machine, q: np.ndarray, tip: np.ndarray, frame: str = "base") -> np.ndarray:
        """Tool tips (N,3) [m] after the twin drives' differential turned their beams, at
        the axis positions q (the compensated commands: the differential is read there, as
        a controller reads its tables' input axes; from the programmed command it differs
        by a table value times the differential's slope, second order). Every turn acts on
        the tool tip in the base frame (as a gantry skew does: the beam carries the tool);
        ``frame="workpiece"``: ``tip`` is relative to the workpiece (its nominal pose at
        q) and so is the result."""
        if not any(d.differential for d in self.drives):
            return tip
        q = np.atleast_2d(np.asarray(q, float))
        tip = np.asarray(tip, float)
        T = machine.workpiece_pose(q) if frame == "workpiece" and machine.has_workpiece else None
        if T is not None:
            tip = np.einsum("pij,pj->pi", T[:, :3, :3], tip) + T[:, :3, 3]
        for d in self.drives:
            w, pivot = d.turn(machine, q)
            tip = pivot + np.einsum("pij,pj->pi", exp3(w), tip - pivot)
        if T is not None:
            tip = np.einsum("pji,pj->pi", T[:, :3, :3], tip - T[:, :3, 3])
        return tip

    # ------------------------------------------------------------ generic files
    def to_dict(self, machine: Machine) -> dict:
        tabs = [_table_to_dict(t, machine.axis(t.input_axis), machine.axis(t.output_axis)) for t in self.tables]
        out = {"format": "vecpin-tables", "version": 1, "machine": machine.name,
               "gauge_offset_change_mm": self.gauge_offset_change * MM_PER_M,
               "convention": "compensated command = command + sum of tables (eq. 15-16); linear interpolation; "
                             "end values hold beyond the ends; modulo tables repeat every turn",
               "tables": tabs}
        if self.drives:
            out["drives_convention"] = (
                "twin-drive axes: the tables above move the axis (the mean of its two drives); the leading drive "
                "gets them plus the sum of the 'differential' tables, the following drive minus it, which turns the "
                "beam by -2 d / |s x x| about s x x (s = separation_mm from the leading to the following drive, "
                "x = the axis direction, base frame)")
            out["drives"] = [d.to_dict(machine) for d in self.drives]
        if self.products:
            out["products_convention"] = (
                "product terms: each adds its 'table' value (interpolated at its input axis, in the output axis' "
                "unit) times its 'factor' value (interpolated at the factor's input axis; a plain number) to the "
                "output axis' command, beside the tables above")
            out["products"] = [{"name": p.name, "table": _table_to_dict(p.table, machine.axis(p.table.input_axis),
                                                                        machine.axis(p.table.output_axis)),
                                "factor": _factor_to_dict(p.factor, machine.axis(p.factor.input_axis))}
                               for p in self.products]
        return out

    @classmethod
    def from_dict(cls, d: dict, machine: Machine) -> "TableSet":
        if d.get("format") != "vecpin-tables":
            raise VecpinError("not a vecpin table file")
        tables = [_table_from_dict(e, machine) for e in d["tables"]]
        drives = [TwinDrive.from_dict(e, machine) for e in d.get("drives", [])]
        products = [ProductTable(_table_from_dict(e["table"], machine), _factor_from_dict(e["factor"], machine))
                    for e in d.get("products", [])]
        return cls(machine.axis_names, tables, d["gauge_offset_change_mm"] * M_PER_MM, d.get("machine", ""), drives,
                   products)

    @classmethod
    def load_json(cls, path: str | Path, machine: Machine) -> "TableSet":
        return cls.from_dict(json.loads(Path(path).read_text()), machine)

    def save_csv(self, path: str | Path, machine: Machine) -> None:
        """One row per table point: table, input, output, index, input position, value (mm/deg);
        a plain CSV (no comment row: a CSV reader takes every row as data). A product term's two
        tables are named 'zc*x:table' (mm/deg) and 'zc*x:factor' (a plain number): their product is added."""
        lines = ["table,input_axis,output_axis,modulo,index,input_position,value"]
        named = [(t.name, t, True) for t in self.tables]
        named += [x for p in self.products for x in ((f"{p.name}:table", p.table, True),
                                                      (f"{p.name}:factor", p.factor, False))]
        for name, t, scaled in named:
            ai, ao = machine.axis(t.input_axis), machine.axis(t.output_axis)
            pos, val = ai.to_user(t.positions), ao.to_user(t.values) if scaled else t.values
            lines += [f"{name},{t.input_axis},{t.output_axis},{int(t.modulo)},{k},{pos[k]:.8f},{val[k]:.9f}"
                      for k in range(len(val))]
        write_text(path, "\n".join(lines) + "\n")   # every row is data: the gauge-line change is in tables.json


def table_grid(axis, n_points: int, modulo: bool) -> tuple[float, float]:
    """(start, step) of an n-point table over the axis travel, or over one turn for modulo."""
    if n_points < 2:
        raise VecpinError("a table needs at least 2 points")
    if modulo:
        return 0.0, 2 * math.pi / (n_points - 1)
    return axis.lower, axis.travel / (n_points - 1)
