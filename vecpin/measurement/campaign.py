"""Measurement campaigns and the interchange CSV.

A campaign file has one row per measured tool-tip position, rows in measurement
order, and these columns (any order):

* one per axis, named exactly as the URDF joint, in mm (linear) or degrees (rotary);
* ``tool``: tool length from the gauge line [mm];
* ``x``, ``y``, ``z``: the measured tool tip in the tracker frame [mm];
* optional ``time`` [s], ``temperature`` [°C] and any other numeric columns, which
  are kept (``Campaign.extra``) for the effects that use them;
* optional ``instrument``: ``tracker`` (default) or ``ballbar``; tracker rows may give
  ``station`` (integer id of the tracker position, default 0); ball bar rows give ``r``
  (the measured radius [mm]) and ``pivot`` (integer id of the ball bar's centre
  socket) and leave ``x``, ``y``, ``z`` empty.

Reading rejects bad input with a :class:`~vecpin.errors.CampaignFileError` naming
the file, the row (line number, header = 1) and the column. In memory a
:class:`Campaign` is SI: ``q`` [m, rad], ``tool`` [m], ``xyz`` [m].
"""
from __future__ import annotations

import csv
import io
import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vecpin.errors import CampaignFileError, VecpinWarning
from vecpin.fileio import write_text
from vecpin.kinematics.machine import Machine

RESERVED = ("tool", "x", "y", "z")
INSTRUMENT_COLUMNS = ("instrument", "station", "r", "pivot")
INSTRUMENTS = ("tracker", "ballbar")
AXIS_LETTERS = set("XYZABCUVW")
TEMPERATURE_RANGE_C = (-20.0, 45.0)  # air temperatures of a workshop in which machines are measured, °C
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
    extra: optional per-row columns (``time`` [s], ``temperature`` [°C], others as read).
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

    def __len__(self) -> int:
        return len(self.tool)

    @property
    def tracker_rows(self) -> np.ndarray:
        return np.flatnonzero(self.instrument == "tracker")

    @property
    def ballbar_rows(self) -> np.ndarray:
        return np.flatnonzero(self.instrument == "ballbar")

    def primary(self) -> "Campaign":
        """The tracker rows of station 0: the rows one tracker pose describes (itself when
        the campaign is not mixed)."""
        if not self.mixed:
            return self
        return self.subset(self.tracker_rows[self.station[self.tracker_rows] == 0])

    @property
    def mixed(self) -> bool:
        """True when the campaign has ball bar rows or several tracker stations."""
        return bool(len(self.ballbar_rows) or len(np.unique(self.station[self.tracker_rows])) > 1)

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
                        self.instrument[rows], self.station[rows], self.radius[rows], self.pivot[rows], self.lines[rows])

    def tool_lengths(self) -> np.ndarray:
        """Distinct tool lengths [m] (sorted)."""
        return np.unique(np.round(self.tool, 9))


# ---------------------------------------------------------------------- reading
MAX_XYZ_MM = 200_000.0   # no tracker reads a point 200 m away: larger x, y, z are not a measurement
MAX_TOOL_MM = 10_000.0   # nor is a tool 10 m long
MAX_ID = 9999            # station and pivot ids are small whole numbers
CELL_SHOWN = 40          # characters of a bad cell quoted in a message


def read_campaign(path: str | Path, machine: Machine) -> Campaign:
    """Read and validate a campaign CSV for ``machine``; see the module docstring.

    Plain files (one number per cell, no blank lines, no ``instrument`` column) are
    parsed by numpy in one pass; any file the fast parser does not take, or any value it
    finds wrong, is parsed again cell by cell for the message with row and column."""
    path = Path(path)
    name = str(path)
    if not path.is_file():
        raise CampaignFileError(name, "no such file")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise CampaignFileError(name, f"not a UTF-8 text file ({exc.reason} at byte {exc.start})") from None
    first, _, body_text = text.partition("\n")
    if not text.strip():
        raise CampaignFileError(name, "the file is empty (expected a header line and one row per measurement)")
    header = [h.strip() for h in _split_header(name, first)]
    _check_header(name, header, machine, body_text)
    parsed = _parse_fast(path, header, body_text)
    if parsed is None:
        parsed = _parse_rows(name, header, body_text)
    values, instrument, rows = parsed
    del text, body_text
    col = {h: values[:, j] for j, h in enumerate(header)}
    need = min_rows(machine.n_axes)
    if len(rows) < need:
        raise CampaignFileError(name, f"only {len(rows)} rows; a fit of a {machine.n_axes}-axis machine needs at least {need}: "
                                "measure more points")
    q_user = np.column_stack([col[a.name] for a in machine.axes])
    _check_axes(name, q_user, rows, machine)
    tool_mm = col["tool"]
    _check_tool(name, tool_mm, rows)
    xyz_mm = np.column_stack([col["x"], col["y"], col["z"]])
    trk = instrument == "tracker"
    _check_xyz_range(name, xyz_mm, rows)
    if trk.sum() >= 10:
        _check_xyz_units(name, xyz_mm[trk], q_user[trk], machine)
    station, radius, pivot = _instrument_columns(name, col, instrument, rows)
    extra = {h: col[h] for h in header if h not in RESERVED and h not in machine.axis_names and h not in INSTRUMENT_COLUMNS}
    _check_extra(name, extra, rows)
    _warn_duplicates(name, values, rows)
    return Campaign(machine.axis_names, machine.to_si(q_user), tool_mm * 1e-3, xyz_mm * 1e-3, extra, name,
                    instrument, station, radius, pivot, rows)


