"""A small interpreter of HEIDENHAIN conversational (Klartext) programs for the tests of
vecpin's NC programs, written from the controls' documentation and nothing of vecpin's
(it imports no vecpin code). It runs a program on a simulated control that starts in a
state the program must not rely on (tests/gcode.py's ``Start``: a work datum shifted,
a tool length active, TCPM (M128) on) and records the same :class:`gcode.Program` as the
G-code interpreter: every move as the machine axes' positions in mm and degrees, how its
end point was given ("machine", "incremental" or "work"), the dwells, stops, comments.

Sources (HEIDENHAIN User's Manuals, conversational programming; TNC 360 p.5-39, TNC 406
p.125, iTNC 530 Pilot):

* a program is ``BEGIN PGM <name> MM|INCH`` ... ``END PGM <name> MM|INCH`` (the same name
  and unit), every block numbered (here: 0, 1, 2, ... in order); ``;`` starts a comment;
* ``L`` is a straight line: axis words (``X+100``, ``IX+5`` incremental), radius
  compensation ``R0`` / ``RL`` / ``RR``, the feed ``F<mm/min>`` (modal) or ``FMAX``
  (rapid, this block only) and miscellaneous functions; ``M91`` references the block's
  coordinates to the machine datum, in that block only, and the tool length is not
  compensated in it; without it the coordinates are the workpiece's (the datum shift);
* ``M128`` (TCPM) keeps the tool tip on the path while rotary axes move and ``M129``
  cancels it; "before positioning with M91 or M92 ... reset M128" (TNC 620 User's Manual
  5/2013 p.340): a move with it active is refused; an ``L`` block may carry
  miscellaneous functions alone;
* cycle 9 DWELL TIME: ``CYCL DEF 9.0 DWELL TIME`` then ``CYCL DEF 9.1 DWELL <s>``,
  active when defined; ``STOP`` halts the program run (cycle start goes on);
  ``TOOL CALL`` would load a tool and its length: refused here (the holder is mounted
  by hand).
"""
from __future__ import annotations

import re

from gcode import INCH, GCodeError, Move, Program, Start

NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)"


def _numbered(text: str) -> list[tuple[int, str]]:
    """(line, block without its number); the numbers run 0, 1, 2, ... in order."""
    out = []
    for n, ln in enumerate(text.splitlines()):
        m = re.fullmatch(r"(\d+)\s+(.*)", ln.strip())
        if m is None or int(m.group(1)) != n:
            raise GCodeError(f"line {n + 1}: block number {n} expected: {ln!r}")
        out.append((n + 1, m.group(2).strip()))
    return out


