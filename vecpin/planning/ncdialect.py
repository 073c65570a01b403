"""The blocks a measurement program is made of, per NC dialect.

Three dialects (the names :mod:`vecpin.planning.ncprogram` and the sign test use):

* ``siemens-840d`` (SINUMERIK 840D): comments after ``;``; ``SUPA`` in a positioning
  block suppresses every frame, the handwheel (DRF) and external zero offsets and
  PRESET for that block only (non-modal), so the axis words are machine coordinates;
  ``G710`` mm for lengths and feeds (``G71`` leaves the feed in the control's basic
  system, inch on an inch machine), ``G17`` plane, ``G40`` no radius compensation, ``G90`` absolute, ``G94``
  feed per minute, ``TRAFOOF`` no kinematic transformation (TRAORI), ``D0`` no tool
  offset; the dwell is ``G4 F<s>`` in a block of its own; the end ``M30``, after which
  the control sets its reset G codes again (machine data MD20150 / MD20152).
* ``fanuc`` (Series 0i/30i): comments in ``( )``, in capitals; a ``;`` is the end of a
  block in ISO code, so it never stands in a comment, nor does ``%`` (end of record);
  ``G21`` (lengths and feeds) in a block of its own first, then ``G17 G40 G49 G80 G90 G94`` (``G49`` also ends
  ``G43.4``); ``G53`` (one-shot) with ``G90`` in each positioning block: machine
  coordinates, always at rapid traverse, so the final approach at a feed is an
  incremental ``G91 G01`` from the machine-coordinate approach position (an increment
  is the same in every coordinate system), followed by ``G90``; the dwell ``G04 P<ms>``;
  the end ``M30``; ``G21`` stays active after it (the header says so).
* ``gcode`` (LinuxCNC): comments in ``( )``; ``M70`` saves the modal state the program
  changes (units, distance and feed mode, plane, compensations) and ``M72`` restores it
  before ``M2``; ``G21``, then ``G17 G40 G49 G80 G90 G94``; ``G53`` (non-modal) with
  ``G0`` or ``G1`` in each positioning block: machine coordinates; the dwell ``G4 P<s>``.
"""
from __future__ import annotations

import re
import textwrap

SIEMENS, FANUC, GCODE = "siemens-840d", "fanuc", "gcode"


def nc_comment(dialect: str, text: str) -> str:
    """A comment block: ``; text`` (Siemens), ``(TEXT)`` (Fanuc: capitals, no ``;``,
    ``%`` or parentheses inside), ``(text)`` (LinuxCNC: no parentheses inside)."""
    if dialect == SIEMENS:
        return f"; {text}"
    text = text.replace("(", "[").replace(")", "]")
    if dialect == FANUC:
        text = re.sub(r"\s*;\s*", ", ", text).replace("%", " PERCENT").upper()
    return f"({text})"


def comments(dialect: str, text: str, width: int = 76) -> list[str]:
    """``text`` as comment blocks of at most about ``width`` characters each (a control
    shows a block on one line; some limit its length)."""
    return [nc_comment(dialect, t) for t in textwrap.wrap(text, width)]


def prologue(dialect: str) -> list[str]:
    """The blocks before the first move: units and a safety block (see the module docstring)."""
    if dialect == SIEMENS:
        return ["G17 G40 G710 G90 G94", "TRAFOOF", "D0"]
    if dialect == FANUC:
        return ["G21", "G17 G40 G49 G80 G90 G94"]
    return ["M70", "G21", "G17 G40 G49 G80 G90 G94"]


def epilogue(dialect: str) -> list[str]:
    """The blocks after the last move: LinuxCNC restores the modal state, then the end."""
    return ["M72", "M2"] if dialect == GCODE else ["M30"]


def restore_note(dialect: str) -> str:
    """What the program leaves changed after its end (a header comment)."""
    if dialect == SIEMENS:
        return ("the program sets G710 (mm, G71 with feeds in mm/min) G17 G40 G90 G94 TRAFOOF D0; at M30 the control sets its reset values "
                "again (G codes: MD20150 / MD20152, tool offset: MD20110 / MD20120): check them if the next program "
                "relies on G70 (inch) or an active tool offset")
    if dialect == FANUC:
        return ("the program sets G21 (mm) G17 G40 G49 G80 G90 G94, which stay active after M30: program G20 again "
                "before an inch program, and the tool length offset (G43) the next program needs")
    return "M70 saves the modal state (units, distance and feed mode, plane, compensations) and M72 restores it before M2"


def stop(dialect: str, text: str) -> str:
    """A programmed stop with a message (cycle start goes on)."""
    return f"{'M00' if dialect == FANUC else 'M0'} {nc_comment(dialect, text)}"


def axis_words(names: list[str], values: list[float]) -> str:
    """Axis words with 3 decimals; a Siemens address of more than one character takes '='."""
    return " ".join(f"{n}{'=' if len(n) > 1 else ''}{v:.3f}" for n, v in zip(names, values))


def rapid(dialect: str, names: list[str], values: list[float]) -> str:
    """A rapid move to machine coordinates (mm, deg)."""
    w = axis_words(names, values)
    if dialect == SIEMENS:
        return f"SUPA G0 {w}"
    return f"G90 G53 {'G00' if dialect == FANUC else 'G0'} {w}"


def feed_word(dialect: str, feed: float) -> str:
    """F in mm/min (Fanuc with a decimal point: a feed without one counts in the least increment)."""
    return f"F{feed:.0f}." if dialect == FANUC else f"F{feed:g}"


def approach(dialect: str, names: list[str], start: list[float], end: list[float], feed: float) -> list[str]:
    """The final approach at ``feed`` from machine position ``start`` to ``end``:
    Siemens and LinuxCNC a G1 in machine coordinates; Fanuc (whose G53 moves at rapid) an
    incremental G91 G01 by the difference of the written values, then G90 again."""
    if dialect == FANUC:
        inc = [round(round(e, 3) - round(s, 3), 3) + 0.0 for s, e in zip(start, end)]
        return [f"G91 G01 {axis_words(names, inc)} {feed_word(dialect, feed)}", "G90"]
    w = axis_words(names, end)
    if dialect == SIEMENS:
        return [f"SUPA G1 {w} {feed_word(dialect, feed)}"]
    return [f"G90 G53 G1 {w} {feed_word(dialect, feed)}"]


def dwell(dialect: str, seconds: float) -> str:
    """A dwell: Siemens ``G4 F<s>``, Fanuc ``G04 P<ms>`` (no decimal point), LinuxCNC ``G4 P<s>``."""
    if dialect == SIEMENS:
        return f"G4 F{seconds:.1f}"
    if dialect == FANUC:
        return f"G04 P{int(round(seconds * 1000))}"
    return f"G4 P{seconds:.1f}"
