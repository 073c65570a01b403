"""Reading a tracker-software export: delimiter, decimal comma, header and column names,
numbers; the words export headers use for coordinates, point names, units and times.
:mod:`vecpin.measurement.importer` turns the table into a campaign."""
from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from vecpin.errors import CampaignFileError, InputError
from vecpin.kinematics.machine import Machine

LENGTH_UNITS = {"mm": 1.0, "in": 25.4, "m": 1000.0}   # mm per unit
UNIT_NAMES = {"mm": "millimetres", "in": "inches", "m": "metres"}
COMMENT_PREFIXES = ("#", "//", "!")
MEAS_WORDS = {"meas", "measured", "measurement", "actual", "act", "value", "val", "pos", "position", "coord",
              "coordinate", "coordinates", "point", "pt", "smr", "target", "tip"}
EXCLUDE_WORDS = {"nom", "nominal", "dev", "deviation", "delta", "d", "err", "error", "tol", "tolerance", "offset",
                 "diff", "design", "cad", "sigma", "std", "unc", "uncertainty", "rms", "ref", "reference"}
POINT_HEADERS = [["point"], ["point", "name"], ["name"], ["id"], ["point", "id"], ["label"], ["pt"], ["pt", "name"],
                 ["point", "number"], ["point", "no"], ["target"], ["target", "name"], ["feature"], ["no"], ["nr"],
                 ["punkt"], ["punktname"], ["punktnummer"], ["punktnr"], ["punkt", "nr"], ["bezeichnung"]]  # German
TIME_WORDS = {"time", "timestamp", "datetime", "date", "zeit", "uhrzeit", "zeitstempel", "datum"}
DATE_ONLY = ({"date"}, {"datum"}, {"day"})   # a column of dates beside a column of times of day
UNIT_TOKENS = {"mm", "millimeter", "millimeters", "millimetre", "millimetres", "in", "inch", "inches", "m", "meter",
               "meters", "metre", "metres", "c", "degc", "celsius", "f", "degf", "fahrenheit", "k", "kelvin", "s", "sec",
               "ms", "min", "h", "hr", "hrs"}
TIME_FORMATS = ["%Y-%m-%dT%H:%M:%S.%f", "%Y-%m-%dT%H:%M:%S", "%Y-%m-%d %H:%M:%S.%f", "%Y-%m-%d %H:%M:%S",
                "%Y/%m/%d %H:%M:%S", "%d.%m.%Y %H:%M:%S", "%d.%m.%Y %H:%M", "%H:%M:%S.%f", "%H:%M:%S",
                "%m/%d/%Y %H:%M:%S", "%d/%m/%Y %H:%M:%S", "%m/%d/%Y %I:%M:%S %p", "%d/%m/%Y %I:%M:%S %p"]

# ---------------------------------------------------------------------- options
def parse_column_map(text: str | None, machine: Machine | None = None) -> dict[str, str]:
    """'x=Meas X,y=Meas Y,z=Meas Z,point=Name' -> {field: export column}. Fields: x, y, z,
    point, time, temperature, tool and the machine's axis names."""
    if not text:
        return {}
    allowed = {"x", "y", "z", "point", "time", "temperature", "tool"} | set(machine.axis_names if machine else ())
    out: dict[str, str] = {}
    for part in str(text).split(","):
        if "=" not in part:
            raise InputError(f"`columns` '{text}': write FIELD=EXPORT COLUMN pairs separated by commas, e.g. "
                             "'x=Meas X,y=Meas Y,z=Meas Z,point=Name'")
        k, v = (s.strip() for s in part.split("=", 1))
        if k not in allowed:
            raise InputError(f"`columns`: '{k}' is not a field; fields are {', '.join(sorted(allowed))}")
        if not v:
            raise InputError(f"`columns`: the export column for '{k}' is empty")
        out[k] = v
    return out


# ---------------------------------------------------------------------- raw table
@dataclass
class ExportTable:
    """The export's cells: ``header`` (names as written), ``rows`` (cells per data line),
    ``lines`` (1-based line number of each data row), and what was detected."""

    path: str
    header: list[str]
    rows: list[list[str]]
    lines: list[int]
    header_line: int
    delimiter: str
    encoding: str
    preamble: list[str]
    notes: list[str] = field(default_factory=list)


def _decode(path: Path) -> tuple[str, str]:
    data = path.read_bytes()
    if data.startswith(b"\xff\xfe") or data.startswith(b"\xfe\xff"):
        return data.decode("utf-16"), "UTF-16"
    if data.startswith(b"\xef\xbb\xbf"):
        return data[3:].decode("utf-8", errors="strict"), "UTF-8 with BOM"
    try:
        return data.decode("utf-8"), "UTF-8"
    except UnicodeDecodeError:
        return data.decode("cp1252", errors="replace"), "Windows-1252 (not UTF-8)"