def run(text: str, axes: dict[str, tuple[float, float]], start: Start | None = None) -> Program:
    """Execute ``text``; ``axes``: address -> (low, high) machine limits in mm or deg
    (A, B and C are rotary axes)."""
    st = start or Start()
    blocks = _numbered(text)
    head = re.fullmatch(r"BEGIN PGM (\w+) (MM|INCH)", blocks[0][1])
    tail = re.fullmatch(r"END PGM (\w+) (MM|INCH)", blocks[-1][1])
    if head is None or tail is None or head.groups() != tail.groups():
        raise GCodeError("a program is BEGIN PGM <name> MM|INCH ... END PGM <name> MM|INCH, the same name and unit")
    units = head.group(2).lower()
    pos: dict = {a: None for a in axes}
    prog = Program()
    tcpm, rcomp, feed, pending_dwell, last_comment = st.transformation, st.radius_comp, None, False, ""
    for n, code in blocks[1:-1]:
        if code.startswith(";"):
            last_comment = code[1:].strip()
            prog.comments.append(last_comment)
            prog.events.append(("comment", last_comment))
            continue
        if pending_dwell:
            m = re.fullmatch(rf"CYCL DEF 9\.1 DWELL ({NUMBER})", code)
            if m is None:
                raise GCodeError(f"line {n}: CYCL DEF 9.0 must be followed by CYCL DEF 9.1 DWELL <s>: {code!r}")
            prog.dwells.append(float(m.group(1)))
            prog.events.append(("dwell", len(prog.dwells) - 1))
            pending_dwell = False
            continue
        if code == "CYCL DEF 9.0 DWELL TIME":
            pending_dwell = True
            continue
        if code == "STOP":
            prog.stops.append((n, last_comment))
            prog.events.append(("stop", len(prog.stops) - 1))
            continue
        if code.startswith("TOOL CALL") or code.startswith("CYCL"):
            raise GCodeError(f"line {n}: {code!r} is not allowed in a measurement program")
        if re.fullmatch(r"L(\s+M\d+)+", code):  # an L block of miscellaneous functions alone ("L M140 MB MAX")
            for mm in re.findall(r"M(\d+)", code):
                if int(mm) == 129:
                    tcpm = False
                elif int(mm) == 128:
                    tcpm = True
                else:
                    raise GCodeError(f"line {n}: M{mm} is not allowed")
            continue
        if not code.startswith("L "):
            raise GCodeError(f"line {n}: not a block of a measurement program: {code!r}")
        words = code[2:].split()
        axis_words, mfun, rapid, frame_inc = [], [], False, {}
        for w in words:
            m = re.fullmatch(rf"(I?)([A-Z])({NUMBER})", w)
            if w in ("R0", "RL", "RR", "R+", "R-"):
                rcomp = w != "R0"
            elif w == "FMAX":
                rapid = True
            elif re.fullmatch(rf"F{NUMBER}", w):
                feed = float(w[1:])
            elif re.fullmatch(r"M\d+", w):
                mfun.append(int(w[1:]))
            elif m is not None and m.group(2) in axes:
                if m.group(2) in [a for a, _ in axis_words]:
                    raise GCodeError(f"line {n}: axis {m.group(2)} twice")
                axis_words.append((m.group(2), float(m.group(3))))
                frame_inc[m.group(2)] = m.group(1) == "I"
            else:
                raise GCodeError(f"line {n}: word {w!r} is not an axis of the machine nor allowed")
        machine = 91 in mfun
        if set(mfun) - {91, 128, 129}:
            raise GCodeError(f"line {n}: M{sorted(set(mfun) - {91, 128, 129})} is not allowed")
        tcpm = False if 129 in mfun else (True if 128 in mfun else tcpm)
        if not axis_words:
            raise GCodeError(f"line {n}: an L block without an axis")
        if rcomp:
            raise GCodeError(f"line {n}: a move with radius compensation active")
        if tcpm:
            raise GCodeError(f"line {n}: a move with TCPM (M128) active")
        if st.tool_length and not machine:
            raise GCodeError(f"line {n}: a move with tool length compensation active (no M91)")
        if not rapid and feed is None:
            raise GCodeError(f"line {n}: a feed move without a feed")
        before = dict(pos)
        for k, v in axis_words:
            v = v * (1.0 if k in "ABC" or units == "mm" else INCH)
            if frame_inc[k]:
                if pos[k] is None:
                    raise GCodeError(f"line {n}: an incremental move of {k} from an unknown position")
                pos[k] = round(pos[k] + v, 9)
            else:
                pos[k] = v + (0.0 if machine else st.offset.get(k, 0.0))
            lo, hi = axes[k]
            if not lo - 1e-9 <= pos[k] <= hi + 1e-9:
                raise GCodeError(f"line {n}: {k} to {pos[k]:g} outside the limits [{lo}, {hi}]")
        frame = "incremental" if any(frame_inc.values()) else ("machine" if machine else "work")
        prog.moves.append(Move(0 if rapid else 1, dict(pos), None if rapid else feed, n, frame,
                               tuple(k for k, _ in axis_words), before))
        prog.events.append(("move", len(prog.moves) - 1))
    if pending_dwell:
        raise GCodeError("CYCL DEF 9.0 without its 9.1 DWELL")
    prog.ended = True
    prog.units_at_end = units
    return prog
