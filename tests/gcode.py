"""A small G-code interpreter for the tests of vecpin's NC programs, written from the
controls' documentation and nothing of vecpin's (it imports no vecpin code).

It runs a program on a simulated control that starts in a state the program must not
rely on (``Start``: inch units, tool length compensation on, a work offset, incremental
mode, unknown axis positions), and records every move as the machine axes' positions in
mm and degrees, how its end point was given ("machine", "incremental" or "work"
coordinates), the dwells, stops and comments, and the modal state at the end. It refuses
what a control refuses or what a measurement program must not do (a move before the
units are set, with tool length or radius compensation active, arcs, cycles, ...).

Sources, per dialect:

* Siemens SINUMERIK 840D sl, Programming Manual Fundamentals: comments after ``;``;
  G groups 1 (G0 G1 G2 G3), 2 (G4, non-modal), 6 (G17 G18 G19), 7 (G40 G41 G42), 13
  (G70 G71 G700 G710: inch / metric; G70 / G71 for lengths only, the feed stays in the
  basic system, so a program sets its units with G700 / G710 here), 14 (G90 G91), 15
  (G93 G94 G95); ``SUPA``
  non-modal suppression of all frames, DRF and external zero offsets: the block's axis
  values are machine coordinates; ``D0`` deselects the tool offset, ``TRAFOOF`` the
  transformation (``TRAORI``); ``G4 F<s>`` in a block of its own; an address of more
  than one letter takes ``=``; ``M30`` ends (after it the control sets the reset
  values of its machine data, which this interpreter does not know: the units stay).
* Fanuc Series 0i-MF / 30i-B, Operator's Manual (M series), G code list: groups 00
  (G04 G53 ... one-shot), 01 (G00 G01 G02 G03), 02 (G17 G18 G19), 03 (G90 G91), 05 (G94
  G95), 06 (G20 G21: in a block of their own at the start of a program), 07 (G40 G41
  G42), 08 (G43 G44 G49, G43.4 G43.5), 09 (G73 ... G80 ... G89), 14 (G54-G59), 16 (G68
  G69), 11 (G50 G51); ``G53`` selects the machine coordinate system for its block only,
  moves at rapid traverse whatever the motion code, and is ignored in G91 (here: an
  error); ``G04 P<ms>`` without a decimal point; comments in ``( )``; ``;`` is the end of
  block (EOB) of ISO code, so one inside a comment cuts the block; a program is framed
  by ``%`` and starts with its ``O`` number; ``M30`` ends and leaves G20/G21 as it was.
* LinuxCNC G-code reference (RS274/NGC modal groups): 0 (G4 G10 G28 G30 G53 G92,
  non-modal), 1 (G0 G1 G2 G3 G33 G38.x G73 G76 G80-G89), 2 (G17-G19), 3 (G90 G91), 5
  (G93 G94 G95), 6 (G20 G21), 7 (G40 G41 G42), 8 (G43 G43.1 G49), 12 (G54-G59.3), 13
  (G61 G64); two words of one group in a block are an error; ``G53`` only with G0 or G1
  active and radius compensation off; ``G4 P<s>``; comments in ``( )`` or after ``;``;
  ``M70`` saves the modal state (units, distance and feed mode, plane, compensations,
  motion mode) and ``M72`` restores it; ``M2`` / ``M30`` end.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import NamedTuple

INCH = 25.4


class GCodeError(AssertionError):
    pass


GROUPS = {
    "siemens-840d": {1: {0, 1, 2, 3}, 2: {4}, 6: {17, 18, 19}, 7: {40, 41, 42}, 13: {70, 71, 700, 710},
                     14: {90, 91}, 15: {93, 94, 95}},
    "fanuc": {0: {4, 53, 28, 30, 10, 92, 52}, 1: {0, 1, 2, 3}, 2: {17, 18, 19}, 3: {90, 91}, 5: {93, 94, 95},
              6: {20, 21}, 7: {40, 41, 42}, 8: {43, 44, 49, 43.4, 43.5}, 9: {73, 74, 76, 80, 81, 82, 83, 84, 85, 86,
                                                                             87, 88, 89},
              11: {50, 51}, 14: {54, 55, 56, 57, 58, 59}, 16: {68, 69}},
    "gcode": {0: {4, 10, 28, 30, 53, 92}, 1: {0, 1, 2, 3, 33, 38.2, 73, 76, 80, 81, 82, 83, 84, 85, 86, 87, 88, 89},
              2: {17, 18, 19}, 3: {90, 91}, 5: {93, 94, 95}, 6: {20, 21}, 7: {40, 41, 42}, 8: {43, 43.1, 49},
              12: {54, 55, 56, 57, 58, 59}, 13: {61, 64}},
}
ALLOWED_G = {0, 1, 4, 17, 20, 21, 40, 49, 53, 700, 710, 80, 90, 91, 94}  # what a measurement program may use
ENDS = {"siemens-840d": {30}, "fanuc": {30}, "gcode": {2, 30}}


@dataclass
class Start:
    """The control's state before the program: everything a program must set itself."""
    units: str | None = "inch"
    distance: str | None = "inc"
    tool_length: bool = True
    radius_comp: bool = False
    transformation: bool = True          # Siemens TRAORI
    offset: dict = field(default_factory=lambda: {"X": 100.0, "Y": -50.0, "Z": 200.0, "C": 30.0})