def _split_header(name: str, line: str) -> list[str]:
    try:
        return next(csv.reader([line]), [])
    except csv.Error as exc:
        raise CampaignFileError(name, f"the header cannot be split into cells ({exc})", row=1) from None


def _parse_fast(path: Path, header: list[str], body: str):
    """(values (N, columns), instrument (N,), line numbers (N,)) by numpy's parser, or
    None when the file needs the cell-by-cell reader (blank lines, an ``instrument``
    column, empty or non-numeric cells, wrong cell counts, values that are not finite)."""
    if not body.strip() or "instrument" in header or re.search(r"\n[ \t,]*\n", "\n" + body.rstrip()):
        return None
    try:
        values = np.loadtxt(path, delimiter=",", comments=None, skiprows=1, ndmin=2, dtype=float, quotechar='"',
                            encoding="utf-8-sig")
    except (ValueError, IndexError):
        return None
    if values.shape[1] != len(header) or not np.all(np.isfinite(values)):
        return None
    return values, np.full(len(values), "tracker", dtype=object), np.arange(2, len(values) + 2)


def _parse_rows(name: str, header: list[str], body: str):
    """The cell-by-cell reader: the first bad cell raises with its row and column."""
    n_max = body.count("\n") + 1
    values = np.empty((n_max, len(header)))
    instrument = np.full(n_max, "tracker", dtype=object)
    rows = np.empty(n_max, int)
    ji = header.index("instrument") if "instrument" in header else None
    optional_by_kind = {"tracker": {"r", "pivot"}, "ballbar": {"x", "y", "z", "station"}}
    reader = csv.reader(io.StringIO(body))
    k = 0
    while True:
        try:
            cells = next(reader)
        except StopIteration:
            break
        except csv.Error as exc:
            raise CampaignFileError(name, f"the line cannot be split into cells ({exc}): a cell this long is not a "
                                    "number; is this a campaign file?", row=reader.line_num + 1) from None
        lineno = reader.line_num + 1
        if not any(c.strip() for c in cells):
            continue
        if len(cells) != len(header):
            raise CampaignFileError(name, f"{len(cells)} cells where the header has {len(header)}: fix the row (a comma "
                                    "missing or too many?) or delete it", row=lineno)
        if ji is not None:
            kind = cells[ji].strip().lower() or "tracker"
            if kind not in INSTRUMENTS:
                raise CampaignFileError(name, f"unknown instrument '{_shown(cells[ji])}' (tracker or ballbar)",
                                        row=lineno, column="instrument")
            instrument[k] = kind
        for j, cell in enumerate(cells):
            if j == ji:
                values[k, j] = np.nan
            elif cell.strip() == "" and header[j] in optional_by_kind[instrument[k]]:
                values[k, j] = np.nan
            else:
                values[k, j] = _parse_cell(name, cell, lineno, header[j])
        rows[k] = lineno
        k += 1
    if k == 0:
        raise CampaignFileError(name, "the file has a header but no measurement rows")
    return values[:k], instrument[:k], rows[:k]


def _shown(cell: str) -> str:
    """A cell as quoted in a message: stripped, and cut when it is long."""
    s = cell.strip()
    return s if len(s) <= CELL_SHOWN else f"{s[:CELL_SHOWN]}... ({len(s)} characters)"


