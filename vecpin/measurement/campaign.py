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
import io
import math
import re
from pathlib import Path

import numpy as np

from vecpin.errors import CampaignFileError
from vecpin.fileio import write_text
from vecpin.kinematics.machine import Machine
from vecpin.units import MM_PER_M, M_PER_MM
from vecpin.measurement.campaignrows import INSTRUMENTS, Campaign, min_rows
from vecpin.measurement.campaignchecks import (MAX_TOOL_MM, RESERVED, check_axes, check_extra, check_header, check_tool,
                                              check_xyz_range, check_xyz_units, warn_duplicates)

INSTRUMENT_COLUMNS = ("instrument", "station", "r", "pivot")
POINT_COLUMNS = ("target", "tool_point")  # text columns: which point a row measured
PAPER_I_TOOLS_MM = (214.88, 312.86)  # the seed's two tool lengths (Paper I): the default of designs and tables


# ---------------------------------------------------------------------- reading
MAX_ID = 9999            # station and pivot ids are small whole numbers
MAX_TARGET_MM = MAX_TOOL_MM  # a tool target is on the tool: no farther from the tool link than the longest tool
FORMULA = "=+-@"          # first characters of a cell a spreadsheet evaluates: never in an id vecpin copies
CELL_SHOWN = 40          # characters of a bad cell quoted in a message


def read_text_file(path: str | Path, missing: str = "no such file", encoding: str = "utf-8-sig") -> str:
    """The text of a file the user gives (a campaign, a plan template, targets, a
    sign-test reading): a missing file is a CampaignFileError saying ``missing``, an
    undecodable one a CampaignFileError with the byte; a UTF-8 byte-order mark is
    dropped."""
    path = Path(path)
    if not path.is_file():
        raise CampaignFileError(str(path), missing)
    try:
        return path.read_text(encoding=encoding)
    except UnicodeDecodeError as exc:
        raise CampaignFileError(str(path), f"not a UTF-8 text file ({exc.reason} at byte {exc.start})") from None


def read_campaign(path: str | Path, machine: Machine) -> Campaign:
    """Read and validate a campaign CSV for ``machine``; see the module docstring.

    Plain files (one number per cell, no blank lines, no ``instrument`` column) are
    parsed by numpy in one pass; any file the fast parser does not take, or any value it
    finds wrong, is parsed again cell by cell for the message with row and column."""
    name = str(path)
    text = read_text_file(path)
    if not text.strip():
        raise CampaignFileError(name, "the file is empty (expected a header line and one row per measurement)")
    first, _, body_text = text.partition("\n")
    del text   # one copy of the file's text at a time (a million rows: 130 MB each)
    header = [h.strip() for h in _split_header(name, first)]
    check_header(name, header, machine, body_text)
    parsed = _parse_fast(path, header, body_text)
    if parsed is None:
        try:
            parsed = _parse_rows(name, header, body_text)
        except CampaignFileError as exc:
            _refuse_template(exc, header, body_text)
            raise
    values, instrument, rows, texts = parsed
    del body_text
    col = {h: values[:, j] for j, h in enumerate(header)}
    need = min_rows(machine.n_axes)
    if len(rows) < need:
        raise CampaignFileError(name, f"only {len(rows)} rows; a fit of a {machine.n_axes}-axis machine needs at least {need}: "
                                "measure more points")
    q_user = np.column_stack([col[a.name] for a in machine.axes])
    check_axes(name, q_user, rows, machine)
    tool_mm = col["tool"]
    check_tool(name, tool_mm, rows)
    xyz_mm = np.column_stack([col["x"], col["y"], col["z"]])
    trk = instrument == "tracker"
    check_xyz_range(name, xyz_mm, rows)
    if trk.sum() >= 10:
        check_xyz_units(name, xyz_mm[trk], q_user[trk], machine)
    station, radius, pivot = _instrument_columns(name, col, instrument, rows)
    point, target = _point_target_columns(name, texts, rows, instrument, machine)
    extra = {h: col[h] for h in header if h not in RESERVED and h not in machine.axis_names
             and h not in INSTRUMENT_COLUMNS and h not in POINT_COLUMNS}
    check_extra(name, extra, rows)
    codes = [np.unique(a.astype(str), return_inverse=True)[1].ravel() for a in (instrument, *texts.values())]
    warn_duplicates(name, np.column_stack([values, *codes]) if len(codes) > 1 else values, rows)
    return Campaign(machine.axis_names, machine.to_si(q_user), tool_mm * M_PER_MM, xyz_mm * M_PER_MM, extra, name,
                    instrument, station, radius, pivot, rows, point, target, rotary=machine.rotary_mask())


