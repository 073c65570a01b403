"""Checks of a campaign file's header and values: each refusal names the file, the row
(line number, header = 1) and the column, and says what to do (used by
:func:`vecpin.measurement.campaign.read_campaign`)."""
from __future__ import annotations

import math
import warnings

import numpy as np

from vecpin.errors import CampaignFileError, VecpinWarning
from vecpin.kinematics.machine import Machine
from vecpin.units import M_PER_MM

RESERVED = ("tool", "x", "y", "z")
AXIS_LETTERS = set("XYZABCUVW")
TEMPERATURE_RANGE_C = (-20.0, 45.0)  # air temperatures of a workshop in which machines are measured, °C
LIMIT_TOLERANCE = 1e-6  # fraction of the travel a command may exceed a limit by (rounding)
MAX_XYZ_MM = 200_000.0   # no tracker reads a point 200 m away: larger x, y, z are not a measurement
MAX_TOOL_MM = 10_000.0   # nor is a tool 10 m long


def check_header(name: str, header: list[str], machine: Machine, body: str = "") -> None:
    if len(header) == 1 and (";" in header[0] or "\t" in header[0]):
        sep = "semicolons" if ";" in header[0] else "tabs"
        raise CampaignFileError(name, f"the header is one cell with {sep} in it: this file is {sep[:-1]}-separated "
                                "(a tracker export or a spreadsheet in a decimal-comma locale?), but campaign files are "
                                "comma-separated with a decimal point; convert it with vecpin import "
                                f"(Python: vecpin.measurement.importer.import_export) for machine {machine.name}", row=1)
    seen: dict[str, int] = {}
    for j, h in enumerate(header):
        if h == "":
            raise CampaignFileError(name, f"header cell {j + 1} is empty; every column needs a name", row=1)
        if h in seen:
            raise CampaignFileError(name, f"duplicate column name (columns {seen[h] + 1} and {j + 1}): rename or delete "
                                    "one", row=1, column=h)
        seen[h] = j
    axes = machine.axis_names
    joint_names = set(machine.model.names) | fixed_joint_names(machine)
    for h in header:
        if h in axes or h in RESERVED:
            continue
        if h in joint_names or (len(h) == 1 and h in AXIS_LETTERS):
            raise CampaignFileError(name, f"looks like an axis, but machine '{machine.name}' has axes "
                                    f"{', '.join(axes)}: is this file for another machine?", row=1, column=h)
    if header[0].startswith("#") and any(a not in seen for a in axes):
        where = header_line(body, machine)
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


def header_line(body: str, machine: Machine) -> str:
    """' (found on line k)' when a later line of the file is the header, else ''."""
    for k, line in enumerate(body.split("\n", 50)[:50]):
        cells = {c.strip() for c in line.split(",")}
        if set(machine.axis_names) <= cells:
            return f"; the header is line {k + 2}"
    return ""


def fixed_joint_names(machine: Machine) -> set[str]:
    import re
    return set(re.findall(r"<joint\s+name=\"([^\"]+)\"", machine.urdf_xml))


def check_axes(name: str, q_user: np.ndarray, rows: np.ndarray, machine: Machine) -> None:
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


def check_tool(name: str, tool_mm: np.ndarray, rows: np.ndarray) -> None:
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


def check_xyz_range(name: str, xyz_mm: np.ndarray, rows: np.ndarray) -> None:
    """x, y, z of a tracker row lie within a tracker's reach (NaN: no point on the row)."""
    far = np.abs(np.nan_to_num(xyz_mm)) > MAX_XYZ_MM
    if far.any():
        k, j = np.argwhere(far)[0]
        raise CampaignFileError(name, f"{xyz_mm[k, j]:g} mm is no tracker reading (more than {MAX_XYZ_MM * M_PER_MM:g} m "
                                "from the tracker): x, y, z are in mm; fix or delete the row", row=int(rows[k]),
                                column="xyz"[j])


def check_xyz_units(name: str, xyz_mm: np.ndarray, q_user: np.ndarray, machine: Machine) -> None:
    # the slides that move the tool in the base frame (a table's slides move the part, not the tool)
    lin = [j for j, a in enumerate(machine.axes) if a.kind == "linear" and a.side == "head"]
    if not lin or len(xyz_mm) < 10:
        return
    cmd_span = float(np.linalg.norm(np.ptp(q_user[:, lin], axis=0)))
    meas_span = float(np.linalg.norm(np.ptp(xyz_mm, axis=0)))
    if cmd_span > 100.0 and meas_span < cmd_span / 100:
        raise CampaignFileError(name, f"the measured points span {meas_span:g} mm while the commands span {cmd_span:g} mm: "
                                "x, y, z look like metres, but they are in mm", column="x")