def _instrument_columns(name: str, col: dict, instrument: np.ndarray, rows: np.ndarray):
    n = len(instrument)
    bb = instrument == "ballbar"
    station = np.zeros(n, int)
    if "station" in col:
        s = col["station"]
        bad = np.flatnonzero(~bb & ((s != np.round(s)) | (s < 0) | (s > MAX_ID)))
        if bad.size:
            raise CampaignFileError(name, f"station must be a whole number 0 .. {MAX_ID} (an id of the tracker "
                                    f"position), not {s[bad[0]]:g}", row=int(rows[bad[0]]), column="station")
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
        bad = np.flatnonzero(bb & (col["r"] > MAX_TOOL_MM))
        if bad.size:
            raise CampaignFileError(name, f"ball bar radius {col['r'][bad[0]]:g} mm is longer than any ball bar",
                                    row=int(rows[bad[0]]), column="r")
        p = col["pivot"]
        bad = np.flatnonzero(bb & ((p != np.round(p)) | (p < 0) | (p > MAX_ID)))
        if bad.size:
            raise CampaignFileError(name, f"pivot must be a whole number 0 .. {MAX_ID} (an id of the ball bar's "
                                    f"centre socket), not {p[bad[0]]:g}", row=int(rows[bad[0]]), column="pivot")
        radius = np.where(bb, col["r"] * 1e-3, np.nan)
        pivot = np.where(bb, np.nan_to_num(col["pivot"], nan=-1), -1).astype(int)
    return station, radius, pivot


def _check_header(name: str, header: list[str], machine: Machine, body: str = "") -> None:
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
            raise CampaignFileError(name, f"duplicate column name (columns {seen[h] + 1} and {j + 1}): rename or delete "
                                    "one", row=1, column=h)
        seen[h] = j
    axes = machine.axis_names
    joint_names = set(machine.model.names) | _fixed_joint_names(machine)
    for h in header:
        if h in axes or h in RESERVED:
            continue
        if h in joint_names or (len(h) == 1 and h in AXIS_LETTERS):
            raise CampaignFileError(name, f"looks like an axis, but machine '{machine.name}' has axes "
                                    f"{', '.join(axes)}: is this file for another machine?", row=1, column=h)
    if header[0].startswith("#") and any(a not in seen for a in axes):
        where = _header_line(body, machine)
        raise CampaignFileError(name, "line 1 is a comment ('#...'), but a campaign file starts with its header line "
                                f"(the column names){where}: delete the comment lines", row=1)
    for a in axes:
        if a not in seen:
            near = [h for h in header if h.lower() == a.lower() and h not in RESERVED]
            hint = f" (found '{near[0]}': names are case-sensitive)" if near else ""
            raise CampaignFileError(name, f"missing axis column for machine '{machine.name}' "
                                    f"(axes: {', '.join(axes)}){hint}: add the column, or give the machine the "
                                    "file was measured on", row=1, column=a)
    for r in RESERVED:
        if r not in seen:
            what = "tool length [mm] from the gauge line" if r == "tool" else "tracker coordinate [mm]"
            raise CampaignFileError(name, f"missing column: {what}; add it", row=1, column=r)


def _header_line(body: str, machine: Machine) -> str:
    """' (found on line k)' when a later line of the file is the header, else ''."""
    for k, line in enumerate(body.split("\n", 50)[:50]):
        cells = {c.strip() for c in line.split(",")}
        if set(machine.axis_names) <= cells:
            return f"; the header is line {k + 2}"
    return ""


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
        raise CampaignFileError(name, f"'{_shown(s)}' is not a number: every cell of a campaign is a number (mm, deg, "
                                "s, °C); fix the cell, or delete the column if it holds notes", row=lineno,
                                column=column) from None
    if not math.isfinite(v):
        raise CampaignFileError(name, f"'{_shown(s)}' is not a finite number: fill in the measured value or delete "
                                "the row", row=lineno, column=column)
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
                                    f"[{lo:g}, {hi:g}] {a.unit}{more}: a typo, or a file of another machine? Fix "
                                    "or delete the row", row=int(rows[k]), column=a.name)
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
        raise CampaignFileError(name, f"negative tool length {tool_mm[bad[0]]:g} mm: tool lengths are mm from the gauge "
                                "line, >= 0; fix the row", row=int(rows[bad[0]]), column="tool")
    bad = np.flatnonzero(tool_mm > MAX_TOOL_MM)
    if bad.size:
        raise CampaignFileError(name, f"tool length {tool_mm[bad[0]]:g} mm is longer than any tool (> "
                                f"{MAX_TOOL_MM:g} mm): 'tool' is in mm from the gauge line", row=int(rows[bad[0]]),
                                column="tool")
    if np.all(tool_mm < 1.0) and np.any(tool_mm > 0):
        raise CampaignFileError(name, f"all tool lengths are below 1 mm (max {tool_mm.max():g}): they look like metres, "
                                "but 'tool' is in mm", column="tool")