def _refuse_template(exc: CampaignFileError, header: list[str], body: str) -> None:
    """An empty reading cell in a file whose x, y, z cells are all empty: a plan's
    template (commands without readings) was given for a campaign; say so."""
    if exc.column not in ("x", "y", "z") or not exc.reason.startswith("empty cell"):
        return
    cols = [header.index(c) for c in ("x", "y", "z")]
    rows = [r for r in csv.reader(io.StringIO(body)) if any(c.strip() for c in r)]
    if all(len(r) > max(cols) and not any(r[j].strip() for j in cols) for r in rows):
        raise CampaignFileError(exc.path, "no readings: x, y and z are empty on every row, as in a plan's template "
                                "(plan.csv of vecpin plan), which holds the commands to measure; give the campaign "
                                "(the tracker's export joined to the plan by vecpin import)", column="x") from None


def _split_header(name: str, line: str) -> list[str]:
    try:
        return next(csv.reader([line]), [])
    except csv.Error as exc:
        raise CampaignFileError(name, f"the header cannot be split into cells ({exc})", row=1) from None


def _parse_fast(path: Path, header: list[str], body: str):
    """(values (N, columns), instrument (N,), line numbers (N,)) by numpy's parser, or
    None when the file needs the cell-by-cell reader (blank lines, an ``instrument``,
    ``target`` or ``tool_point`` column, empty or non-numeric cells, wrong cell counts, values that are not finite)."""
    blank = re.match(r"[ \t,]*\n", body) or re.search(r"\n[ \t,]*\n(?=\s*\S)", body)   # a blank line before the end
    if not body or body.isspace() or "instrument" in header or any(h in POINT_COLUMNS for h in header) or blank:
        return None
    try:
        values = np.loadtxt(path, delimiter=",", comments=None, skiprows=1, ndmin=2, dtype=float, quotechar='"',
                            encoding="utf-8-sig")
    except (ValueError, IndexError):
        return None
    if values.shape[1] != len(header) or not np.all(np.isfinite(values)):
        return None
    return values, np.full(len(values), "tracker", dtype=object), np.arange(2, len(values) + 2), {}


def _parse_rows(name: str, header: list[str], body: str):
    """The cell-by-cell reader: the first bad cell raises with its row and column."""
    n_max = body.count("\n") + 1
    values = np.empty((n_max, len(header)))
    instrument = np.full(n_max, "tracker", dtype=object)
    rows = np.empty(n_max, int)
    ji = header.index("instrument") if "instrument" in header else None
    optional_by_kind = {"tracker": {"r", "pivot"}, "ballbar": {"x", "y", "z", "station"}, "nest": {"r", "pivot"}}
    text = {j for j, h in enumerate(header) if h in POINT_COLUMNS}
    texts = {header[j]: np.full(n_max, "", dtype=object) for j in text}
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
                raise CampaignFileError(name, f"unknown instrument '{_shown(cells[ji])}' ({', '.join(INSTRUMENTS)})",
                                        row=lineno, column="instrument")
            instrument[k] = kind
        for j, cell in enumerate(cells):
            if j == ji or j in text:
                values[k, j] = np.nan
            elif cell.strip() == "" and header[j] in optional_by_kind[instrument[k]]:
                values[k, j] = np.nan
            else:
                values[k, j] = _parse_cell(name, cell, lineno, header[j])
        for j in text:
            texts[header[j]][k] = cells[j].strip()
        rows[k] = lineno
        k += 1
    if k == 0:
        raise CampaignFileError(name, "the file has a header but no measurement rows")
    return values[:k], instrument[:k], rows[:k], {h: t[:k] for h, t in texts.items()}


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
        radius = np.where(bb, col["r"] * M_PER_MM, np.nan)
        pivot = np.where(bb, np.nan_to_num(col["pivot"], nan=-1), -1).astype(int)
    return station, radius, pivot


