"""The campaign template of a measurement plan: the campaign format with empty x, y, z.

One row per planned measurement, in measurement order, with the columns of a campaign
file (:mod:`vecpin.measurement.campaign`):

* ``point``: the point number (1, 2, ...; the NC programs call it P0001, P0002, ...);
* one column per axis (mm or degrees), ``tool`` (mm from the gauge line);
* ``x``, ``y``, ``z``: empty, to be filled from the tracker (a filled template reads
  as a campaign);
* optional ``approach_<AXIS>``: +1 when the axis reaches the point from below, -1 from
  above, 0 straight from the previous point;
* on a plan with table nests (a machine with table axes): ``instrument`` (``tracker``
  for a tool-tip reading, ``nest`` for a reading of a reflector in a table nest, taken
  at the dwell of the tool-tip row before it, the same command), ``target`` (the nest's
  id on nest rows, empty on tool rows) and ``nest_x``, ``nest_y``, ``nest_z``: where the
  nest was planned, mm in the workpiece (table) frame, on nest rows only (the fit finds
  the real position; the planned one is the start, and where a simulation puts it);
* on a plan read from several tracker stations (a second station proposed for the
  table's tilt range, :mod:`vecpin.planning.nestplacement`): ``station``, the tracker
  position each row is read from (0: the plan's tracker; 1: the second station, whose
  rows come after all of station 0's, as a block of their own). The stations' positions
  (mm, machine base frame) are in plan.json (``stations_mm``) and in the NC programs'
  comments; a campaign keeps the column (:mod:`vecpin.measurement.campaign`), so the
  fit finds every station's pose.

Every row has its own point number, nest rows too, so a tracker export whose points
are named after the template (P0001, P0002, ...) joins by name, and one without names
joins by order. A filled template of a plan without nests reads as a campaign; with
nests, ``vecpin import`` makes the campaign (the planned nest positions are not
campaign columns).

:func:`read_template` checks a template the way :func:`read_campaign` checks a
campaign: every problem names the file, row (line, header = 1) and column.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vecpin.errors import CampaignFileError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import MAX_ID, read_text_file
from vecpin.units import M_PER_MM, to_mm


NEST_COLUMNS = ("instrument", "target", "nest_x", "nest_y", "nest_z")


@dataclass
class PlanTemplate:
    """Planned rows (SI): ``point`` (N,) int, ``q`` (N,n) [m, rad] in the machine's chain
    order, ``tool`` (N,) [m], ``approach`` (N,n) signs or None; on a plan with table
    nests ``instrument`` (N,) "tracker"/"nest", ``target`` (N,) nest id ("" on tool
    rows) and ``nest`` (N,3) [m] planned nest position in the workpiece frame (NaN on
    tool rows); None on a plan without nests. ``station`` (N,) int: the tracker station
    each row is read from, None on a plan read from one station."""

    point: np.ndarray
    q: np.ndarray
    tool: np.ndarray
    approach: np.ndarray | None = None
    source: str = "<plan>"
    instrument: np.ndarray | None = None
    target: np.ndarray | None = None
    nest: np.ndarray | None = None
    station: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.point)

    @property
    def has_nests(self) -> bool:
        return self.instrument is not None and bool(np.any(self.instrument == "nest"))

    @property
    def tool_rows(self) -> np.ndarray:
        """Rows that read the tool tip (every row of a plan without nests)."""
        return np.arange(len(self)) if self.instrument is None else np.flatnonzero(self.instrument != "nest")

    @property
    def nest_rows(self) -> np.ndarray:
        return np.zeros(0, int) if self.instrument is None else np.flatnonzero(self.instrument == "nest")

    @property
    def stations(self) -> np.ndarray:
        """(N,) the tracker station of every row (0 on a plan read from one station)."""
        return np.zeros(len(self), int) if self.station is None else self.station

    def nests(self) -> dict[str, np.ndarray]:
        """{nest id: planned position (3,) [m], workpiece frame} in the order first read."""
        out: dict[str, np.ndarray] = {}
        for i in self.nest_rows:
            out.setdefault(str(self.target[i]), self.nest[i].copy())
        return out

    def take(self, rows) -> "PlanTemplate":
        """The template of some rows (index array), order kept."""
        rows = np.asarray(rows)
        pick = (lambda a: None if a is None else a[rows])
        return PlanTemplate(self.point[rows], self.q[rows], self.tool[rows], pick(self.approach), self.source,
                            pick(self.instrument), pick(self.target), pick(self.nest), pick(self.station))

    def to_csv(self, machine: Machine) -> str:
        """The template CSV text (mm, deg; 6 decimals in mm, 8 in deg, as campaign files)."""
        q_user = machine.to_user(self.q)
        header = ["point"] + machine.axis_names + ["tool", "x", "y", "z"]
        if self.approach is not None:
            header += [f"approach_{a}" for a in machine.axis_names]
        nests = self.has_nests
        if nests:
            header += list(NEST_COLUMNS)
            nest_mm = to_mm(self.nest)
        several = bool(np.any(self.stations != 0))
        if several:
            header.append("station")
        lines = [",".join(header)]
        fmts = ["%.6f" if a.kind == "linear" else "%.8f" for a in machine.axes]
        tool_mm = to_mm(self.tool)
        for i in range(len(self)):
            cells = [str(int(self.point[i]))] + [f % v for f, v in zip(fmts, q_user[i])] + [f"{tool_mm[i]:.6f}", "", "", ""]
            if self.approach is not None:
                cells += [str(int(s)) for s in self.approach[i]]
            if nests:
                on_nest = self.instrument[i] == "nest"
                cells += [str(self.instrument[i]), str(self.target[i]) if on_nest else ""]
                cells += [f"{v:.6f}" for v in nest_mm[i]] if on_nest else ["", "", ""]
            if several:
                cells.append(str(int(self.station[i])))
            lines.append(",".join(cells))
        return "\n".join(lines) + "\n"


def point_name(point: int) -> str:
    """The name of a planned point in NC programs and tracker jobs: P0001, P0002, ..."""
    return f"P{int(point):04d}"


def read_template(path: str | Path, machine: Machine) -> PlanTemplate:
    """Read a plan's campaign template (x, y, z may be empty or filled; they are ignored)."""
    name = str(path)
    text = read_text_file(path, "no such plan file (the campaign template written by 'vecpin plan')")
    rows = [r for r in csv.reader(text.splitlines())]
    rows = [(i + 1, r) for i, r in enumerate(rows) if any(c.strip() for c in r)]
    if not rows:
        raise CampaignFileError(name, "the plan file is empty")
    header = [h.strip() for h in rows[0][1]]
    for col in ["point"] + machine.axis_names + ["tool"]:
        if col not in header:
            what = "point number" if col == "point" else ("tool length [mm]" if col == "tool" else
                                                          f"axis of machine '{machine.name}'")
            raise CampaignFileError(name, f"missing column ({what}); is this a plan template for "
                                    f"{machine.name}?", row=1, column=col)
    body = rows[1:]
    if not body:
        raise CampaignFileError(name, "the plan has a header but no rows")
    idx = {h: j for j, h in enumerate(header)}
    app_cols = [f"approach_{a}" for a in machine.axis_names]
    has_app = all(c in idx for c in app_cols)
    cols = ["point"] + machine.axis_names + ["tool"] + (app_cols if has_app else [])
    vals = np.empty((len(body), len(cols)))
    for k, (line, cells) in enumerate(body):
        if len(cells) != len(header):
            raise CampaignFileError(name, f"{len(cells)} cells where the header has {len(header)}", row=line)
        for j, c in enumerate(cols):
            s = cells[idx[c]].strip()
            try:
                v = float(s)
            except ValueError:
                raise CampaignFileError(name, f"'{s}' is not a number" if s else "empty cell", row=line, column=c) from None
            if not math.isfinite(v):
                raise CampaignFileError(name, f"'{s}' is not a finite number", row=line, column=c)
            vals[k, j] = v
    lines = np.array([ln for ln, _ in body])
    point = vals[:, 0]
    bad = np.flatnonzero((point != np.round(point)) | (point < 1))
    if bad.size:
        raise CampaignFileError(name, f"point number {point[bad[0]]:g} is not a whole number >= 1",
                                row=int(lines[bad[0]]), column="point")
    _, first, counts = np.unique(point, return_index=True, return_counts=True)
    if np.any(counts > 1):
        dup = point[first[np.argmax(counts > 1)]]
        rows_dup = lines[point == dup]
        raise CampaignFileError(name, f"point {dup:g} appears on rows {', '.join(map(str, rows_dup))}; point numbers "
                                "must be unique", row=int(rows_dup[1]), column="point")
    n = machine.n_axes
    q_user = vals[:, 1:1 + n]
    for j, a in enumerate(machine.axes):
        tol = 1e-6 * (a.upper_user - a.lower_user)
        out = np.flatnonzero((q_user[:, j] < a.lower_user - tol) | (q_user[:, j] > a.upper_user + tol))
        if out.size:
            raise CampaignFileError(name, f"command {q_user[out[0], j]:g} {a.unit} is outside the axis limits "
                                    f"[{a.lower_user:g}, {a.upper_user:g}] {a.unit}", row=int(lines[out[0]]), column=a.name)
    tool = vals[:, 1 + n]
    bad = np.flatnonzero(tool < 0)
    if bad.size:
        raise CampaignFileError(name, f"negative tool length {tool[bad[0]]:g} mm", row=int(lines[bad[0]]), column="tool")
    approach = vals[:, 2 + n:].astype(int) if has_app else None
    instrument, target, nest = _nest_columns(name, idx, body, lines)
    if instrument is not None:
        at = np.maximum.accumulate(np.where(instrument != "nest", np.arange(len(body)), 0))  # the tool row before
        moved = np.flatnonzero((instrument == "nest") & np.any(np.abs(q_user - q_user[at]) > 1e-9, axis=1))
        if moved.size:
            k = moved[0]
            raise CampaignFileError(name, f"nest row {point[k]:g} has another command than the tool-tip row "
                                    f"{point[at[k]]:g} before it: nests are read at that row's dwell, without moving",
                                    row=int(lines[k]), column=machine.axis_names[int(np.argmax(
                                        np.abs(q_user[k] - q_user[at[k]])))])
    return PlanTemplate(point.astype(int), machine.to_si(q_user), tool * M_PER_MM, approach, name, instrument, target,
                        nest, _station_column(name, idx, body, lines))


