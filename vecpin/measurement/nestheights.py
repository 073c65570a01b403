"""The nests' heights above the table's face: the file the operator fills in, the fit reads.

On a machine whose table turns, the tracker sees the table only through the reflectors in
its nests, and the fit finds where they are, not where the table's face is. The height of
each reflector's centre above the face, measured once the nests are placed (a height gauge
on the face: the reflector's top less its radius, or the nest's stated height plus the
radius), lets the fit place the face (:func:`~vecpin.compensation.frame.on_the_table_face`):
the tables then keep the table a part is clamped to. Without it, a tilt of the true face
against the volume stays in what a part sees.

``nest_heights.csv``, one row per nest, mm::

    nest,planned_mm,height_mm
    1,28.18,
    2,43.62,

``nest``: the nest's id as the plan's template names it (its ``target`` on nest rows);
``planned_mm``: where the plan put the reflector centre (for orientation only);
``height_mm``: the measured height above the face, filled in by the operator. A plan on a
machine with table nests writes the file with ``height_mm`` empty; a simulation writes it
filled with the simulated nests' heights. :func:`read_nest_heights` reads a filled file
and names the file, row and column of anything wrong; the fit then checks the ids and the
heights against its nests (:func:`~vecpin.measurement.tableframe.check_nest_heights`).
"""
from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from vecpin.errors import CampaignFileError
from vecpin.measurement.campaign import read_text_file
from vecpin.measurement.tableframe import MAX_NEST_HEIGHT_MM
from vecpin.units import MM_PER_M

NEST_HEIGHTS_FILE = "nest_heights.csv"
COLUMNS = ("nest", "planned_mm", "height_mm")


def nest_heights_csv(nests: dict, measured: bool = False) -> str:
    """The file's text for ``nests`` {id: (3,) [m], workpiece frame: z above the table's face}:
    ``height_mm`` empty for the operator to fill in, or with ``measured`` the nests' own
    heights (a simulation's nests, whose heights are known)."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(COLUMNS)
    for k, p in sorted(nests.items()):
        h = f"{float(p[2]) * MM_PER_M:.2f}"
        w.writerow([k, h, h if measured else ""])
    return out.getvalue()


def read_nest_heights(path: str | Path, nests=None) -> dict[str, float]:
    """{nest id: height [mm] of its reflector centre above the table's face} from a filled
    ``nest_heights.csv``; every problem names the file, row (line, header = 1) and column:
    a missing or repeated id, an empty or non-numeric height, one outside 0 .. 2000 mm or
    below 1 mm (metres typed), fewer than three nests and, with ``nests`` (the campaign's
    nest ids), an id the campaign has no nest for."""
    rows = list(csv.reader(io.StringIO(read_text_file(path, "no such file (the plan writes nest_heights.csv: fill "
                                                              "in height_mm and give it to the fit)"))))
    if not rows or [c.strip() for c in rows[0][:1]] != ["nest"] or "height_mm" not in [c.strip() for c in rows[0]]:
        semi = bool(rows) and ";" in ";".join(rows[0]) and len(rows[0]) == 1   # a spreadsheet's regional setting
        raise CampaignFileError(path, f"the header must name the columns nest and height_mm ({','.join(COLUMNS)})"
                                + ("; this file is separated by ';': save it with commas and decimal points"
                                   if semi else ""), 1)
    col = [c.strip() for c in rows[0]].index("height_mm")
    known = None if nests is None else sorted(str(k) for k in nests)
    out: dict[str, float] = {}
    for line, row in enumerate(rows[1:], start=2):
        if not any(c.strip() for c in row):
            continue
        nest = row[0].strip()
        if not nest:
            raise CampaignFileError(path, "a nest id is missing", line, "nest")
        if nest in out:
            raise CampaignFileError(path, f"nest {nest} is given twice; one height per nest", line, "nest")
        if known is not None and nest not in known:
            raise CampaignFileError(path, f"the campaign has no nest '{nest}' (its nests: "
                                    f"{', '.join(known) or 'none'})", line, "nest")
        out[nest] = _height(path, line, nest, row[col].strip() if col < len(row) else "")
    if len(out) < 3:
        raise CampaignFileError(path, f"heights of {len(out)} nest(s): the table's face needs three or more nests "
                                "not on a line, one row per nest (nest,height_mm)")
    return out


def _height(path, line: int, nest: str, text: str) -> float:
    """The height [mm] in cell ``text`` of nest ``nest`` on file line ``line``, checked."""
    if not text:
        raise CampaignFileError(path, f"no height for nest {nest}: measure its reflector centre above the "
                                "table's face, mm, and write it here", line, "height_mm")
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise CampaignFileError(path, f"'{text}' is not a height in mm", line, "height_mm")
    if not 0.0 <= value <= MAX_NEST_HEIGHT_MM:
        raise CampaignFileError(path, f"{text} mm: the height of nest {nest}'s reflector centre above the table's "
                                f"face is 0 .. {MAX_NEST_HEIGHT_MM:g} mm (e.g. 19.05 for a 1.5-inch sphere in a "
                                "magnetic nest)", line, "height_mm")
    if 0.0 < value < 1.0:   # no reflector's centre sits that close to the face: 19.05 mm typed as 0.01905 m
        raise CampaignFileError(path, f"{text}: a reflector centre {value:g} mm above the table's face: metres? "
                                f"Heights are mm ({value * 1000:g} if it was in metres)", line, "height_mm")
    return value