def _point_target_columns(name: str, texts: dict, rows: np.ndarray, instrument: np.ndarray, machine: Machine):
    """(point (N,) tool point index, target (N,) id text) from the ``tool_point`` and
    ``target`` columns (``texts``: their cells per row); a nest row must name its nest,
    a tool point is an index or a tool link's name."""
    n = len(rows)
    point, target = np.zeros(n, int), np.full(n, "", dtype=object)
    links = list(machine.tool_links)
    for k, cell in enumerate(texts.get("tool_point", ())):
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
            raise CampaignFileError(name, f"tool point '{_shown(cell)}': a tool point index 0..{len(links) - 1} or a "
                                    f"tool link name ({', '.join(links)})", row=int(rows[k]), column="tool_point")
        point[k] = int(v)
    for k, cell in enumerate(texts.get("target", ())):
        if cell and (not cell.isprintable() or any(c in cell for c in " ,;\"'") or cell[0] in FORMULA):
            raise CampaignFileError(name, f"target '{_shown(cell)}': an id without spaces, commas or quotes, not "
                                    "starting with = + - @ (a spreadsheet would evaluate it)", row=int(rows[k]),
                                    column="target")
        target[k] = cell
    nest = np.flatnonzero(instrument == "nest")
    if nest.size and not machine.has_workpiece:
        raise CampaignFileError(name, f"a nest row measures a reflector on the machine table, but {machine.name} has no "
                                "table (no 'workpiece' link in its URDF): measure the tool instead, or use the URDF "
                                "with the table branch", row=int(rows[nest[0]]), column="instrument")
    missing = np.flatnonzero((instrument == "nest") & (target == ""))
    if missing.size:
        raise CampaignFileError(name, "a nest row names its nest in the 'target' column (the id of the nest on "
                                "the table)", row=int(rows[missing[0]]), column="target")
    return point, target


def read_targets(path: str | Path) -> dict[str, np.ndarray]:
    """Known tool-target offsets from a small CSV ``target,x,y,z`` (mm, in the tool link
    frame: the spindle's or the robot flange's) -> {id: offset (3,) [m]}. Targets a
    campaign names that are not in the file are found by the fit."""
    name = str(path)
    lines = list(csv.reader(read_text_file(path, "no such targets file").splitlines()))
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
        if cells[0][0] in FORMULA or not cells[0].isprintable():
            raise CampaignFileError(name, f"target '{_shown(cells[0])}': an id not starting with = + - @ (a "
                                    "spreadsheet would evaluate it)", row=lineno, column="target")
        mm = np.array([_parse_cell(name, c, lineno, h) for c, h in zip(cells[1:4], "xyz")])
        if np.linalg.norm(mm) > MAX_TARGET_MM:
            raise CampaignFileError(name, f"target '{_shown(cells[0])}' is {np.linalg.norm(mm):g} mm from the tool link "
                                    f"origin; a target on the tool is at most {MAX_TARGET_MM:g} mm from it (offsets are "
                                    "mm)", row=lineno)
        out[cells[0]] = mm * M_PER_MM
    norms = [np.linalg.norm(v) / M_PER_MM for v in out.values()]
    if norms and 0 < max(norms) < 1.0:
        raise CampaignFileError(name, f"every target is less than 1 mm from the tool link origin (largest "
                                f"{max(norms):g}); the offsets are mm (e.g. 0,0,100), not metres", column="x")
    return out


def attach_targets(campaign: "Campaign", targets: dict[str, np.ndarray], path) -> "Campaign":
    """Give ``campaign`` the known offsets of a targets file; every id of the file must be
    a target the campaign measures (ids are case-sensitive), else the file is refused
    naming its unmatched ids. Campaign targets the file lacks are found by the fit."""
    named = sorted({str(t) for t, i in zip(campaign.target, campaign.instrument) if t and i != "nest"})
    unmatched = sorted(set(targets) - set(named))
    if unmatched:
        raise CampaignFileError(path, f"target ids {', '.join(unmatched)} are not measured in {campaign.source} "
                                f"(its targets: {', '.join(named) or 'none'}; ids are case-sensitive)", column="target")
    campaign.targets = dict(targets)
    return campaign


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