class Move(NamedTuple):
    code: int          # 0 rapid, 1 at the feed (as the control moves: Fanuc's G53 is a rapid)
    pos: dict          # every axis' machine position after the move (None: unknown)
    feed: float | None
    line: int
    frame: str         # "machine", "incremental" or "work"
    axes: tuple        # the axes the block programmed
    before: dict       # every axis' machine position before the move


@dataclass
class Program:
    moves: list = field(default_factory=list)
    dwells: list = field(default_factory=list)    # seconds, in order
    stops: list = field(default_factory=list)     # (line, comment) of M0 / M00
    comments: list = field(default_factory=list)
    events: list = field(default_factory=list)    # ("move", i) / ("dwell", i) / ("stop", i) / ("comment", text)
    units_at_end: str | None = None
    ended: bool = False


def _blocks(text: str, dialect: str) -> list[tuple[int, str, list[str]]]:
    """(line number, code, comments) per block."""
    lines = text.splitlines()
    out = []
    if dialect == "fanuc":
        if lines[0] != "%" or lines[-1] != "%":
            raise GCodeError("a Fanuc program starts and ends with a % line")
        if not re.match(r"^O\d{4}\b", lines[1]):
            raise GCodeError(f"the program number O#### must follow the %: {lines[1]!r}")
        body = [(n, ln) for n, ln in enumerate(lines, 1)][1:-1]
        body[0] = (2, lines[1][5:])  # the comment after the program number
        for n, ln in body:
            if "%" in ln:
                raise GCodeError(f"line {n}: % (end of record) inside the program")
            for part in ln.split(";"):  # ISO code: ';' is the end of block
                code, comments = _paren(part, n)
                if re.search(r"[a-z]", code):
                    raise GCodeError(f"line {n}: lower case outside a comment: {ln!r}")
                out.append((n, code, comments))
        return out
    for n, ln in enumerate(lines, 1):
        if dialect == "siemens-840d":
            code, sep, c = ln.partition(";")
            out.append((n, code.strip(), [c.strip()] if sep else []))
        else:
            code, comments = _paren(ln, n)
            code, sep, c = code.partition(";")
            out.append((n, code.strip().upper(), comments + ([c.strip()] if sep else [])))
    return out


def _paren(text: str, n: int) -> tuple[str, list[str]]:
    comments = re.findall(r"\(([^()]*)\)", text)
    code = re.sub(r"\([^()]*\)", " ", text)
    if "(" in code or ")" in code:
        raise GCodeError(f"line {n}: unbalanced or nested parentheses (a ';' inside a comment ends a Fanuc block): "
                         f"{text!r}")
    return code.strip(), comments


