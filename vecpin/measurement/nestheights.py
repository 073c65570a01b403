"""The nests' heights above the table's face: the file the operator fills in, the fit reads.

On a machine whose table turns, the tracker sees the table only through the reflectors in
its nests, and the fit finds where they are, not where the table's face is. The height of
each reflector's centre above the face, measured once the nests are placed (a height gauge
on the face: the reflector's top less its radius, or the nest's stated height plus the
radius), lets the fit place the face (:func:`~vecpin.compensation.frame.on_the_table_face`):
the tables then keep the table a part is clamped to, as far as the heights tell it.
Without it, a tilt of the true face against the volume stays in what a part sees.

``nest_heights.csv``, one row per nest, mm::

    nest,planned_mm,height_mm,height_sd_mm
    1,28.18,,0.02
    2,43.62,,0.02

``nest``: the nest's id as the plan's template names it (its ``target`` on nest rows);
``planned_mm``: where the plan put the reflector centre (for orientation only);
``height_mm``: the measured height above the face, filled in by the operator;
``height_sd_mm``: the standard deviation of that reading, mm (optional: a file without the
column, or an empty cell, takes :data:`GAUGE_SD_MM`; 0: exact, a simulation's heights). A
plan on a machine with table nests writes the file with ``height_mm`` empty and the default
standard deviation; a simulation writes it filled with the simulated nests' heights, exact.
:func:`read_nest_heights` reads a filled file and names the file, row and column of anything
wrong; the fit then checks the ids and the heights against its nests (:func:`check_nest_heights`).

The default standard deviation, :data:`GAUGE_SD_MM` = 0.02 mm, is an assumption the user
changes in the file (or with the height): a dial or digital height gauge reads to 0.01 mm
with a stated accuracy of about +-0.03 mm over 300 mm (e.g. Mitutoyo's 192-130); taken as a
bound with no distribution known (GUM 4.3.7: a rectangular one, 0.03 / sqrt(3) = 0.017 mm)
and with the reflector's seating and the face's local flatness (about 0.01 mm), 0.02 mm.
"""
from __future__ import annotations

import csv
import io
import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from vecpin.errors import CampaignFileError, InputError
from vecpin.measurement.campaign import read_text_file
from vecpin.measurement.tableframe import on_a_line
from vecpin.units import M_PER_MM, MM_PER_M

NEST_HEIGHTS_FILE = "nest_heights.csv"
COLUMNS = ("nest", "planned_mm", "height_mm", "height_sd_mm")
MAX_NEST_HEIGHT_MM = 2000.0   # a reflector centre farther above the table face is a unit mistake
GAUGE_SD_MM = 0.02            # a height gauge's reading, 1 sigma [mm] (the module text says where it comes from)
MAX_SD_MM = 5.0               # a reading less certain than this is no gauge's (a unit mistake)
MIN_SD_MM = 1e-4              # a standard deviation above 0 and below this [mm] is metres typed


def nest_heights_csv(nests: dict, measured: bool = False) -> str:
    """The file's text for ``nests`` {id: (3,) [m], workpiece frame: z above the table's face}:
    ``height_mm`` empty for the operator to fill in and the default standard deviation, or with
    ``measured`` the nests' own heights, exact (a simulation's nests, whose heights are known)."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(COLUMNS)
    for k, p in sorted(nests.items()):   # a simulation's heights to 0.1 µm: exact as stated
        h = float(p[2]) * MM_PER_M
        w.writerow([k, f"{h:.2f}", f"{h:.4f}" if measured else "", "0" if measured else f"{GAUGE_SD_MM:g}"])
    return out.getvalue()


def height_reason(text, nest: str) -> tuple[float, str | None]:
    """(value [mm], why it is refused or None) of the height ``text`` (a cell, an option's
    value or a number) of nest ``nest``: the one check of a height, its wording shared by the
    file and the options (each adds where: file, row and column, or the option)."""
    value = number(text)
    if not math.isfinite(value):
        return value, f"'{text}' is not a height in mm"
    if not 0.0 <= value <= MAX_NEST_HEIGHT_MM:
        return value, (f"{text} mm: the height of nest {nest}'s reflector centre above the table's face is 0 .. "
                       f"{MAX_NEST_HEIGHT_MM:g} mm (e.g. 19.05 for a 1.5-inch sphere in a magnetic nest)")
    if 0.0 < value < 1.0:   # no reflector's centre sits that close to the face: 19.05 mm typed as 0.01905 m
        return value, (f"{text}: a reflector centre {value:g} mm above the table's face: metres? Heights are mm "
                       f"({value * 1000:g} if it was in metres)")
    return value, None


def sd_reason(text, nest: str) -> tuple[float, str | None]:
    """(value [mm], why it is refused or None) of the standard deviation ``text`` of nest
    ``nest``'s height reading, as :func:`height_reason`."""
    value = number(text)
    if not math.isfinite(value):
        return value, f"'{text}' is not a standard deviation in mm"
    if not 0.0 <= value <= MAX_SD_MM:
        return value, (f"{text} mm: the standard deviation of nest {nest}'s height reading is 0 .. {MAX_SD_MM:g} mm "
                       f"(a height gauge: about {GAUGE_SD_MM:g}; 0: exact, a simulation's heights)")
    if 0.0 < value < MIN_SD_MM:
        return value, (f"{text}: a standard deviation of {value:g} mm, finer than any height gauge reads: metres? "
                       f"Standard deviations are mm ({value * 1000:g} if it was in metres)")
    return value, None


def number(text) -> float:
    """``text`` (a cell or a setting's value) as a float; NaN when it is no number (a bool is none)."""
    if isinstance(text, bool):
        return math.nan
    try:
        return float(text)
    except (TypeError, ValueError):
        return math.nan


