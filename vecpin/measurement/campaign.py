"""Measurement campaigns and the interchange CSV.

A campaign file has one row per measured tool-tip position, rows in measurement
order, and these columns (any order):

* one per axis, named exactly as the URDF joint, in mm (linear) or degrees (rotary);
* ``tool``: tool length from the gauge line [mm];
* ``x``, ``y``, ``z``: the measured tool tip in the tracker frame [mm];
* optional ``time`` [s], ``temperature`` [°C] and any other numeric columns, which
  are kept (``Campaign.extra``) for the effects that use them;
* optional ``instrument``: ``tracker`` (default), ``nest`` or ``ballbar``; tracker and
  nest rows may give ``station`` (integer id of the tracker position, default 0); ball
  bar rows give ``r`` (the measured radius [mm]) and ``pivot`` (integer id of the ball
  bar's centre socket) and leave ``x``, ``y``, ``z`` empty;
* optional ``target``: on a ``tracker`` row the id of the reflector on the tool (empty:
  the tool tip, ``tool`` mm along the tool axis); its offset [mm] in the tool link frame
  is known from a targets file (:func:`read_targets`) or found by the fit. On a ``nest``
  row (a reflector in a nest fixed on the machine table) the nest's id; its position
  in the workpiece frame is found by the fit;
* optional ``tool_point``: the tool point measured (its index 0, 1, ... or its link
  name, e.g. ``spindle_2``), for machines with several tool points driven by one command
  set (``point``, as planned campaigns use it, is the plan's point number: kept as data).

Reading rejects bad input with a :class:`~vecpin.errors.CampaignFileError` naming
the file, the row (line number, header = 1) and the column. In memory a
:class:`Campaign` is SI: ``q`` [m, rad], ``tool`` [m], ``xyz`` [m].
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vecpin.errors import CampaignFileError
from vecpin.fileio import write_text
from vecpin.kinematics.machine import Machine
from vecpin.units import MM_PER_M, M_PER_MM

RESERVED = ("tool", "x", "y", "z")
INSTRUMENT_COLUMNS = ("instrument", "station", "r", "pivot")
POINT_COLUMNS = ("target", "tool_point")  # text columns: which point a row measured
INSTRUMENTS = ("tracker", "ballbar", "nest")
AXIS_LETTERS = set("XYZABCUVW")
PAPER_I_TOOLS_MM = (214.88, 312.86)  # the seed's two tool lengths (Paper I): the default of designs and tables
LIMIT_TOLERANCE = 1e-6  # fraction of the travel a command may exceed a limit by (rounding)


def min_rows(n_axes: int) -> int:
    """Fewest rows any fit could use: the smallest model (a constant offset per axis,
    the gauge line and the 6 tracker-frame corrections) has n + 7 unknowns and each
    row gives 3 equations; one more row leaves a residual to judge the fit by."""
    return math.ceil((n_axes + 7) / 3) + 1


@dataclass
class Campaign:
    """Measured tool tips of one machine, rows in measurement order (SI units).

    q: (N, n) axis commands [m, rad], chain order of ``axis_names``;
    tool: (N,) tool lengths [m]; xyz: (N, 3) tracker-frame positions [m];
    extra: optional per-row columns (``time`` [s], ``temperature`` [°C], others as read);
    point: (N,) tool point index; target: (N,) target or nest id ("" = the tool tip);
    targets: known tool-target offsets {id: (3,) [m] in the tool link frame}.
    """

    axis_names: list[str]
    q: np.ndarray
    tool: np.ndarray
    xyz: np.ndarray
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    source: str = "<memory>"
    instrument: np.ndarray | None = None   # (N,) "tracker" / "ballbar"; None: all tracker
    station: np.ndarray | None = None      # (N,) tracker position id
    radius: np.ndarray | None = None       # (N,) ball bar radius [m] (NaN on tracker rows)
    pivot: np.ndarray | None = None        # (N,) ball bar pivot id (-1 on tracker rows)
    lines: np.ndarray | None = None        # (N,) line number of each row in its file (header = 1)
    point: np.ndarray | None = None        # (N,) tool point index (0: the first tool link)
    target: np.ndarray | None = None       # (N,) target id on tracker rows, nest id on nest rows ("" = none)
    targets: dict = field(default_factory=dict)  # known tool-target offsets {id: (3,) [m], tool link frame}

    def __post_init__(self):
        n = len(self.tool)
        if self.instrument is None:
            self.instrument = np.full(n, "tracker", dtype=object)
        if self.station is None:
            self.station = np.zeros(n, int)
        if self.radius is None:
            self.radius = np.full(n, np.nan)
        if self.pivot is None:
            self.pivot = np.full(n, -1, int)
        if self.lines is None:
            self.lines = np.arange(2, n + 2)
        if self.point is None:
            self.point = np.zeros(n, int)
        if self.target is None:
            self.target = np.full(n, "", dtype=object)

    def __len__(self) -> int:
        return len(self.tool)

    @property
    def tracker_rows(self) -> np.ndarray:
        return np.flatnonzero(self.instrument == "tracker")

    @property
    def ballbar_rows(self) -> np.ndarray:
        return np.flatnonzero(self.instrument == "ballbar")

    @property
    def nest_rows(self) -> np.ndarray:
        """Rows measuring a reflector in a table nest (tracker readings of a workpiece point)."""
        return np.flatnonzero(self.instrument == "nest")

    @property
    def plain(self) -> bool:
        """True when every row is a tool tip (no nest, no target, tool point 0): the
        rows the nominal tool tip alone predicts."""
        return not (len(self.nest_rows) or np.any(self.point != 0) or np.any(self.target != ""))

    def primary(self) -> "Campaign":
        """The tracker rows of station 0: the rows one tracker pose describes (itself when
        the campaign is not mixed)."""
        if not self.mixed:
            return self
        return self.subset(self.tracker_rows[self.station[self.tracker_rows] == 0])

    @property
    def mixed(self) -> bool:
        """True when the campaign has ball bar rows or several tracker stations."""
        return bool(len(self.ballbar_rows) or len(self.nest_rows)
                    or len(np.unique(self.station[self.tracker_rows])) > 1)

    @property
    def time(self) -> np.ndarray | None:
        return self.extra.get("time")

    @property
    def temperature(self) -> np.ndarray | None:
        return self.extra.get("temperature")

    def subset(self, rows) -> "Campaign":
        """A campaign of the given rows (index array or boolean mask), order kept."""
        rows = np.asarray(rows)
        return Campaign(list(self.axis_names), self.q[rows], self.tool[rows], self.xyz[rows],
                        {k: v[rows] for k, v in self.extra.items()}, self.source,
                        self.instrument[rows], self.station[rows], self.radius[rows], self.pivot[rows], self.lines[rows],
                        self.point[rows], self.target[rows], dict(self.targets))

    def tool_lengths(self) -> np.ndarray:
        """Distinct tool lengths [m] (sorted)."""
        return np.unique(np.round(self.tool, 9))


# ---------------------------------------------------------------------- reading
def read_campaign(path: str | Path, machine: Machine) -> Campaign:
    """Read and validate a campaign CSV for ``machine``; see the module docstring."""
    path = Path(path)
    name = str(path)
    if not path.is_file():
        raise CampaignFileError(name, "no such file")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise CampaignFileError(name, f"not a UTF-8 text file ({exc.reason} at byte {exc.start})") from None
    lines = [ln for ln in csv.reader(text.splitlines())]
    if not lines or all(not any(c.strip() for c in ln) for ln in lines):
        raise CampaignFileError(name, "the file is empty (expected a header line and one row per measurement)")
    header = [h.strip() for h in lines[0]]
    _check_header(name, header, machine)
    body = [(i + 2, ln) for i, ln in enumerate(lines[1:]) if any(c.strip() for c in ln)]
    if not body:
        raise CampaignFileError(name, "the file has a header but no measurement rows")
    values = np.empty((len(body), len(header)))
    ji = header.index("instrument") if "instrument" in header else None
    instrument = np.full(len(body), "tracker", dtype=object)
    optional_by_kind = {"tracker": {"r", "pivot"}, "ballbar": {"x", "y", "z", "station"}, "nest": {"r", "pivot"}}
    text = {j for j, h in enumerate(header) if h in POINT_COLUMNS}
    for k, (lineno, cells) in enumerate(body):
        if len(cells) != len(header):
            raise CampaignFileError(name, f"{len(cells)} cells where the header has {len(header)}", row=lineno)
        if ji is not None:
            kind = cells[ji].strip().lower() or "tracker"
            if kind not in INSTRUMENTS:
                raise CampaignFileError(name, f"unknown instrument '{cells[ji].strip()}' ({', '.join(INSTRUMENTS)})",
                                        row=lineno, column="instrument")
            instrument[k] = kind
        for j, cell in enumerate(cells):
            if j == ji or j in text:
                values[k, j] = np.nan
            elif cell.strip() == "" and header[j] in optional_by_kind[instrument[k]]:
                values[k, j] = np.nan
            else:
                values[k, j] = _parse_cell(name, cell, lineno, header[j])
    rows = np.array([ln for ln, _ in body])
    col = {h: values[:, j] for j, h in enumerate(header)}
    need = min_rows(machine.n_axes)
    if len(body) < need:
        raise CampaignFileError(name, f"only {len(body)} rows; a fit of a {machine.n_axes}-axis machine needs at least {need}")
    q_user = np.column_stack([col[a.name] for a in machine.axes])
    _check_axes(name, q_user, rows, machine)
    tool_mm = col["tool"]
    _check_tool(name, tool_mm, rows)
    xyz_mm = np.column_stack([col["x"], col["y"], col["z"]])
    trk = instrument == "tracker"
    if trk.sum() >= 10:
        _check_xyz_units(name, xyz_mm[trk], q_user[trk], machine)
    station, radius, pivot = _instrument_columns(name, col, instrument, rows)
    point, target = _point_target_columns(name, header, body, instrument, machine)
    extra = {h: col[h] for h in header if h not in RESERVED and h not in machine.axis_names
             and h not in INSTRUMENT_COLUMNS and h not in POINT_COLUMNS}
    _check_extra(name, extra, rows)
    return Campaign(machine.axis_names, machine.to_si(q_user), tool_mm * M_PER_MM, xyz_mm * M_PER_MM, extra, name,
                    instrument, station, radius, pivot, rows, point, target)


def _instrument_columns(name: str, col: dict, instrument: np.ndarray, rows: np.ndarray):
    n = len(instrument)
    bb = instrument == "ballbar"
    station = np.zeros(n, int)
    if "station" in col:
        s = col["station"]
        bad = np.flatnonzero(~bb & ((s != np.round(s)) | (s < 0)))
        if bad.size:
            raise CampaignFileError(name, f"station must be a whole number >= 0, not {s[bad[0]]:g}",
                                    row=int(rows[bad[0]]), column="station")
        station = np.where(bb, 0, np.nan_to_num(s)).astype(int)
    radius, pivot = np.full(n, np.nan), np.full(n, -1, int)
    if bb.any():
        for c in ("r", "pivot"):
            if c not in col:
                raise CampaignFileError(name, f"ball bar rows need a '{c}' column", row=1, column=c)
        bad = np.flatnonzero(bb & (col["r"] <= 1.0))
        if bad.size:
            raise CampaignFileError(name, f"ball bar radius {col['r'][bad[0]]:g} mm: expected mm (radius > 1 mm)",
                                    row=int(rows[bad[0]]), column="r")
        radius = np.where(bb, col["r"] * M_PER_MM, np.nan)
        pivot = np.where(bb, np.nan_to_num(col["pivot"], nan=-1), -1).astype(int)
    return station, radius, pivot


def _point_target_columns(name: str, header: list[str], body: list, instrument: np.ndarray, machine: Machine):
    """(point (N,) tool point index, target (N,) id text) from the ``tool_point`` and
    ``target`` columns; a nest row must name its nest, a tool point is an index or a tool
    link's name."""
    n = len(body)
    point, target = np.zeros(n, int), np.full(n, "", dtype=object)
    links = list(machine.tool_links)
    if "tool_point" in header:
        j = header.index("tool_point")
        for k, (lineno, cells) in enumerate(body):
            cell = cells[j].strip()
            if cell == "":
                continue
            if cell in links:
                point[k] = links.index(cell)
                continue
            try:
                v = float(cell)
            except ValueError:
                v = math.nan
            if not (v == int(v) if math.isfinite(v) else False) or not 0 <= v < len(links):
                raise CampaignFileError(name, f"tool point '{cell}': a tool point index 0..{len(links) - 1} or a tool "
                                        f"link name ({', '.join(links)})", row=lineno, column="tool_point")
            point[k] = int(v)
    if "target" in header:
        j = header.index("target")
        for k, (lineno, cells) in enumerate(body):
            cell = cells[j].strip()
            if cell and (not cell.isprintable() or any(c in cell for c in " ,;\"'")):
                raise CampaignFileError(name, f"target '{cell}': an id without spaces, commas or quotes", row=lineno,
                                        column="target")
            target[k] = cell
    missing = np.flatnonzero((instrument == "nest") & (target == ""))
    if missing.size:
        lineno = body[missing[0]][0]
        raise CampaignFileError(name, "a nest row names its nest in the 'target' column (the id of the nest on "
                                "the table)", row=lineno, column="target")
    return point, target