def _delimiter_of(line: str) -> str | None:
    for d in (";", "\t", ","):
        if d in line:
            return d
    return None


DELIMITER_NAMES = {",": "comma", ";": "semicolon", "\t": "tab"}


def _option_delimiter(value: str) -> str | None:
    v = {"auto": None, "comma": ",", ",": ",", "semicolon": ";", ";": ";", "tab": "\t", "\\t": "\t", "\t": "\t"}
    if value not in v:
        raise InputError(f"`delimiter` '{value}': one of auto, comma, semicolon, tab")
    return v[value]


def read_export_table(path: str | Path, delimiter: str = "auto", is_header=None) -> ExportTable:
    """Read the cells of an export. ``is_header(cells) -> bool`` picks the header line
    among the first 30 non-comment lines (default: the first)."""
    path = Path(path)
    name = str(path)
    if not path.is_file():
        raise CampaignFileError(name, "no such export file")
    text, enc = _decode(path)
    forced = _option_delimiter(delimiter)
    numbered = [(i + 1, ln) for i, ln in enumerate(text.splitlines())]
    content = [(i, ln) for i, ln in numbered if ln.strip() and not ln.strip().startswith(COMMENT_PREFIXES)]
    comments = [ln.strip() for _, ln in numbered if ln.strip().startswith(COMMENT_PREFIXES)]
    if not content:
        raise CampaignFileError(name, "the export is empty (no header and no measured points)")
    chosen = None
    for k, (lineno, ln) in enumerate(content[:30]):
        d = forced or _delimiter_of(ln)
        if d is None:
            continue
        cells = [c.strip() for c in next(csv.reader([ln], delimiter=d))]
        if is_header is None or is_header(cells):
            chosen = (k, lineno, d, cells)
            break
    if chosen is None:
        lineno, ln = content[0]
        if (forced or _delimiter_of(ln)) is None:
            raise CampaignFileError(name, f"no comma, semicolon or tab in the header '{ln.strip()[:60]}': give "
                                    "`delimiter`", row=lineno)
        raise CampaignFileError(name, "no header line names the measured coordinates x, y, z (looked at the first "
                                f"30 lines; line {lineno} reads '{ln.strip()[:70]}'): name the columns with "
                                "`columns` 'x=...,y=...,z=...'", row=lineno)
    k, header_line, d, header = chosen
    while header and header[-1] == "":
        header = header[:-1]
    preamble = [ln.strip() for _, ln in content[:k]] + comments
    rows, lines = [], []
    for lineno, ln in content[k + 1:]:
        cells = [c.strip() for c in next(csv.reader([ln], delimiter=d))]
        while len(cells) > len(header) and cells[-1] == "":
            cells = cells[:-1]  # a trailing delimiter
        if len(cells) != len(header):
            raise CampaignFileError(name, f"{len(cells)} cells where the header (line {header_line}) has {len(header)} "
                                    f"({DELIMITER_NAMES[d]}-separated)", row=lineno)
        rows.append(cells)
        lines.append(lineno)
    if not rows:
        raise CampaignFileError(name, f"the export has a header (line {header_line}) but no measured points")
    return ExportTable(name, header, rows, lines, header_line, d, enc, preamble)


# ---------------------------------------------------------------------- columns
def _tokens(h: str) -> tuple[list[str], list[str]]:
    """Words of a header and its unit annotations: 'Meas. X [in]' -> (['meas', 'x'], ['in'])."""
    s = h.strip().lower().replace("°", " deg")
    units = [u.strip() for u in re.findall(r"[\[\(\{]\s*([^\]\)\}]*)\s*[\]\)\}]", s)]
    s = re.sub(r"[\[\(\{][^\]\)\}]*[\]\)\}]", " ", s)
    words = [w for w in re.split(r"[\s_\-./:#]+", s) if w]
    trailing = []
    while len(words) > 1 and words[-1] in UNIT_TOKENS:
        trailing.insert(0, words.pop())
    if len(words) > 1 and words[-1] == "deg" and trailing:
        words.pop()
    units = [u.replace("deg ", "deg").replace(" ", "") for u in units] + trailing
    return words, units


def _is_coord(words: list[str], axis: str) -> bool:
    core = [w for w in words if w not in MEAS_WORDS]
    return core == [axis] and not (set(words) & EXCLUDE_WORDS)


