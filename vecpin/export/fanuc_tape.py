"""The Fanuc parameter tape (a backup's ``CNC-PARA.TXT`` / ``PITCH.TXT``), its syntax only:
leader, ``%`` records, parameter lines ``N<5 digits>Q1`` with per-axis fields
``A<n>P<value>`` (or one ``P<value>``), pitch data ``N<5 digits>Q0P<int>`` (point
``N - 10000``). Forms: real 0i-F / 30i backups (github IlyasMIM/HM100TS,
Jir8taiwan/FanucParameter2CSVoutput), 15i tape format (parameters and pitch data in one
file). What the numbers mean is :mod:`vecpin.export.fanuc`'s.
"""
from __future__ import annotations

import re
from pathlib import Path

from vecpin.errors import ControllerFileError
from vecpin.export.common import read_lines

_PARAM = re.compile(r"^N(\d{5})Q1(.*)$")
_DATA = re.compile(r"^N(\d{5})Q0P(-?\d+)$")
_FIELD = re.compile(r"([ALST])(\d+)([PMI])(-?\d+(?:\.\d*)?)")
_SINGLE = re.compile(r"^[PMI](-?\d+(?:\.\d*)?)$")


def read_tape(path: Path) -> tuple[dict[int, dict], dict[int, int]]:
    """Parameters {number: {axis number: value text}} and pitch data {point: value} of a
    parameter tape; text before the first ``%`` is leader, the second ``%`` ends it."""
    params: dict[int, dict] = {}
    data: dict[int, int] = {}
    inside = done = False
    lines = read_lines(path, "latin-1")
    for no, raw in enumerate(lines, 1):
        text = raw.strip()
        if not text:
            continue
        if text == "%":
            if inside:
                done = True
                inside = False
            elif not done:
                inside = True
            continue
        if not inside:
            continue
        md = _DATA.match(text)
        if md:
            n = int(md.group(1)) - 10000
            if n < 0:
                raise ControllerFileError(path, f"pitch data N{md.group(1)} below N10000", no)
            if n in data:
                raise ControllerFileError(path, f"pitch point {n} is given twice", no)
            data[n] = int(md.group(2))
            continue
        mp = _PARAM.match(text)
        if not mp:
            raise ControllerFileError(path, f"'{text}' is neither a parameter (N<5 digits>Q1...) nor pitch data "
                                      "(N<5 digits>Q0P<int>)", no)
        body = mp.group(2)
        one = _SINGLE.match(body)
        if one:
            params[int(mp.group(1))] = {0: (one.group(1), no)}
            continue
        fields = _FIELD.findall(body)
        if "".join("".join(f) for f in fields) != body:
            raise ControllerFileError(path, f"parameter N{mp.group(1)}: cannot read '{body}' (A<n>P<value>...)", no)
        params[int(mp.group(1))] = {int(n): (v, no) for kind, n, _, v in fields if kind == "A"}
    if not done:
        raise ControllerFileError(path, "no closing % (the tape is cut short)" if inside else "no % record found",
                                  len(lines))
    return params, data
