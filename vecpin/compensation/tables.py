"""Compensation tables: what a controller loads (Paper I eq. 13-16; Paper II eq. 1-2).

A table maps the position of an *input* axis i to an increment of the command of an
*output* axis o, by linear interpolation between equally spaced points (eq. 14); the
compensated command is ``q_c = q + t(q)`` with ``t_o(q) = sum_i t_oi(q_i)`` (eq. 15-16).
Beyond the first and last points the end values hold (as the controllers do). A table
on a rotary input may be *modulo*: it covers one turn and repeats.

Tables live in SI (m or rad, in the unit of the output axis); files are mm/deg. A
:class:`TableSet` also carries the change of the controller's gauge-line offset
``T_offset`` [m].
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vecpin.errors import VecpinError
from vecpin.fileio import write_text
from vecpin.kinematics.machine import Machine
from vecpin.units import MM_PER_M, M_PER_MM


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
        """The seed's two-letter name: output then input axis, e.g. 'zx' = Z corrected from X."""
        return (self.output_axis + self.input_axis).lower()

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
class TableSet:
    """Tables of one machine plus the gauge-line offset change [m]."""

    axis_names: list[str]
    tables: list[CompensationTable] = field(default_factory=list)
    gauge_offset_change: float = 0.0
    source: str = ""

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
        return out

    def apply(self, q: np.ndarray) -> np.ndarray:
        """Compensated commands q + t(q) (eq. 15)."""
        q = np.atleast_2d(np.asarray(q, float))
        return q + self.increments(q)

    def subset(self, names) -> "TableSet":
        keep = {n.lower() for n in names}
        return TableSet(list(self.axis_names), [t for t in self.tables if t.name in keep or t.is_pitch],
                        self.gauge_offset_change, self.source)

    # ------------------------------------------------------------ generic files
    def to_dict(self, machine: Machine) -> dict:
        tabs = []
        for t in self.tables:
            ai, ao = machine.axis(t.input_axis), machine.axis(t.output_axis)
            tabs.append({"name": t.name, "input_axis": t.input_axis, "output_axis": t.output_axis,
                         "input_unit": ai.unit, "output_unit": ao.unit, "modulo": t.modulo,
                         "start": float(ai.to_user(t.start)), "step": float(ai.to_user(t.step)),
                         "points": len(t.values), "values": [float(v) for v in ao.to_user(t.values)]})
        return {"format": "vecpin-tables", "version": 1, "machine": machine.name,
                "gauge_offset_change_mm": self.gauge_offset_change * MM_PER_M,
                "convention": "compensated command = command + sum of tables (eq. 15-16); linear interpolation; "
                              "end values hold beyond the ends; modulo tables repeat every turn",
                "tables": tabs}

    def save_json(self, path: str | Path, machine: Machine) -> None:
        write_text(path, json.dumps(self.to_dict(machine), indent=1))

    @classmethod
    def from_dict(cls, d: dict, machine: Machine) -> "TableSet":
        if d.get("format") != "vecpin-tables":
            raise VecpinError("not a vecpin table file")
        tables = []
        for e in d["tables"]:
            ai, ao = machine.axis(e["input_axis"]), machine.axis(e["output_axis"])
            tables.append(CompensationTable(ai.name, ao.name, float(ai.to_si(e["start"])), float(ai.to_si(e["step"])),
                                            ao.to_si(np.array(e["values"], float)), bool(e["modulo"])))
        return cls(machine.axis_names, tables, d["gauge_offset_change_mm"] * M_PER_MM, d.get("machine", ""))

    @classmethod
    def load_json(cls, path: str | Path, machine: Machine) -> "TableSet":
        return cls.from_dict(json.loads(Path(path).read_text()), machine)

    def save_csv(self, path: str | Path, machine: Machine) -> None:
        """One row per table point: table, input, output, index, input position, value (mm/deg)."""
        lines = ["table,input_axis,output_axis,modulo,index,input_position,value"]
        for t in self.tables:
            ai, ao = machine.axis(t.input_axis), machine.axis(t.output_axis)
            pos, val = ai.to_user(t.positions), ao.to_user(t.values)
            lines += [f"{t.name},{t.input_axis},{t.output_axis},{int(t.modulo)},{k},{pos[k]:.8f},{val[k]:.9f}"
                      for k in range(len(val))]
        lines.append(f"# gauge_offset_change_mm,{self.gauge_offset_change * MM_PER_M:.6f}")
        write_text(path, "\n".join(lines) + "\n")


def table_grid(axis, n_points: int, modulo: bool) -> tuple[float, float]:
    """(start, step) of an n-point table over the axis travel, or over one turn for modulo."""
    if n_points < 2:
        raise VecpinError("a table needs at least 2 points")
    if modulo:
        return 0.0, 2 * math.pi / (n_points - 1)
    return axis.lower, axis.travel / (n_points - 1)
