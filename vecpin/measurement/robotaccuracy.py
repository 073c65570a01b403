"""The public UR10 laser-tracker dataset of Landgraf et al. (CASE 2021,
github.com/christianlandgraf/ipa-robot-accuracy, MIT licence) into a campaign.

Each series' ``measurements_*.csv`` is ``;``-separated with decimal commas: a time stamp,
the commanded pose (``Goal x`` ... in m and rad, not used), the six joint angles in rad
named as ROS names the UR joints (``shoulder_pan_joint`` ... ``wrist_3_joint``: the
bundled ``ur10``'s axes), the air temperature in °C and the pose of a Leica T-Mac probe
measured by the tracker (``measurement_x``, ``_y``, ``_z`` in mm; angles in deg, not
used), in three of the four series with each coordinate's standard deviation
(``measurement_std_x`` ..., mm). The T-Mac's centre is the point measured: 109.0 mm along
the flange's z (the series' ``Trafo_TM_F_init.txt``: 108.99996544 mm, 0.087 mm aside,
which the 6-DoF model's constant error after the last joint takes up), the campaign's
tool length.

What is odd, and what is done about it (every point in the read's notes):

* Series A (``measurements_grid.csv``) stamps rows ``yyyymmddHHMMSS``; its last rows were
  measured days earlier than the rows before them (repeats appended at the end): the
  rows are put in time order, the campaign's order of measurement.
* Series B, C and D stamp every row ``2,02011E+13`` or ``2,02103E+13``: the time rounded to
  six digits by a spreadsheet, the same number for every row. Such stamps carry no time:
  no ``time`` column is written and the file's order is taken as the measurement order.
* Joint angles are radians, the tracker's coordinates millimetres: each is converted to
  what a campaign holds (the CSV: deg and mm).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from vecpin.errors import CampaignFileError, InputError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.exportread import (_COMMA, _DOT, ExportTable, detect_decimal, parse_number,
                                           read_export_table)
from vecpin.units import M_PER_MM

JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
          "wrist_3_joint")
XYZ = ("measurement_x", "measurement_y", "measurement_z")
STD = ("measurement_std_x", "measurement_std_y", "measurement_std_z")
TEMPERATURE = "measurement_temperature"
TIME = "Timestamp"
TMAC_TOOL_MM = 109.0  # the T-Mac's centre along the flange's z (Trafo_TM_F_init.txt of every series)
_STAMP = re.compile(r"^\d{14}$")                            # yyyymmddHHMMSS
_ROUNDED = re.compile(r"^\d([.,]\d+)?[eE]\+?\d+$")          # a stamp a spreadsheet wrote as a float


@dataclass
class DatasetRead:
    """The campaign (SI, rows in measurement order) and what was done to read it."""

    campaign: Campaign
    path: str
    tool_mm: float
    notes: list[str]

    def lines(self) -> list[str]:
        c = self.campaign
        extra = ", ".join(c.extra) or "none"
        out = [f"read {len(c)} measured poses from {self.path} (ipa-robot-accuracy dataset, UR10)",
               f"  joints in rad (deg in a campaign CSV); T-Mac centre x, y, z in mm; tool {self.tool_mm:g} mm "
               f"along the flange's z; extra columns: {extra}"]
        return out + [f"  note: {n}" for n in self.notes]


def dataset_header(header: list[str]) -> bool:
    """True for the header of a series' measurement file (the joints and the T-Mac's x, y, z)."""
    return all(n in header for n in JOINTS + XYZ)


def _error(table: ExportTable, msg: str, k: int | None = None, column: str | None = None) -> CampaignFileError:
    return CampaignFileError(table.path, msg, row=table.lines[k] if k is not None else table.header_line, column=column)


def _times(table: ExportTable, j: int) -> tuple[np.ndarray | None, str]:
    """Seconds since the first stamp, or None with the reason the stamps carry no time."""
    cells = [r[j] for r in table.rows]
    if all(_STAMP.match(c) for c in cells):
        try:
            t = np.array([datetime.strptime(c, "%Y%m%d%H%M%S").replace(tzinfo=timezone.utc).timestamp()
                          for c in cells])
        except ValueError:
            k = next(k for k, c in enumerate(cells) if not _valid_stamp(c))
            raise _error(table, f"'{cells[k]}' is not a date and time yyyymmddHHMMSS", k, TIME) from None
        return t, ""
    if all(_ROUNDED.match(c) for c in cells):
        distinct = sorted(set(cells))
        return None, (f"time stamps carry no time: every row's '{TIME}' is a number rounded to a few digits by a "
                      f"spreadsheet ({', '.join(repr(c) for c in distinct[:3])}{' ...' if len(distinct) > 3 else ''}"
                      f" for {len(cells)} rows); no time column is written and the file's row order is taken as the "
                      "order of measurement")
    kinds = ["stamp" if _STAMP.match(c) else "rounded" if _ROUNDED.match(c) else None for c in cells]
    k = next((k for k, v in enumerate(kinds) if v is None), None)
    if k is None:  # both kinds: the first row unlike the first
        k = next(k for k, v in enumerate(kinds) if v != kinds[0])
        raise _error(table, f"time stamp '{cells[k]}' is unlike line {table.lines[0]}'s '{cells[0]}': the stamps of "
                     "one series are all yyyymmddHHMMSS (as in series A) or all rounded numbers (as in series B-D)",
                     k, TIME)
    raise _error(table, f"time stamp '{cells[k][:40]}' is neither yyyymmddHHMMSS (as in series A) nor a rounded "
                 "number (as in series B-D)", k, TIME)


def _valid_stamp(c: str) -> bool:
    try:
        datetime.strptime(c, "%Y%m%d%H%M%S")
        return True
    except ValueError:
        return False


def read_dataset(path: str | Path, machine: Machine, *, tool_mm: float = TMAC_TOOL_MM) -> DatasetRead:
    """Read one series' measurement file (module text) as a campaign of ``machine``,
    whose axes must be the six UR joints (``Machine.load("ur10")``); ``tool_mm``: the
    T-Mac centre's distance from the flange along its z, mm."""
    if not (math.isfinite(tool_mm) and 0 <= tool_mm <= 10_000):
        raise InputError(f"`tool_mm` {tool_mm}: the T-Mac centre's distance from the flange, mm (0 .. 10000)")
    if tuple(machine.axis_names) != JOINTS:
        raise CampaignFileError(str(path), f"the dataset's joints are {', '.join(JOINTS)}; machine '{machine.name}' "
                                f"has axes {', '.join(machine.axis_names)} (use the bundled ur10)")
    table = _table(path)
    column = _columns(table)
    q = column(JOINTS)                                                       # rad, as the campaign holds them
    far = np.abs(q) > 2 * np.pi + 1e-6
    if far.any():
        k, j = np.argwhere(far)[0]
        raise _error(table, f"{q[k, j]:g} is beyond one turn: joint angles in this dataset are radians", int(k),
                     JOINTS[j])
    xyz = column(XYZ) * M_PER_MM
    order, extra, notes = _time_order(table)
    if TEMPERATURE in table.header:
        extra["temperature"] = T = column((TEMPERATURE,))[:, 0]
        notes.append(f"air temperature {T.min():.2f} .. {T.max():.2f} °C")
    extra |= {f"std_{c}": column((n,))[:, 0] for c, n in zip("xyz", STD) if n in table.header}   # mm
    extra = {k: v[order] for k, v in extra.items()}
    campaign = Campaign(list(JOINTS), q[order], np.full(len(order), tool_mm * M_PER_MM), xyz[order], extra,
                        table.path, lines=np.asarray(table.lines)[order], rotary=machine.rotary_mask())
    return DatasetRead(campaign, table.path, tool_mm, notes)