def check_extra(name: str, extra: dict[str, np.ndarray], rows: np.ndarray) -> None:
    t = extra.get("time")
    if t is not None:
        back = np.flatnonzero(np.diff(t) < 0)
        if back.size:
            k = back[0] + 1
            restart = (" or the clock restarted (a later session counted from 0 again: time is seconds since the "
                       "campaign's first row; add the earlier sessions' length to its rows)" if t[k] <= t[0] else "")
            raise CampaignFileError(name, f"time goes backwards ({t[k - 1]:g} s then {t[k]:g} s): rows must be in "
                                    f"measurement order{restart}", row=int(rows[k]), column="time")
    T = extra.get("temperature")
    if T is not None:
        bad = np.flatnonzero((T < TEMPERATURE_RANGE_C[0]) | (T > TEMPERATURE_RANGE_C[1]))
        if bad.size:
            v = T[bad[0]]
            hint = (" (kelvin? temperature is in °C)" if v > 200 else
                    f" ({(v - 32) / 1.8:.1f} °C if it is °F: temperature is in °C; convert the column, or import the "
                    "export with `temperature_unit` F)" if 32 <= v <= 130 else "")
            raise CampaignFileError(name, f"temperature {v:g} °C is not a workshop temperature ({TEMPERATURE_RANGE_C[0]:g} "
                                    f".. {TEMPERATURE_RANGE_C[1]:g} °C){hint}", row=int(rows[bad[0]]), column="temperature")


def _repeated_rows(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rows (ascending) that repeat an earlier row in every cell, the first row each one
    repeats) of ``v`` (N, columns) float, bit for bit. Rows are sorted by a 64-bit hash of
    their bits (a million rows: 8 MB keys, not a copy of the table per sort) and every
    match is checked cell by cell; a hash shared by different rows (never seen) falls
    back to sorting the rows themselves."""
    bits = v.view(np.uint64)
    h = np.zeros(len(v), np.uint64)
    for j in range(v.shape[1]):   # an odd multiplier per column, mixed in (wraps modulo 2**64)
        h = (h ^ (bits[:, j] * np.uint64(0x9E3779B97F4A7C15 - 2 * j))) * np.uint64(0xBF58476D1CE4E5B9)
    order = np.argsort(h, kind="stable")
    hs = h[order]
    start = np.r_[True, hs[1:] != hs[:-1]]
    head = order[np.maximum.accumulate(np.where(start, np.arange(len(v)), 0))]
    dup, first = order[~start], head[~start]
    if not np.array_equal(v[dup], v[first]):
        keys = v.view(np.dtype((np.void, v.dtype.itemsize * v.shape[1]))).ravel()
        _, idx, inverse = np.unique(keys, return_index=True, return_inverse=True)
        dup = np.flatnonzero(idx[inverse.ravel()] != np.arange(len(keys)))
        return dup, idx[inverse.ravel()[dup]]
    by_row = np.argsort(dup)
    return dup[by_row], first[by_row]


def warn_duplicates(name: str, values: np.ndarray, rows: np.ndarray) -> None:
    """Warn about rows that repeat an earlier row in every cell: a block pasted twice (a
    real repeat measurement differs in the last digits of x, y, z)."""
    if len(values) < 2:
        return
    v = np.ascontiguousarray(np.nan_to_num(values, nan=np.inf))
    dup, first = _repeated_rows(v)
    if dup.size:
        k = dup[0]
        warnings.warn(VecpinWarning(f"{name}: {dup.size} row(s) repeat an earlier row in every cell (row "
                                    f"{rows[k]} = row {rows[first[0]]}): a block pasted twice? They "
                                    "count as extra measurements; delete the copies unless they are real repeats"),
                      stacklevel=3)


STILL_SHARE = 1e-4   # an axis whose commands span less than this share of its travel did not move


def stood_still(machine: Machine, campaign) -> list:
    """The axes of ``machine`` that stood still in every row of ``campaign`` (their commands
    spanning less than :data:`STILL_SHARE` of the travel); none for an empty campaign."""
    q = np.asarray(campaign.q, float)
    if not len(q):
        return []
    return [a for a in machine.axes if np.ptp(q[:, a.index]) < STILL_SHARE * a.travel]


def still_axes_notes(machine: Machine, campaign) -> list[str]:
    """One note naming the axes that stood still in every row of ``campaign`` (their commands
    spanning less than :data:`STILL_SHARE` of the travel), with where they stood: the campaign
    cannot tell how their errors change, so a model of it knows them at that position only."""
    q = np.asarray(campaign.q, float)
    still = stood_still(machine, campaign)
    if not still:
        return []
    where = ", ".join(f"{a.name} at {a.to_user(q[0, a.index]):g} {a.unit}" for a in still)
    one = len(still) == 1
    its, it = ("its", "it") if one else ("their", "they")
    return [f"{campaign.source}: {'this axis' if one else 'these axes'} did not move in any row ({where}): "
            f"the campaign cannot tell how {its} errors change, so the model holds {its} errors at that position (no "
            f"slope beyond it); measure {'it' if one else 'them'} over {its} travel, or use the model and its tables "
            f"only where {it} stood"]
