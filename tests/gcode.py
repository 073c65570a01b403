"""A small, strict G-code reader for the tests of vecpin's NC programs.

It knows only what a measurement program may contain and rejects everything else:
positioning G0/G1 (Fanuc writes G00/G01), the dwell G4/G04, the modal settings G90
(absolute), G21 (mm, Fanuc/ISO) or G71 (mm, Siemens), G94 (feed per minute), the stops
M0/M00, the ends M30 (Siemens/Fanuc) or M2 (plain), the feed F, the dwell time and the
axis words. Dwell syntax per dialect, from the vendors' documentation:

* Siemens 840D: ``G4 F<seconds>`` in a block of its own (SINUMERIK 840D sl Programming
  Manual Fundamentals, "Dwell time (G4)": F = time in seconds);
* Fanuc: ``G04 P<milliseconds>`` without a decimal point (Fanuc Series 0i/30i Operator's
  Manual, "Dwell (G04)": P in ms, no decimal point allowed);
* plain G-code (LinuxCNC): ``G4 P<seconds>`` (LinuxCNC G-code reference, G4 Dwell: P in
  seconds).

Comments: Siemens after ``;``, Fanuc and plain in ``( )``; a Fanuc program is framed by
``%`` lines and starts with its ``O`` number, and has no lower-case letters outside comments.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

WORD = re.compile(r"^([A-Z])([+-]?\d+(?:\.\d*)?)$")
EXTENDED = re.compile(r"^([A-Z][A-Z0-9]*)=([+-]?\d+(?:\.\d*)?)$")  # Siemens: an address with digits takes '='



class GCodeError(AssertionError):
    pass


@dataclass
class Program:
    moves: list = field(default_factory=list)   # (code 0/1, {axis: value}, feed or None, line number)
    dwells: list = field(default_factory=list)  # seconds, in order
    stops: list = field(default_factory=list)   # (line number, comment) of M0
    comments: list = field(default_factory=list)
    events: list = field(default_factory=list)  # ("move", i) / ("dwell", i) / ("stop", i) / ("comment", text) in order
    modal: set = field(default_factory=set)
    ended: bool = False


def _strip(line: str, dialect: str) -> tuple[str, list[str]]:
    if dialect == "siemens-840d":
        code, _, c = line.partition(";")
        return code.strip(), ([c.strip()] if _ else [])
    comments = re.findall(r"\(([^()]*)\)", line)
    code = re.sub(r"\([^()]*\)", " ", line)
    if "(" in code or ")" in code:
        raise GCodeError(f"unbalanced or nested parentheses: {line!r}")
    return code.strip(), comments


def parse(text: str, dialect: str, axes: dict[str, tuple[float, float]]) -> Program:
    """Read ``text``; ``axes``: NC axis name -> (low, high) limits in mm or deg."""
    lines = text.splitlines()
    prog = Program()
    g = {"siemens-840d": ("0", "1", "4"), "fanuc": ("00", "01", "04"), "gcode": ("0", "1", "4")}[dialect]
    modal_ok = {"siemens-840d": {"90", "71", "94"}, "fanuc": {"90", "21", "94"}, "gcode": {"90", "21", "94"}}[dialect]
    end_code = "2" if dialect == "gcode" else "30"
    stop_code = "00" if dialect == "fanuc" else "0"
    if dialect == "fanuc":
        if lines[0] != "%" or lines[-1] != "%":
            raise GCodeError("a Fanuc program starts and ends with a % line")
        if not re.match(r"^O\d{4}\b", lines[1]):
            raise GCodeError(f"the program number O#### must follow the %: {lines[1]!r}")
        lines = lines[2:-1]
    for n, line in enumerate(lines, 1):
        code, comments = _strip(line, dialect)
        prog.comments += comments
        prog.events += [("comment", c) for c in comments]
        if dialect == "fanuc" and re.search(r"[a-z]", code):
            raise GCodeError(f"line {n}: lower case outside a comment: {line!r}")
        if not code:
            continue
        if prog.ended:
            raise GCodeError(f"line {n}: code after the program end")
        words = []
        for tok in code.split():
            m = WORD.match(tok) or (EXTENDED.match(tok) if dialect == "siemens-840d" else None)
            if not m:
                raise GCodeError(f"line {n}: {tok!r} is not a word")
            words.append((m.group(1), m.group(2)))
        letters = [w[0] for w in words]
        if letters.count("G") > 1 and not all(v in modal_ok for k, v in words if k == "G"):
            raise GCodeError(f"line {n}: several G codes mixed with motion: {line!r}")
        gs = [v for k, v in words if k == "G"]
        ms = [v for k, v in words if k == "M"]
        if gs and all(v in modal_ok for v in gs):
            if len(words) != len(gs):
                raise GCodeError(f"line {n}: modal settings must stand alone: {line!r}")
            prog.modal |= set(gs)
            continue
        if ms:
            if len(words) != 1:
                raise GCodeError(f"line {n}: M code with other words: {line!r}")
            if ms[0] == stop_code:
                prog.stops.append((n, " ".join(comments)))
                prog.events.append(("stop", len(prog.stops) - 1))
            elif ms[0] == end_code:
                prog.ended = True
            else:
                raise GCodeError(f"line {n}: M{ms[0]} is not allowed")
            continue
        if len(gs) != 1:
            raise GCodeError(f"line {n}: a block needs one of G{g[0]}/G{g[1]}/G{g[2]}: {line!r}")
        code_ = gs[0]
        rest = [(k, v) for k, v in words if k != "G"]
        if code_ == g[2]:  # dwell
            if dialect == "siemens-840d":
                if len(rest) != 1 or rest[0][0] != "F":
                    raise GCodeError(f"line {n}: Siemens dwell is G4 F<s> alone: {line!r}")
                t = float(rest[0][1])
            elif dialect == "fanuc":
                if len(rest) != 1 or rest[0][0] != "P" or "." in rest[0][1]:
                    raise GCodeError(f"line {n}: Fanuc dwell is G04 P<ms> without a decimal point: {line!r}")
                t = int(rest[0][1]) / 1000.0
            else:
                if len(rest) != 1 or rest[0][0] != "P":
                    raise GCodeError(f"line {n}: dwell is G4 P<s>: {line!r}")
                t = float(rest[0][1])
            prog.dwells.append(t)
            prog.events.append(("dwell", len(prog.dwells) - 1))
            continue
        if code_ not in g[:2]:
            raise GCodeError(f"line {n}: G{code_} is not allowed")
        pos, feed = {}, None
        for k, v in rest:
            if k == "F":
                if code_ == g[0]:
                    raise GCodeError(f"line {n}: a feed on a rapid move")
                if dialect == "fanuc" and "." not in v:
                    raise GCodeError(f"line {n}: Fanuc feeds carry a decimal point")
                feed = float(v)
            elif k in axes:
                if k in pos:
                    raise GCodeError(f"line {n}: axis {k} twice")
                val = float(v)
                lo, hi = axes[k]
                if not lo - 1e-9 <= val <= hi + 1e-9:
                    raise GCodeError(f"line {n}: {k}{v} outside the limits [{lo}, {hi}]")
                pos[k] = val
            else:
                raise GCodeError(f"line {n}: word {k}{v} is not an axis of the machine")
        if set(pos) != set(axes):
            raise GCodeError(f"line {n}: every axis must be programmed ({', '.join(axes)}): {line!r}")
        if code_ == g[1] and feed is None:
            raise GCodeError(f"line {n}: G1 without a feed")
        prog.moves.append((0 if code_ == g[0] else 1, pos, feed, n))
        prog.events.append(("move", len(prog.moves) - 1))
    if not prog.ended:
        raise GCodeError("no program end")
    if "90" not in prog.modal or not ({"21", "71"} & prog.modal):
        raise GCodeError("absolute positioning in mm must be set (G90 and G21/G71)")
    return prog