def read_targets(path: str | Path) -> dict[str, np.ndarray]:
    """Known tool-target offsets from a small CSV ``target,x,y,z`` (mm, in the tool link
    frame: the spindle's or the robot flange's) -> {id: offset (3,) [m]}. Targets a
    campaign names that are not in the file are found by the fit."""
    path = Path(path)
    name = str(path)
    if not path.is_file():
        raise CampaignFileError(name, "no such targets file")
    try:
        lines = list(csv.reader(path.read_text(encoding="utf-8-sig").splitlines()))
    except UnicodeDecodeError as exc:
        raise CampaignFileError(name, f"not a UTF-8 text file ({exc.reason} at byte {exc.start})") from None
    rows = [(i + 1, [c.strip() for c in ln]) for i, ln in enumerate(lines) if any(c.strip() for c in ln)]
    if not rows or rows[0][1][:4] != ["target", "x", "y", "z"]:
        raise CampaignFileError(name, "a targets file starts with the header 'target,x,y,z' (offsets in mm in the "
                                "tool link frame)", row=1)
    out: dict[str, np.ndarray] = {}
    for lineno, cells in rows[1:]:
        if len(cells) < 4 or not cells[0]:
            raise CampaignFileError(name, "a row is: target id, x, y, z [mm]", row=lineno)
        if cells[0] in out:
            raise CampaignFileError(name, f"target '{cells[0]}' is given twice", row=lineno, column="target")
        out[cells[0]] = np.array([_parse_cell(name, c, lineno, h) for c, h in zip(cells[1:4], "xyz")]) * M_PER_MM
    return out