def read_nest_heights(path: str | Path, nests=None) -> dict[str, tuple[float, float]]:
    """{nest id: (height [mm] of its reflector centre above the table's face, its standard
    deviation [mm])} from a filled ``nest_heights.csv`` (without ``height_sd_mm``, or a cell
    empty: :data:`GAUGE_SD_MM`); every problem names the file, row (line, header = 1) and
    column: a missing or repeated id, an empty height, either value refused by
    :func:`height_reason` or :func:`sd_reason`, fewer than three nests and, with ``nests``
    (the campaign's nest ids), an id the campaign has no nest for."""
    rows = list(csv.reader(io.StringIO(read_text_file(path, "no such file (the plan writes nest_heights.csv: fill "
                                                              "in height_mm and give it to the fit)"))))
    head = [c.strip() for c in rows[0]] if rows else []
    if head[:1] != ["nest"] or "height_mm" not in head:
        semi = bool(rows) and ";" in ";".join(rows[0]) and len(rows[0]) == 1   # a spreadsheet's regional setting
        raise CampaignFileError(path, f"the header must name the columns nest and height_mm ({','.join(COLUMNS)}; "
                                "height_sd_mm optional)" + ("; this file is separated by ';': save it with commas "
                                                            "and decimal points" if semi else ""), 1)
    col, sd_col = head.index("height_mm"), head.index("height_sd_mm") if "height_sd_mm" in head else None
    known = None if nests is None else sorted(str(k) for k in nests)
    out: dict[str, tuple[float, float]] = {}
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
        text = row[col].strip() if col < len(row) else ""
        if not text:
            raise CampaignFileError(path, f"no height for nest {nest}: measure its reflector centre above the "
                                    "table's face, mm, and write it here", line, "height_mm")
        height, why = height_reason(text, nest)
        if why:
            raise CampaignFileError(path, why, line, "height_mm")
        sd_text = row[sd_col].strip() if sd_col is not None and sd_col < len(row) else ""
        sd, why = sd_reason(sd_text, nest) if sd_text else (GAUGE_SD_MM, None)
        if why:
            raise CampaignFileError(path, why, line, "height_sd_mm")
        out[nest] = (height, sd)
    if len(out) < 3:
        raise CampaignFileError(path, f"heights of {len(out)} nest(s): the table's face needs three or more nests "
                                "not on a line, one row per nest (nest,height_mm)")
    return out


def _split(value) -> tuple[object, object]:
    """(height, standard deviation or None) of one given value: a height [mm] or (height, sd) [mm]."""
    if isinstance(value, (tuple, list)) and len(value) == 2:
        return value[0], value[1]
    return value, None


def check_nest_heights(heights_mm: dict, nests: dict, option: str = "nest_heights") -> dict:
    """{nest id: height [m]} from ``heights_mm`` {id: mm, or (mm, standard deviation mm)}: each
    nest's reflector centre above the table face, for the nests of a fit (``nests`` {id: (3,)
    [m]}, None before the fit). Refused, naming ``option``: an id the fit has no nest for, a
    height or a standard deviation :func:`height_reason` or :func:`sd_reason` refuses, fewer
    than three nests, nests on a line (no plane)."""
    out = {}
    for k, v in heights_mm.items():
        k = str(k)
        if k not in nests:
            raise InputError(f"`{option}` {k}: the campaign has no nest '{k}' (its nests: "
                             f"{', '.join(sorted(nests)) or 'none'})")
        h, sd = _split(v)
        value, why = height_reason(h, k)
        why = why or (sd_reason(sd, k)[1] if sd is not None else None)
        if why:
            raise InputError(f"`{option}` {k}: {why}")
        out[k] = value * M_PER_MM
    found = all(nests[k] is not None for k in out)   # before the fit no nest is found: no line to judge
    if out and (len(out) < 3 or found and on_a_line(np.array([nests[k] for k in out]))):
        raise InputError(f"`{option}`: heights of {len(out)} nest(s) ({', '.join(sorted(out))}); the table's face "
                         "needs three or more nests not on a line")
    return out


def nest_height_sds(heights_mm: dict) -> dict:
    """{nest id: standard deviation [m] of its height reading} of checked ``heights_mm``
    (:func:`check_nest_heights`): the one given, else :data:`GAUGE_SD_MM`."""
    out = {}
    for k, v in heights_mm.items():
        sd = _split(v)[1]
        out[str(k)] = (GAUGE_SD_MM if sd is None else float(sd)) * M_PER_MM
    return out


def campaign_nest_ids(campaign) -> dict:
    """The campaign's nest ids (its nest rows' targets), as :func:`check_nest_heights` takes
    them before a fit (no nest found yet: {id: None})."""
    return dict.fromkeys(str(t) for t in campaign.target[campaign.nest_rows])


def check_heights_before_fit(heights_mm: dict | None, campaign, option: str = "nest_heights") -> None:
    """The nests' heights checked against ``campaign``'s nests before any fit (ids and values,
    naming ``option``); the nests' line is judged after it (:func:`with_nest_heights`)."""
    if heights_mm:
        check_nest_heights(heights_mm, campaign_nest_ids(campaign), option)


def with_nest_heights(setup, heights_mm: dict | None, option: str = "nest_heights"):
    """``setup`` (a fitted model's) carrying ``heights_mm`` {id: mm, or (mm, sd mm)}, checked
    against its fitted nests: ``nest_heights`` and ``nest_height_sd`` [m]."""
    if not heights_mm:
        return setup
    return replace(setup, nest_heights=check_nest_heights(heights_mm, setup.nests, option),
                   nest_height_sd=nest_height_sds(heights_mm))