def _words(code: str, dialect: str, n: int) -> list[tuple[str, str]]:
    words = []
    for tok in code.split():
        if dialect == "siemens-840d" and tok in ("SUPA", "TRAFOOF", "TRAORI"):
            words.append((tok, ""))
            continue
        m = re.fullmatch(r"([A-Z])\s*([+-]?(?:\d+\.?\d*|\.\d+))", tok)
        if m is None and dialect == "siemens-840d":
            m = re.fullmatch(r"([A-Z][A-Z0-9]*)=([+-]?(?:\d+\.?\d*|\.\d+))", tok)
        if m is None:
            raise GCodeError(f"line {n}: {tok!r} is not a word")
        words.append((m.group(1), m.group(2)))
    if words and words[0][0] == "N":  # block number
        words = words[1:]
    return words


def run(text: str, dialect: str, axes: dict[str, tuple[float, float]], start: Start | None = None) -> Program:
    """Execute ``text``; ``axes``: NC address -> (low, high) machine limits in mm or deg
    (A, B and C, and addresses starting with them, are rotary axes as ISO 841 names them).
    ``dialect`` "heidenhain": conversational programs, by tests/heidenhain.py."""
    if dialect == "heidenhain":
        from heidenhain import run as run_conversational
        return run_conversational(text, axes, start)
    st = start or Start()
    groups = GROUPS[dialect]
    units, distance, tlc, rcomp, trafo = st.units, st.distance, st.tool_length, st.radius_comp, st.transformation
    motion, feed, plane, feedmode = None, None, None, None
    saved, units_set = None, False
    pos: dict = {a: None for a in axes}
    prog = Program()
    for n, code, comments in _blocks(text, dialect):
        prog.comments += comments
        prog.events += [("comment", c) for c in comments]
        if not code:
            continue
        if prog.ended:
            raise GCodeError(f"line {n}: code after the program end")
        words = _words(code, dialect, n)
        gs = [float(v) for k, v in words if k == "G"]
        seen = {}
        for g in gs:
            grp = next((k for k, s in groups.items() if g in s), None)
            if grp is None or g not in ALLOWED_G or (g == 53 and dialect == "siemens-840d") \
                    or (g in (700, 710) and dialect != "siemens-840d") or (g in (20, 21) and dialect == "siemens-840d"):
                raise GCodeError(f"line {n}: G{g:g} is not allowed here ({code!r})")
            if grp in seen:
                raise GCodeError(f"line {n}: G{seen[grp]:g} and G{g:g} of one modal group in a block")
            seen[grp] = g
        machine = ("SUPA", "") in words if dialect == "siemens-840d" else 53 in gs
        rest = [(k, v) for k, v in words if k not in ("G", "SUPA")]
        for g in gs:
            if g in (20, 21, 700, 710):
                if dialect == "fanuc" and len(words) != 1:
                    raise GCodeError(f"line {n}: Fanuc wants G20/G21 in a block of its own")
                units, units_set = ("mm" if g in (21, 710) else "inch"), True
            elif g in (90, 91):
                distance = "abs" if g == 90 else "inc"
            elif g == 49:
                tlc = False
            elif g == 40:
                rcomp = False
            elif g == 17:
                plane = 17
            elif g == 94:
                feedmode = 94
            elif g in (0, 1):
                motion = int(g)
        if 4 in gs:  # dwell
            if len(gs) != 1:
                raise GCodeError(f"line {n}: a dwell stands in a block of its own")
            if dialect == "siemens-840d":
                if len(rest) != 1 or rest[0][0] != "F":
                    raise GCodeError(f"line {n}: Siemens dwell is G4 F<s> alone: {code!r}")
                t = float(rest[0][1])
            elif dialect == "fanuc":
                if len(rest) != 1 or rest[0][0] != "P" or "." in rest[0][1]:
                    raise GCodeError(f"line {n}: Fanuc dwell is G04 P<ms> without a decimal point: {code!r}")
                t = int(rest[0][1]) / 1000.0
            else:
                if len(rest) != 1 or rest[0][0] != "P":
                    raise GCodeError(f"line {n}: dwell is G4 P<s>: {code!r}")
                t = float(rest[0][1])
            prog.dwells.append(t)
            prog.events.append(("dwell", len(prog.dwells) - 1))
            continue
        axis_words, others = [], []
        for k, v in rest:
            if k == "TRAFOOF":
                trafo = False
            elif k == "TRAORI":
                trafo = True
            elif k == "D" and dialect == "siemens-840d":
                tlc = float(v) != 0
            elif k == "F":
                if dialect == "fanuc" and "." not in v:
                    raise GCodeError(f"line {n}: a Fanuc feed without a decimal point counts in least increments")
                feed = float(v)
            elif k == "M":
                others.append(int(float(v)))
            elif k in axes:
                if k in [a for a, _ in axis_words]:
                    raise GCodeError(f"line {n}: axis {k} twice")
                if dialect == "fanuc" and "." not in v:
                    raise GCodeError(f"line {n}: {k}{v}: a Fanuc value without a decimal point counts in least "
                                     "increments")
                axis_words.append((k, float(v)))
            else:
                raise GCodeError(f"line {n}: word {k}{v} is not an axis of the machine nor allowed")
        for m in others:
            if len(others) > 1 or axis_words:
                raise GCodeError(f"line {n}: an M code with other words: {code!r}")
            if m == 0:
                prog.stops.append((n, " ".join(comments)))
                prog.events.append(("stop", len(prog.stops) - 1))
            elif m in ENDS[dialect]:
                prog.ended = True
            elif dialect == "gcode" and m == 70:
                saved = (units, distance, tlc, rcomp, motion, plane, feedmode)
            elif dialect == "gcode" and m == 72:
                if saved is None:
                    raise GCodeError(f"line {n}: M72 without M70")
                units, distance, tlc, rcomp, motion, plane, feedmode = saved
            else:
                raise GCodeError(f"line {n}: M{m} is not allowed")
        if not axis_words:
            if machine:
                raise GCodeError(f"line {n}: machine coordinates without a move")
            continue
        if units is None or distance is None or motion is None:
            raise GCodeError(f"line {n}: a move before the units, distance mode and motion are set")
        if not units_set:
            raise GCodeError(f"line {n}: a move before the program sets its units")
        if tlc:
            raise GCodeError(f"line {n}: a move with tool length compensation active")
        if rcomp:
            raise GCodeError(f"line {n}: a move with radius compensation active")
        if trafo and dialect == "siemens-840d":
            raise GCodeError(f"line {n}: a move with the transformation (TRAORI) active")
        if machine and distance == "inc" and dialect == "fanuc":
            raise GCodeError(f"line {n}: G53 in G91 is ignored by Fanuc")
        before = dict(pos)
        scale = {k: (1.0 if k[0] in "ABC" else (INCH if units == "inch" else 1.0)) for k, _ in axis_words}
        if machine:
            frame = "machine"
        elif distance == "inc":
            frame = "incremental"
        else:
            frame = "work"
        for k, v in axis_words:
            v = v * scale[k]
            if frame == "incremental":
                if pos[k] is None:
                    raise GCodeError(f"line {n}: an incremental move of {k} from an unknown position")
                pos[k] = round(pos[k] + v, 9)
            else:
                pos[k] = v + (st.offset.get(k, 0.0) if frame == "work" else 0.0)
            lo, hi = axes[k]
            if not lo - 1e-9 <= pos[k] <= hi + 1e-9:
                raise GCodeError(f"line {n}: {k} to {pos[k]:g} outside the limits [{lo}, {hi}]")
        kind = 0 if (motion == 0 or (machine and dialect == "fanuc")) else 1
        if kind == 1 and feed is None:
            raise GCodeError(f"line {n}: G1 without a feed")
        prog.moves.append(Move(kind, dict(pos), feed if kind else None, n, frame, tuple(k for k, _ in axis_words),
                               before))
        prog.events.append(("move", len(prog.moves) - 1))
    if not prog.ended:
        raise GCodeError("no program end")
    prog.units_at_end = units
    return prog


def parse(text: str, dialect: str, axes: dict[str, tuple[float, float]]) -> Program:
    """:func:`run` from the default :class:`Start`."""
    return run(text, dialect, axes)