def _check_header(name: str, header: list[str], machine: Machine) -> None:
    if len(header) == 1 and (";" in header[0] or "\t" in header[0]):
        sep = "semicolons" if ";" in header[0] else "tabs"
        raise CampaignFileError(name, f"the header is one cell with {sep} in it: this file is {sep[:-1]}-separated "
                                "(a tracker export or a spreadsheet in a decimal-comma locale?), but campaign files are "
                                "comma-separated with a decimal point; convert it with 'vecpin import "
                                f"{name} --machine {machine.name} [--plan PLAN.csv] --out campaign.csv'", row=1)
    seen: dict[str, int] = {}
    for j, h in enumerate(header):
        if h == "":
            raise CampaignFileError(name, f"header cell {j + 1} is empty; every column needs a name", row=1)
        if h in seen:
            raise CampaignFileError(name, f"duplicate column name (columns {seen[h] + 1} and {j + 1})", row=1, column=h)
        seen[h] = j
    axes = machine.axis_names
    joint_names = set(machine.model.names) | _fixed_joint_names(machine)
    for h in header:
        if h in axes or h in RESERVED:
            continue
        if h in joint_names or (len(h) == 1 and h in AXIS_LETTERS):
            raise CampaignFileError(name, f"looks like an axis, but machine '{machine.name}' has axes "
                                    f"{', '.join(axes)}: is this file for another machine?", row=1, column=h)
    for a in axes:
        if a not in seen:
            near = [h for h in header if h.lower() == a.lower() and h not in RESERVED]
            hint = f" (found '{near[0]}': names are case-sensitive)" if near else ""
            raise CampaignFileError(name, f"missing axis column for machine '{machine.name}' "
                                    f"(axes: {', '.join(axes)}){hint}", row=1, column=a)
    for r in RESERVED:
        if r not in seen:
            what = "tool length [mm] from the gauge line" if r == "tool" else "tracker coordinate [mm]"
            raise CampaignFileError(name, f"missing column: {what}", row=1, column=r)