def resolve_columns(header: list[str], user: dict[str, str], axes: list[str], want_axes: bool) -> tuple[dict, dict]:
    """{field: column index} from the user's map and recognised names (English and German
    headers; a date column beside a time-of-day column is field ``date``, read with the time);
    second dict: the candidates found for fields that are ambiguous ({field: [names]})."""
    idx: dict[str, int] = {}
    ambiguous: dict[str, list[str]] = {}
    lower = {h.lower(): j for j, h in enumerate(header)}
    for f, col in user.items():
        if col in header:
            idx[f] = header.index(col)
        elif col.lower() in lower:
            idx[f] = lower[col.lower()]
        else:
            idx[f] = -1  # reported by the caller with the header listed
    taken = set(idx.values())
    if want_axes:
        for a in axes:
            if a not in idx and a in header:
                idx[a] = header.index(a)
                taken.add(idx[a])
    toks = [_tokens(h)[0] for h in header]
    tests = {"x": lambda w: _is_coord(w, "x"), "y": lambda w: _is_coord(w, "y"), "z": lambda w: _is_coord(w, "z"),
             "point": lambda w: w in POINT_HEADERS,
             "time": lambda w: bool(TIME_WORDS & set(w)) and not
             ({"temp", "temperature"} & set(w)) and not (set(w) & EXCLUDE_WORDS),
             "temperature": lambda w: any(x.startswith("temp") or "temperatur" in x for x in w)
             and not (set(w) & EXCLUDE_WORDS),
             "tool": lambda w: w in (["tool"], ["tool", "length"], ["holder"], ["holder", "length"])}
    for f, test in tests.items():
        if f in idx:
            continue
        exact = [j for j, h in enumerate(header) if h == f and j not in taken]
        cand = exact or [j for j, w in enumerate(toks) if j not in taken and test(w)]
        if f == "temperature" and len(cand) > 1:
            air = [j for j in cand if any(w in ("air", "luft") or w.startswith("luft") for w in toks[j])]
            cand = air if len(air) == 1 else cand
        if f == "time" and len(cand) == 2:   # a date column beside a time-of-day column: read as one stamp
            dates = [j for j in cand if set(toks[j]) in DATE_ONLY]
            if len(dates) == 1:
                idx["date"] = dates[0]
                taken.add(dates[0])
                cand = [j for j in cand if j != dates[0]]
        if len(cand) == 1:
            idx[f] = cand[0]
            taken.add(cand[0])
        elif len(cand) > 1:
            ambiguous[f] = [header[j] for j in cand]
    return idx, ambiguous


# ---------------------------------------------------------------------- numbers
_DOT = re.compile(r"^[+-]?(\d+\.\d*|\.\d+)([eE][+-]?\d+)?$")
_COMMA = re.compile(r"^[+-]?(\d+,\d*|,\d+)([eE][+-]?\d+)?$")


def detect_decimal(cells: list[str]) -> str:
    """'.' or ',' from numeric cells; both present is an error raised by the caller."""
    dots = sum(bool(_DOT.match(c)) for c in cells)
    commas = sum(bool(_COMMA.match(c)) for c in cells)
    if commas and dots:
        return "mixed"
    return "," if commas else "."


def parse_number(s: str, decimal: str) -> float:
    s = s.strip().replace("\u2212", "-")
    if decimal == ",":
        if "." in s and "," in s:
            raise ValueError("thousands separator")
        s = s.replace(",", ".")
    elif "," in s:
        raise ValueError("decimal comma in a file read with a decimal point")
    v = float(s)
    if not math.isfinite(v):
        raise ValueError("not finite")
    return v


# ---------------------------------------------------------------------- units
def unit_hint(header_units: list[str], preamble: list[str]) -> tuple[str | None, str]:
    """The length unit the column headers' unit tokens or a preamble line (``Units: Inches``)
    state, and where it was read ("conflict" when the headers disagree; None: not stated)."""
    table = {"mm": "mm", "millimeter": "mm", "millimeters": "mm", "millimetre": "mm", "millimetres": "mm",
             "in": "in", "inch": "in", "inches": "in", '"': "in", "m": "m", "meter": "m", "meters": "m", "metre": "m",
             "metres": "m"}
    found = {table[u] for u in header_units if u in table}
    if len(found) == 1:
        return found.pop(), "from the column headers"
    if len(found) > 1:
        return "conflict", "the column headers give different units"
    pat = re.compile(r"\b(?:units?|length\s*units?|linear\s*units?|distance\s*units?)\b\s*[:=]?\s*"
                     r"(mm|millimet\w*|inch(?:es)?|in|m|met(?:er|re)s?)\b", re.I)
    for ln in preamble:
        m_ = pat.search(ln)
        if m_:
            w = m_.group(1).lower()
            return ("mm" if w.startswith("mm") or w.startswith("millim") else "in" if w.startswith("in") else "m"), \
                f"from the line '{ln[:50]}'"
    return None, ""