# ---------------------------------------------------------------------- writing
def write_campaign(path: str | Path, campaign: Campaign, machine: Machine) -> None:
    """Write a campaign CSV (the text of :func:`campaign_text`: mm, deg)."""
    write_text(path, campaign_text(campaign, machine))


def campaign_text(campaign: Campaign, machine: Machine) -> str:
    """A campaign as the CSV text :func:`read_campaign` reads, the one writer of campaign
    files (simulated and imported alike): the axes [mm, deg; 6 decimals in mm = 1 nm, 8 in
    deg], ``tool`` and the tracker-frame ``x``, ``y``, ``z`` [mm, 6 decimals], the extra
    columns (6 decimals; ``point`` and ``approach_<AXIS>`` as whole numbers when they are),
    then each per-row column a row uses (:func:`_row_columns`). An empty cell is NaN (a
    ball bar row's x, y, z)."""
    if list(campaign.axis_names) != machine.axis_names:
        raise ValueError(f"campaign axes {campaign.axis_names} do not match machine axes {machine.axis_names}")
    q_user = machine.to_user(campaign.q)
    extra = {k: np.asarray(v, float) for k, v in campaign.extra.items()}
    fmts = ["%.6f" if a.kind == "linear" else "%.8f" for a in machine.axes] + ["%.6f"] * 4 + \
        [_extra_format(k, v) for k, v in extra.items()]
    cols = [q_user[:, j] for j in range(machine.n_axes)] + [campaign.tool * MM_PER_M] + \
        [campaign.xyz[:, k] * MM_PER_M for k in range(3)] + list(extra.values())
    row_header, row_cells = _row_columns(campaign, machine)
    cells = [["" if v != v else f % v for v in np.asarray(c, float).tolist()] for f, c in zip(fmts, cols)]  # v != v: NaN
    lines = [",".join(machine.axis_names + ["tool", "x", "y", "z"] + list(extra) + row_header)]
    lines += [",".join((*numbers, *more)) for numbers, more in zip(zip(*cells), row_cells)]
    return "\n".join(lines) + "\n"


def _extra_format(name: str, values: np.ndarray) -> str:
    """The number format of an extra column: a plan's point numbers and approach signs
    (``point``, ``approach_<AXIS>``) as whole numbers when every value is one, else 6
    decimals (time [s], temperature [°C], others)."""
    counted = name == "point" or name.startswith("approach_")
    return "%d" if counted and np.all(np.isfinite(values)) and np.all(values == np.round(values)) else "%.6f"


def _row_columns(campaign: Campaign, machine: Machine) -> tuple[list[str], list[list[str]]]:
    """The per-row text columns of a campaign file, each written only when a row uses it:
    ``instrument`` (a nest or ball bar row), ``target`` (a target or nest id), ``station``
    (a tracker station other than 0; empty on ball bar rows), ``r`` [mm] and ``pivot``
    (ball bar rows; empty elsewhere), ``tool_point`` (a tool point other than the first,
    as its link's name). Returns the header cells and each row's cells."""
    bb = campaign.instrument == "ballbar"
    columns: dict[str, list[str]] = {}
    if np.any(campaign.instrument != "tracker"):
        columns["instrument"] = [str(v) for v in campaign.instrument]
    if np.any(campaign.target != ""):
        columns["target"] = [str(v) for v in campaign.target]
    if np.any(campaign.station[~bb] != 0):
        columns["station"] = ["" if b else str(int(s)) for b, s in zip(bb, campaign.station)]
    if bb.any():
        columns["r"] = [f"{r * MM_PER_M:.6f}" if b else "" for b, r in zip(bb, campaign.radius)]
        columns["pivot"] = [str(int(p)) if b else "" for b, p in zip(bb, campaign.pivot)]
    if np.any(campaign.point != 0):
        columns["tool_point"] = [machine.tool_links[int(p)] for p in campaign.point]
    if not columns:
        return [], [[] for _ in range(len(campaign))]
    return list(columns), [list(cells) for cells in zip(*columns.values())]


def write_targets(path: str | Path, targets: dict) -> None:
    """A targets file (``target,x,y,z`` in mm) for :func:`read_targets`."""
    lines = ["target,x,y,z"] + [f"{k}," + ",".join(f"{v * MM_PER_M:.6f}" for v in np.asarray(o, float))
                                for k, o in targets.items()]
    write_text(path, "\n".join(lines) + "\n")
