"""The blocks a measurement program is made of, per NC dialect.

Four dialects (the names :mod:`vecpin.planning.ncprogram` and the sign test use):

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
* ``heidenhain`` (TNC 640 conversational, Klartext): ``BEGIN PGM <name> MM`` first and
  ``END PGM <name> MM`` last, every block numbered from 0; comments after ``;``; a
  straight line ``L`` with signed axis words (``X+100.000``), ``R0`` (no radius
  compensation), ``FMAX`` (rapid) or ``F<mm/min>`` and ``M91``: the coordinates are
  referenced to the machine datum, in that block only, and the tool length is not
  compensated in it (TNC 360 / TNC 406 User's Manuals, "M91/M92"); the dwell is cycle 9,
  ``CYCL DEF 9.0 DWELL TIME`` and ``CYCL DEF 9.1 DWELL <s>`` (active as defined, no
  call: syntax as the TNC user's manuals print it, INFERRED for the TNC 640: its page
  was not found in a public copy); the stop ``STOP`` after a comment that says why.
  ``L M129`` first (TCPM, ``M128``, off: "before positioning with M91 or M92 ... reset
  M128", TNC 620 User's Manual 5/2013 p.340); no ``TOOL CALL``:
  the holder is mounted by hand and ``M91`` blocks ignore the tool length.
"""
from __future__ import annotations

import re
import textwrap

SIEMENS, FANUC, GCODE, HEIDENHAIN = "siemens-840d", "fanuc", "gcode", "heidenhain"


def nc_comment(dialect: str, text: str) -> str:
    """A comment block: ``; text`` (Siemens), ``(TEXT)`` (Fanuc: capitals, no ``;``,
    ``%`` or parentheses inside), ``(text)`` (LinuxCNC: no parentheses inside)."""
    if dialect in (SIEMENS, HEIDENHAIN):
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
    if dialect == HEIDENHAIN:
        return ["L M129"]
    return ["M70", "G21", "G17 G40 G49 G80 G90 G94"]


def epilogue(dialect: str) -> list[str]:
    """The blocks after the last move: LinuxCNC restores the modal state, then the end."""
    if dialect == HEIDENHAIN:
        return []
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
    if dialect == HEIDENHAIN:
        return ("L M129 cancels TCPM (M128) before the first move; M91 acts in its own block only, R0 in every block, "
                "no TOOL CALL: the program changes no other modal state")
    return "M70 saves the modal state (units, distance and feed mode, plane, compensations) and M72 restores it before M2"


def stop(dialect: str, text: str) -> str:
    """A programmed stop with a message (cycle start goes on); Heidenhain: the message
    as a comment block, then ``STOP`` (two lines, each a block)."""
    if dialect == HEIDENHAIN:
        return f"{nc_comment(dialect, text)}\nSTOP"
    return f"{'M00' if dialect == FANUC else 'M0'} {nc_comment(dialect, text)}"


def axis_words(names: list[str], values: list[float], signed: bool = False) -> str:
    """Axis words with 3 decimals; a Siemens address of more than one character takes '=';
    ``signed``: every value with its sign (Heidenhain ``X+100.000``)."""
    if signed:
        return " ".join(f"{n}{v + 0.0:+.3f}" for n, v in zip(names, values))
    return " ".join(f"{n}{'=' if len(n) > 1 else ''}{v:.3f}" for n, v in zip(names, values))


def rapid(dialect: str, names: list[str], values: list[float]) -> str:
    """A rapid move to machine coordinates (mm, deg)."""
    if dialect == HEIDENHAIN:
        return f"L {axis_words(names, values, True)} R0 FMAX M91"
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
    if dialect == HEIDENHAIN:
        return [f"L {axis_words(names, end, True)} R0 F{feed:.0f} M91"]
    w = axis_words(names, end)
    if dialect == SIEMENS:
        return [f"SUPA G1 {w} {feed_word(dialect, feed)}"]
    return [f"G90 G53 G1 {w} {feed_word(dialect, feed)}"]


def dwell(dialect: str, seconds: float) -> str:
    """A dwell: Siemens ``G4 F<s>``, Fanuc ``G04 P<ms>`` (no decimal point), LinuxCNC ``G4 P<s>``,
    Heidenhain cycle 9 (two blocks: ``CYCL DEF 9.0 DWELL TIME``, ``CYCL DEF 9.1 DWELL <s>``)."""
    if dialect == HEIDENHAIN:
        return f"CYCL DEF 9.0 DWELL TIME\nCYCL DEF 9.1 DWELL {seconds:.1f}"
    if dialect == SIEMENS:
        return f"G4 F{seconds:.1f}"
    if dialect == FANUC:
        return f"G04 P{int(round(seconds * 1000))}"
    return f"G4 P{seconds:.1f}"