def _table(path: str | Path) -> ExportTable:
    """The series' table: the header line with the joints and the T-Mac's x, y, z."""
    try:
        return read_export_table(path, "semicolon", dataset_header)
    except CampaignFileError as exc:
        if not exc.reason.startswith("no header line"):
            raise
        first = read_export_table(path, "semicolon")
        missing = [n for n in JOINTS + XYZ if n not in first.header]
        raise CampaignFileError(exc.path, "not a measurement file of the ipa-robot-accuracy dataset: the header has no "
                                f"column {', '.join(missing)}", row=first.header_line) from None


def _columns(table: ExportTable):
    """A reader of numeric columns, ``column(names) -> (N, len(names))``, with the table's
    one decimal mark (refused when the numeric cells mix commas and points)."""
    col = {h: j for j, h in enumerate(table.header)}
    numeric = [n for n in JOINTS + XYZ + STD + (TEMPERATURE,) if n in col]
    decimal = detect_decimal([r[col[n]] for r in table.rows for n in numeric])
    if decimal == "mixed":  # the first cell of the rarer mark
        cells = [(k, n) for k in range(len(table.rows)) for n in numeric]
        comma = [(k, n) for k, n in cells if _COMMA.match(table.rows[k][col[n]])]
        dot = [(k, n) for k, n in cells if _DOT.match(table.rows[k][col[n]])]
        (k, n), mark, other = (dot[0], "point", "commas") if len(comma) >= len(dot) else (comma[0], "comma", "points")
        raise _error(table, f"'{table.rows[k][col[n]]}' has a decimal {mark} while the other cells have decimal "
                     f"{other}", k, n)

    def cell(k: int, name: str) -> float:
        s = table.rows[k][col[name]]
        if s == "":
            raise _error(table, "empty cell (no value is guessed: fill it or delete the row)", k, name)
        try:
            return parse_number(s, decimal)
        except ValueError:
            raise _error(table, f"'{s[:40]}' is not a number", k, name) from None

    def column(names: tuple[str, ...]) -> np.ndarray:
        return np.array([[cell(k, n) for n in names] for k in range(len(table.rows))]).reshape(-1, len(names))
    return column


def _time_order(table: ExportTable) -> tuple[np.ndarray, dict[str, np.ndarray], list[str]]:
    """(row order of measurement, {"time": s since the first stamp} when the stamps carry
    time, notes): rows stamped earlier than the row before them are put in time order."""
    order, notes = np.arange(len(table.rows)), []
    if TIME not in table.header:
        return order, {}, [f"no '{TIME}' column: the file's row order is taken as the order of measurement"]
    t, why = _times(table, table.header.index(TIME))
    if t is None:
        return order, {}, [why]
    back = np.flatnonzero(np.diff(t) < 0) + 1
    if back.size:
        order = np.argsort(t, kind="stable")
        lines = [table.lines[k] for k in back]
        notes.append(f"{back.size} rows are stamped earlier than the row before them (lines "
                     f"{', '.join(map(str, lines[:6]))}{' ...' if len(lines) > 6 else ''}): rows put in time "
                     "order, the order of measurement")
    t = t - t.min()
    gaps = np.diff(np.sort(t))
    notes.append(f"time stamps span {t.max() / 3600:.1f} h, the longest pause {gaps.max() / 3600:.1f} h"
                 if gaps.size else "one time stamp")
    return order, {"time": t}, notes