def _fixed_joint_names(machine: Machine) -> set[str]:
    import re
    return set(re.findall(r"<joint\s+name=\"([^\"]+)\"", machine.urdf_xml))


def _parse_cell(name: str, cell: str, lineno: int, column: str) -> float:
    s = cell.strip()
    if s == "":
        raise CampaignFileError(name, "empty cell (no value is guessed: fill it or delete the row)", row=lineno, column=column)
    try:
        v = float(s)
    except ValueError:
        raise CampaignFileError(name, f"'{s}' is not a number", row=lineno, column=column) from None
    if not math.isfinite(v):
        raise CampaignFileError(name, f"'{s}' is not a finite number", row=lineno, column=column)
    return v


def _check_axes(name: str, q_user: np.ndarray, rows: np.ndarray, machine: Machine) -> None:
    for j, a in enumerate(machine.axes):
        v = q_user[:, j]
        lo, hi = a.lower_user, a.upper_user
        tol = LIMIT_TOLERANCE * (hi - lo)
        bad = np.flatnonzero((v < lo - tol) | (v > hi + tol))
        if bad.size:
            k = bad[0]
            more = f" ({bad.size - 1} more rows too)" if bad.size > 1 else ""
            raise CampaignFileError(name, f"command {v[k]:g} {a.unit} is outside the axis limits "
                                    f"[{lo:g}, {hi:g}] {a.unit}{more}", row=int(rows[k]), column=a.name)
        span = float(v.max() - v.min())
        if len(v) >= 10 and span > 0:
            if a.kind == "linear" and (hi - lo) >= 50.0:
                # metres where mm are expected: the whole column fits inside the limits / 1000
                if span <= (hi - lo) / 200 and np.all(np.abs(v) <= max(abs(lo), abs(hi)) / 1000 * 1.001 + 1e-9):
                    raise CampaignFileError(name, f"values span only {span:g} mm of a {hi - lo:g} mm travel: "
                                            "they look like metres, but axis columns are in mm", column=a.name)
            if a.kind == "rotary" and (hi - lo) >= 20.0:
                if span <= math.radians(hi - lo) * 1.001 and np.all(np.abs(v) <= math.radians(max(abs(lo), abs(hi))) * 1.001):
                    raise CampaignFileError(name, f"values span only {span:g} deg of a {hi - lo:g} deg travel: "
                                            "they look like radians, but rotary axis columns are in degrees", column=a.name)