def _station_column(name: str, idx: dict[str, int], body: list, lines: np.ndarray) -> np.ndarray | None:
    """(N,) the tracker station of every row (whole numbers >= 0, each station's rows in one
    block, station 0 first), or None without a ``station`` column."""
    if "station" not in idx:
        return None
    out = np.zeros(len(body), int)
    for k, (line, cells) in enumerate(body):
        s = cells[idx["station"]].strip() or "0"
        try:
            v = float(s)
        except ValueError:
            v = -1.0
        if not (v == round(v) and 0 <= v <= MAX_ID):
            raise CampaignFileError(name, f"station '{s}': a whole number 0 .. {MAX_ID} (the tracker position the row "
                                    "is read from; 0 the plan's tracker)", row=line, column="station")
        out[k] = int(v)
    change = np.flatnonzero(np.diff(out) != 0) + 1
    if out[0] != 0 or np.any(np.diff(out[np.r_[0, change]]) <= 0):
        k = int(change[np.argmax(np.diff(out[np.r_[0, change]]) <= 0)]) if out[0] == 0 else 0
        raise CampaignFileError(name, f"station {out[k]} here: a plan reads station 0 first, then each further station "
                                "in one block of rows (the tracker moves once between blocks)", row=int(lines[k]),
                                column="station")
    return out