def _check_xyz_range(name: str, xyz_mm: np.ndarray, rows: np.ndarray) -> None:
    """x, y, z of a tracker row lie within a tracker's reach (NaN: no point on the row)."""
    far = np.abs(np.nan_to_num(xyz_mm)) > MAX_XYZ_MM
    if far.any():
        k, j = np.argwhere(far)[0]
        raise CampaignFileError(name, f"{xyz_mm[k, j]:g} mm is no tracker reading (more than {MAX_XYZ_MM / 1e3:g} m "
                                "from the tracker): x, y, z are in mm; fix or delete the row", row=int(rows[k]),
                                column="xyz"[j])


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
        bad = np.flatnonzero((T < TEMPERATURE_RANGE_C[0]) | (T > TEMPERATURE_RANGE_C[1]))
        if bad.size:
            v = T[bad[0]]
            hint = (" (kelvin? temperature is in °C)" if v > 200 else
                    f" ({(v - 32) / 1.8:.1f} °C if it is °F: temperature is in °C; convert the column, or import the "
                    "export with vecpin import --temperature-unit F)" if 32 <= v <= 130 else "")
            raise CampaignFileError(name, f"temperature {v:g} °C is not a workshop temperature ({TEMPERATURE_RANGE_C[0]:g} "
                                    f".. {TEMPERATURE_RANGE_C[1]:g} °C){hint}", row=int(rows[bad[0]]), column="temperature")


def _warn_duplicates(name: str, values: np.ndarray, rows: np.ndarray) -> None:
    """Warn about rows that repeat an earlier row in every cell: a block pasted twice (a
    real repeat measurement differs in the last digits of x, y, z)."""
    if len(values) < 2:
        return
    v = np.ascontiguousarray(np.nan_to_num(values, nan=np.inf))
    keys = v.view(np.dtype((np.void, v.dtype.itemsize * v.shape[1]))).ravel()
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    dup = np.flatnonzero(first[inverse.ravel()] != np.arange(len(keys)))
    if dup.size:
        k = dup[0]
        warnings.warn(VecpinWarning(f"{name}: {dup.size} row(s) repeat an earlier row in every cell (row "
                                    f"{rows[k]} = row {rows[first[inverse.ravel()[k]]]}): a block pasted twice? They "
                                    "count as extra measurements; delete the copies unless they are real repeats"),
                      stacklevel=3)


# ---------------------------------------------------------------------- writing
def write_campaign(path: str | Path, campaign: Campaign, machine: Machine) -> None:
    """Write a campaign CSV (mm, deg; 6 decimals in mm = 1 nm, 8 in deg)."""
    if list(campaign.axis_names) != machine.axis_names:
        raise ValueError(f"campaign axes {campaign.axis_names} do not match machine axes {machine.axis_names}")
    q_user = machine.to_user(campaign.q)
    header = machine.axis_names + ["tool", "x", "y", "z"] + list(campaign.extra)
    fmts = ["%.6f" if a.kind == "linear" else "%.8f" for a in machine.axes] + ["%.6f"] * 4 + ["%.6f"] * len(campaign.extra)
    cols = [q_user[:, j] for j in range(machine.n_axes)] + [campaign.tool * 1e3] + \
        [campaign.xyz[:, k] * 1e3 for k in range(3)] + [np.asarray(v, float) for v in campaign.extra.values()]
    mixed = campaign.mixed
    if mixed:
        header += ["instrument", "station", "r", "pivot"]
    lines = [",".join(header)]
    for i in range(len(campaign)):
        cells = ["" if np.isnan(c[i]) else f % c[i] for f, c in zip(fmts, cols)]
        if mixed:
            bb = campaign.instrument[i] == "ballbar"
            cells += [campaign.instrument[i], "" if bb else str(int(campaign.station[i])),
                      f"{campaign.radius[i] * 1e3:.6f}" if bb else "", str(int(campaign.pivot[i])) if bb else ""]
        lines.append(",".join(cells))
    write_text(path, "\n".join(lines) + "\n")