def _check_tool(name: str, tool_mm: np.ndarray, rows: np.ndarray) -> None:
    bad = np.flatnonzero(tool_mm < 0)
    if bad.size:
        raise CampaignFileError(name, f"negative tool length {tool_mm[bad[0]]:g} mm", row=int(rows[bad[0]]), column="tool")
    if np.all(tool_mm < 1.0) and np.any(tool_mm > 0):
        raise CampaignFileError(name, f"all tool lengths are below 1 mm (max {tool_mm.max():g}): they look like metres, "
                                "but 'tool' is in mm", column="tool")


def _check_xyz_units(name: str, xyz_mm: np.ndarray, q_user: np.ndarray, machine: Machine) -> None:
    lin = [j for j, a in enumerate(machine.axes) if a.kind == "linear"]
    if not lin or len(xyz_mm) < 10:
        return
    cmd_span = float(np.linalg.norm(np.ptp(q_user[:, lin], axis=0)))
    meas_span = float(np.linalg.norm(np.ptp(xyz_mm, axis=0)))
    if cmd_span > 100.0 and meas_span < cmd_span / 100:
        raise CampaignFileError(name, f"the measured points span {meas_span:g} mm while the commands span {cmd_span:g} mm: "
                                "x, y, z look like metres, but they are in mm", column="x")