def _nest_columns(name: str, idx: dict[str, int], body: list, lines: np.ndarray):
    """(instrument, target, nest (N,3) [m]) of a template with nest rows, or Nones."""
    if "instrument" not in idx:
        return None, None, None
    n = len(body)
    instrument = np.full(n, "tracker", dtype=object)
    target = np.full(n, "", dtype=object)
    nest = np.full((n, 3), np.nan)
    for k, (line, cells) in enumerate(body):
        kind = cells[idx["instrument"]].strip().lower() or "tracker"
        if kind not in ("tracker", "nest"):
            raise CampaignFileError(name, f"instrument '{kind}': a plan's rows read the tool tip (tracker) or a table "
                                    "nest (nest)", row=line, column="instrument")
        instrument[k] = kind
        if kind != "nest":
            continue
        for c in ("target", "nest_x", "nest_y", "nest_z"):
            if c not in idx:
                raise CampaignFileError(name, f"a nest row needs the column '{c}' (the nest's id and its planned "
                                        "position, mm in the workpiece frame)", row=1, column=c)
        tid = cells[idx["target"]].strip()
        if not tid or any(ch in tid for ch in " ,\"'"):
            raise CampaignFileError(name, "a nest row names its nest in the 'target' column (an id without spaces, "
                                    "commas or quotes)", row=line, column="target")
        target[k] = tid
        for j, c in enumerate(("nest_x", "nest_y", "nest_z")):
            s = cells[idx[c]].strip()
            try:
                v = float(s)
            except ValueError:
                raise CampaignFileError(name, f"'{s}' is not a number (the planned nest position, mm)" if s else
                                        "empty cell: a nest row gives its nest's planned position (mm, workpiece frame)",
                                        row=line, column=c) from None
            if not math.isfinite(v):
                raise CampaignFileError(name, f"'{s}' is not a finite number", row=line, column=c)
            nest[k, j] = v * M_PER_MM
    seen: dict[str, int] = {}
    for k in np.flatnonzero(instrument == "nest"):
        first = seen.setdefault(str(target[k]), int(k))
        if np.any(np.abs(nest[k] - nest[first]) > 1e-9):
            raise CampaignFileError(name, f"nest {target[k]} is planned at two positions (rows {lines[first]} and "
                                    f"{lines[k]}): one nest stays where it is for the whole campaign",
                                    row=int(lines[k]), column="nest_x")
    if instrument[0] == "nest":
        raise CampaignFileError(name, "the first row reads a nest: nests are read at the dwell of a tool-tip row "
                                "before them", row=int(lines[0]), column="instrument")
    return instrument, target, nest