def _check_extra(name: str, extra: dict[str, np.ndarray], rows: np.ndarray) -> None:
    t = extra.get("time")
    if t is not None:
        back = np.flatnonzero(np.diff(t) < 0)
        if back.size:
            k = back[0] + 1
            raise CampaignFileError(name, f"time goes backwards ({t[k - 1]:g} s then {t[k]:g} s): rows must be in "
                                    "measurement order", row=int(rows[k]), column="time")
    T = extra.get("temperature")
    if T is not None:
        bad = np.flatnonzero((T < -50) | (T > 100))
        if bad.size:
            hint = " (kelvin? temperature is in °C)" if T[bad[0]] > 200 else ""
            raise CampaignFileError(name, f"temperature {T[bad[0]]:g} °C is not a workshop temperature{hint}",
                                    row=int(rows[bad[0]]), column="temperature")


# ---------------------------------------------------------------------- writing
def write_campaign(path: str | Path, campaign: Campaign, machine: Machine) -> None:
    """Write a campaign CSV (mm, deg; 6 decimals in mm = 1 nm, 8 in deg)."""
    if list(campaign.axis_names) != machine.axis_names:
        raise ValueError(f"campaign axes {campaign.axis_names} do not match machine axes {machine.axis_names}")
    q_user = machine.to_user(campaign.q)
    header = machine.axis_names + ["tool", "x", "y", "z"] + list(campaign.extra)
    fmts = ["%.6f" if a.kind == "linear" else "%.8f" for a in machine.axes] + ["%.6f"] * 4 + ["%.6f"] * len(campaign.extra)
    cols = [q_user[:, j] for j in range(machine.n_axes)] + [campaign.tool * MM_PER_M] + \
        [campaign.xyz[:, k] * MM_PER_M for k in range(3)] + [np.asarray(v, float) for v in campaign.extra.values()]
    mixed = campaign.mixed
    if mixed:
        header += ["instrument", "station", "r", "pivot"]
    point_header, point_cells = _point_target_cells(campaign, machine)
    header += point_header
    lines = [",".join(header)]
    for i in range(len(campaign)):
        cells = ["" if np.isnan(c[i]) else f % c[i] for f, c in zip(fmts, cols)]
        if mixed:
            bb = campaign.instrument[i] == "ballbar"
            cells += [campaign.instrument[i], "" if bb else str(int(campaign.station[i])),
                      f"{campaign.radius[i] * MM_PER_M:.6f}" if bb else "", str(int(campaign.pivot[i])) if bb else ""]
        lines.append(",".join(cells + point_cells[i]))
    write_text(path, "\n".join(lines) + "\n")


def _point_target_cells(campaign: Campaign, machine: Machine) -> tuple[list[str], list[list[str]]]:
    """The ``target`` and ``tool_point`` columns of a campaign file (only when used):
    header cells and per-row cells (the tool point as its link's name)."""
    header = []
    use_target = bool(np.any(campaign.target != ""))
    use_point = bool(np.any(campaign.point != 0))
    if use_target:
        header.append("target")
    if use_point:
        header.append("tool_point")
    rows = []
    for i in range(len(campaign)):
        cells = []
        if use_target:
            cells.append(str(campaign.target[i]))
        if use_point:
            cells.append(machine.tool_links[int(campaign.point[i])])
        rows.append(cells)
    return header, rows


def write_targets(path: str | Path, targets: dict) -> None:
    """A targets file (``target,x,y,z`` in mm) for :func:`read_targets`."""
    lines = ["target,x,y,z"] + [f"{k}," + ",".join(f"{v * MM_PER_M:.6f}" for v in np.asarray(o, float))
                                for k, o in targets.items()]
    write_text(path, "\n".join(lines) + "\n")
