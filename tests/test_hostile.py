"""The hostile corpus (issue 16): input a careless, hurried or unlucky user gives every command.

Every refusal is asserted exactly: exit status 2, one ``vecpin: error:`` line with no
traceback, the text naming the place (file and row/column, or the option) and what to
do. Valid but odd files (BOM, CRLF, quoted numbers, shuffled or extra columns, ...) must
give the same model as the clean file, parameter by parameter. Multi-file results are
all-or-nothing (an interruption leaves the previous set), reruns write the same bytes,
output paths are checked before the work, and limits before memory is spent.

The inputs are built from one small simulated campaign (30 commands x 2 tools on the
bundled flow_xyzcb) and its AP order-2 model; each case edits a copy the way a user
would get it wrong. Classes (issue 16): silent wrong results (units, frames, machines,
options outside their meaning), data loss (atomic sets, paths checked first),
tracebacks, memory (limits before work), unclear messages; plus meshes and warnings.
"""
from __future__ import annotations

import json
import math
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from hostile_helpers import ok, refused, simulated_base

from vecpin.cli import main

pytestmark = pytest.mark.slow   # a long matrix: the edit loop (-m 'not slow') leaves it to CI

DATA = Path(__file__).parent / "data"
HOSTILE = DATA / "hostile"
PROFILE = str(DATA / "controllers" / "flow_xyzcb_profile.json")
FIT_FAST = ["--model", "ap", "--order", "2", "--basis", "chebyshev", "--quiet"]


# ------------------------------------------------------------------ helpers
class Table:
    """A campaign CSV as header + rows of text cells, edited like a user would."""

    def __init__(self, text: str):
        lines = text.strip("\n").split("\n")
        self.header = lines[0].split(",")
        self.rows = [ln.split(",") for ln in lines[1:]]

    def copy(self) -> "Table":
        t = Table.__new__(Table)
        t.header, t.rows = list(self.header), [list(r) for r in self.rows]
        return t

    def col(self, name: str) -> int:
        return self.header.index(name)

    def scale(self, names, factor: float, fmt: str = "%.9f") -> "Table":
        for r in self.rows:
            for n in names:
                r[self.col(n)] = fmt % (float(r[self.col(n)]) * factor)
        return self

    def set(self, row: int, name: str, value: str) -> "Table":
        self.rows[row][self.col(name)] = value
        return self

    def add_column(self, name: str, values) -> "Table":
        self.header.append(name)
        for r, v in zip(self.rows, values):
            r.append(str(v))
        return self

    def text(self, sep: str = ",", eol: str = "\n") -> str:
        return eol.join(sep.join(c) for c in [self.header] + self.rows) + eol

    def write(self, path: Path, **kw) -> Path:
        path.write_bytes(self.text(**kw).encode("utf-8"))
        return path


def parameters(model_path) -> dict[str, float]:
    return {p["name"]: p["value"] for p in json.loads(Path(model_path).read_text())["parameters"]}


def files_of(folder: Path) -> dict[str, bytes]:
    """Every file's bytes but the manifest's (it records the time and a new generation id)."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name != "vecpin-manifest.json"}


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    """A simulated campaign of flow_xyzcb (60 rows), its validation file, an AP order-2
    model and its tables; ``work`` is a scratch folder per module."""
    b = simulated_base(tmp_path_factory.mktemp("hostile"), FIT_FAST)
    b.table, b.truth = Table(b.csv.read_text()), b.dir / "sim" / "truth.json"
    return b


@pytest.fixture
def work(tmp_path):
    return tmp_path


# ============================================================ 1. campaign files: refusals
def _semicolon(t):
    return t.text(sep=";")


def _comment_first(t):
    return "# exported by the tracker software, 2024-05-02\n" + t.text()


def _x_1e308(t):
    return t.copy().set(3, "x", "1e308").text()


def _cell_200k(t):
    return t.copy().set(3, "x", "1" * 200_000).text()


def _inches_xyz(t):
    return t.copy().scale("xyz", 1 / 25.4).text()


def _inches_commands(t):
    return t.copy().scale("XYZ", 1 / 25.4).text()


def _tool_cm(t):
    return t.copy().scale(["tool"], 0.1).text()


def _one_tool_in_metres(t):
    c = t.copy()
    return c.set(7, "tool", "%.6f" % (float(c.rows[7][c.col("tool")]) / 1000)).text()


def _swap_xy(t):
    c = t.copy()
    i, j = c.col("x"), c.col("y")
    c.header[i], c.header[j] = c.header[j], c.header[i]
    return c.text()


def _negate_z(t):
    return t.copy().scale("z", -1.0).text()


def _temperature(convert):
    """The temperature column converted from °C by ``convert``."""
    def build(t):
        c = t.copy()
        for r in c.rows:
            r[c.col("temperature")] = "%.3f" % convert(float(r[c.col("temperature")]))
        return c.text()
    return build


def _first_rows(text, n):
    return "\n".join(text.splitlines()[:n + 1]) + "\n"


def _eight_rows_inches(t):
    return _first_rows(t.copy().scale("xyz", 1 / 25.4).text(), 8)


def _eight_rows_metres(t):
    return _first_rows(t.copy().scale("xyz", 1e-3).text(), 8)


def _station(value):
    def build(t):
        return t.copy().add_column("station", ["0"] * 4 + [value] + ["0"] * (len(t.rows) - 5)).text()
    return build


def _ballbar(pivot):
    """Two ball bar rows appended: pivot 1, then ``pivot``."""
    def build(t):
        c = t.copy()
        c.add_column("instrument", ["tracker"] * len(c.rows)).add_column("r", [""] * len(c.rows))
        c.add_column("pivot", [""] * len(c.rows))
        for k in range(2):
            r = list(c.rows[k])
            for n in "xyz":
                r[c.col(n)] = ""
            r[c.col("instrument")], r[c.col("r")], r[c.col("pivot")] = "ballbar", "254.0", ["1", pivot][k]
            r[c.col("time")] = "%.3f" % (float(c.rows[-1][c.col("time")]) + 15 * (k + 1))
            c.rows.append(r)
        return c.text()
    return build


def _unknown_instrument(t):
    return t.copy().add_column("instrument", ["tracker"] * 6 + ["laser"] + ["tracker"] * (len(t.rows) - 7)).text()


def _text_column(t):
    return t.copy().add_column("operator", ["ann"] * len(t.rows)).text()


def _short_row(t):
    c = t.copy()
    c.rows[10] = c.rows[10][:-2]
    return c.text()


def _too_few_rows(t):
    return _first_rows(t.text(), 4)


def _time_backwards(t):
    c = t.copy()
    c.rows[20][c.col("time")], c.rows[21][c.col("time")] = c.rows[21][c.col("time")], c.rows[20][c.col("time")]
    return c.text()


def _outside_limits(t):
    return t.copy().set(12, "X", "7000.0").text()


def _negative_tool(t):
    return t.copy().set(3, "tool", "-214.88").text()


def _radians(t):
    return t.copy().scale("C", math.pi / 180).text()


def _x_in_metres(t):
    return t.copy().scale("X", 1e-3, "%.9f").text()


def _empty_cell(t):
    return t.copy().set(8, "y", "").text()


def _nan_cell(t):
    return t.copy().set(8, "Z", "NaN").text()


def _one_command(t):
    c = t.copy()
    first = c.rows[0]
    for r in c.rows:
        for n in ("X", "Y", "Z", "C", "B", "tool"):
            r[c.col(n)] = first[c.col(n)]
    return c.text()


def _renamed(column, name):
    """The header's ``column`` renamed ``name``."""
    def build(t):
        c = t.copy()
        c.header[c.col(column)] = name
        return c.text()
    return build


CSV_REFUSALS = {  # name -> (builder, fragments: the place and what to do)
    "semicolon-separated": (_semicolon, ["row 1", "semicolon-separated", "vecpin import"]),
    "tab-separated": (lambda t: t.text(sep="\t"), ["row 1", "tab-separated", "vecpin import"]),
    "comment line first": (_comment_first, ["row 1", "comment", "the header is line 2", "delete the comment"]),
    "x = 1e308": (_x_1e308, ["row 5", "column 'x'", "no tracker reading", "fix or delete the row"]),
    "200 kB cell": (_cell_200k, ["row 5", "cannot be split into cells", "is this a campaign file"]),
    "x, y, z in inches": (_inches_xyz, ["column 'x'", "x, y, z in inches while the commands are mm", "fix the units"]),
    "commands in inches": (_inches_commands, ["from the nominal tool tips", "inches or cm"]),
    "tool lengths in cm": (_tool_cm, ["from the nominal tool tips", "inches or cm"]),
    "one tool length in metres": (_one_tool_in_metres, ["row 9", "metres for mm", "fix or delete the row"]),
    "x and y swapped (left-handed)": (_swap_xy, ["mirror image", "left-handed", "fix the columns"]),
    "z negated (left-handed)": (_negate_z, ["mirror image", "left-handed", "fix the columns"]),
    "temperature in °F": (_temperature(lambda c: c * 9 / 5 + 32),
                          ["row 2", "column 'temperature'", "°F", "convert the column"]),
    "temperature in kelvin": (_temperature(lambda c: c + 273.15), ["row 2", "column 'temperature'", "kelvin"]),
    "8 rows, x/y/z in inches": (_eight_rows_inches, ["column 'x'", "x, y, z in inches while", "fix the units"]),
    "8 rows, x/y/z in metres": (_eight_rows_metres, ["column 'x'", "x, y, z in metres", "fix the units"]),
    "station id 1e20": (_station("1e20"), ["row 6", "column 'station'", "whole number 0 .. 9999"]),
    "station id -1": (_station("-1"), ["row 6", "column 'station'", "whole number"]),
    "station id 1.5": (_station("1.5"), ["row 6", "column 'station'", "whole number"]),
    "ball bar pivot 1.5 beside 1": (_ballbar("1.5"), ["row 63", "column 'pivot'", "whole number"]),
    "unknown instrument": (_unknown_instrument, ["row 8", "column 'instrument'", "tracker, ballbar, nest"]),
    "text column": (_text_column, ["row 2", "column 'operator'", "delete the column"]),
    "row with too few cells": (_short_row, ["row 12", "cells where the header has", "fix the row"]),
    "4 rows": (_too_few_rows, ["only 4 rows", "at least 5", "measure more points"]),
    "time goes backwards": (_time_backwards, ["row 23", "column 'time'", "measurement order"]),
    "command beyond the limits": (_outside_limits, ["row 14", "column 'X'", "outside the axis limits",
                                                    "Fix or delete the row"]),
    "negative tool length": (_negative_tool, ["row 5", "column 'tool'", "negative tool length", "fix the row"]),
    "rotary column in radians": (_radians, ["column 'C'", "radians", "degrees"]),
    "axis column in metres": (_x_in_metres, ["column 'X'", "metres", "in mm"]),
    "empty cell": (_empty_cell, ["row 10", "column 'y'", "fill it or delete the row"]),
    "NaN cell": (_nan_cell, ["row 10", "column 'Z'", "not a finite number", "fill in the measured value"]),
    "one command only": (_one_command, ["on a line", "measure commands spread over the travel"]),
    "axis column in lower case": (_renamed("B", "b"), ["row 1", "column 'B'", "found 'b'", "case-sensitive"]),
    "axis of another machine": (_renamed("B", "A"), ["row 1", "column 'A'", "another machine"]),
    "duplicate column": (_renamed("time", "temperature"),
                         ["row 1", "column 'temperature'", "duplicate column", "rename"]),
}


@pytest.mark.parametrize("case", sorted(CSV_REFUSALS))
def test_campaign_refused_by_fit(base, work, capsys, case):
    build, fragments = CSV_REFUSALS[case]
    path = work / "campaign.csv"
    path.write_text(build(base.table), encoding="utf-8")
    out = work / "model.json"
    msg = refused(["fit", "flow_xyzcb", path, "--out", out] + FIT_FAST, capsys, *fragments)
    assert str(path) in msg
    assert not out.exists()


def test_not_utf8_files_are_refused(base, work, capsys):
    utf16 = work / "utf16.csv"
    utf16.write_bytes(base.table.text().encode("utf-16"))
    refused(["fit", "flow_xyzcb", utf16, "--out", work / "m.json"] + FIT_FAST, capsys, str(utf16), "not a UTF-8")
    png = work / "picture.csv"
    png.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)))
    refused(["fit", "flow_xyzcb", png, "--out", work / "m.json"] + FIT_FAST, capsys, str(png), "not a UTF-8")


def test_empty_and_header_only_files(base, work, capsys):
    empty = work / "empty.csv"
    empty.write_text("")
    refused(["fit", "flow_xyzcb", empty, "--out", work / "m.json"] + FIT_FAST, capsys, str(empty), "empty")
    head = work / "head.csv"
    head.write_text(",".join(base.table.header) + "\n\n")
    refused(["fit", "flow_xyzcb", head, "--out", work / "m.json"] + FIT_FAST, capsys, str(head), "no measurement rows")


def test_metres_in_a_campaign_spanning_less_than_100_mm(flow, work, capsys, rng):
    """A small campaign (linear commands within 80 mm, rotaries still) with x, y, z in metres."""
    from vecpin.kinematics.so3 import exp3
    n = 40
    q = np.zeros((n, 5))
    q[:, :3] = np.array([3.0, 1.2, 0.5]) + rng.uniform(0, 0.05, (n, 3))  # < 100 mm between any two
    q[:, 3:] = rng.uniform(-1.0, 1.0, (n, 2))  # the rotaries move: only the linear commands span < 100 mm
    tool = np.repeat([0.21488, 0.31286], n // 2)
    R = exp3(np.array([0.1, -0.2, 2.0]))
    xyz = flow.tool_tip(q, tool) @ R.T + np.array([2.0, -1.0, 0.3])
    qu = flow.to_user(q)
    rows = [",".join(f"{v:.6f}" for v in list(qu[k]) + [tool[k] * 1e3] + list(xyz[k])) for k in range(n)]
    path = work / "small.csv"
    path.write_text("X,Y,Z,C,B,tool,x,y,z\n" + "\n".join(rows) + "\n")
    refused(["fit", "flow_xyzcb", path, "--out", work / "m.json"] + FIT_FAST, capsys, str(path), "column 'x'",
            "x, y, z in metres", "fix the units")


# the same reader behind every other command that takes a campaign
OTHER_COMMANDS = {
    "evaluate": lambda b, p, w: ["evaluate", b.model, p],
    "orders": lambda b, p, w: ["orders", "flow_xyzcb", p, "--orders", "1,2", "--quiet"],
    "diagnose": lambda b, p, w: ["diagnose", "flow_xyzcb", p, "--out", w / "d", "--quiet"],
    "view --html": lambda b, p, w: ["view", b.model, p, "--html", w / "v.html"],
    "report": lambda b, p, w: ["report", b.model, p, "--out", w / "r", "--quiet"],
    "tables --commands": lambda b, p, w: ["tables", b.model, "--commands", p, "--out", w / "t", "--quiet"],
    "assess": lambda b, p, w: ["assess", p, "--machine", "flow_xyzcb"],
    "verify (before)": lambda b, p, w: ["verify", p, b.val, "--machine", "flow_xyzcb"],
    "verify (after)": lambda b, p, w: ["verify", b.val, p, "--machine", "flow_xyzcb"],
    "orders --validation": lambda b, p, w: ["orders", "flow_xyzcb", b.csv, "--validation", p, "--orders", "1"],
    "report --validation": lambda b, p, w: ["report", b.model, b.csv, "--validation", p, "--out", w / "r"],
}


@pytest.mark.parametrize("command, case", [(c, k) for c in sorted(OTHER_COMMANDS)
                                           for k in ("empty cell", "200 kB cell", "x, y, z in inches")
                                           if not (c == "tables --commands" and k == "x, y, z in inches")])
def test_campaign_refused_by_every_command(base, work, capsys, command, case):
    build, fragments = CSV_REFUSALS[case]
    path = work / "bad.csv"
    path.write_text(build(base.table), encoding="utf-8")
    refused(OTHER_COMMANDS[command](base, path, work), capsys, str(path), *fragments)


def test_tables_use_only_the_commands_of_a_campaign(base, work, capsys):
    """``tables --commands`` takes the commands and tools of a campaign, not its x, y, z:
    a file with x, y, z in inches gives the same tables as the clean one."""
    bad = work / "inches.csv"
    bad.write_text(_inches_xyz(base.table))
    ok(["tables", base.model, "--commands", base.csv, "--out", work / "a", "--quiet"], capsys)
    ok(["tables", base.model, "--commands", bad, "--out", work / "b", "--quiet"], capsys)
    assert (work / "a" / "tables.json").read_bytes() == (work / "b" / "tables.json").read_bytes()


# ============================================================ 2. valid but odd: the same model
def _bom(t):
    return "\ufeff" + t.text()


def _shuffled(t):
    c = t.copy()
    order = [6, 0, 9, 3, 7, 1, 10, 4, 8, 2, 5]
    c.header = [c.header[k] for k in order]
    c.rows = [[r[k] for k in order] for r in c.rows]
    return c.text()


def _quoted(t):
    c = t.copy()
    c.header = [f'"{h}"' for h in c.header]
    c.rows = [[f'"{v}"' for v in r] for r in c.rows]
    return c.text()


def _spaces(t):
    c = t.copy()
    c.header = [f" {h}  " for h in c.header]
    c.rows = [[f"  {v} " for v in r] for r in c.rows]
    return c.text()


def _extra_columns(t):
    c = t.copy()
    c.add_column("humidity", [f"{40 + k * 0.1:.1f}" for k in range(len(c.rows))])
    return c.add_column("operator_id", ["7"] * len(c.rows)).text()


def _blank_lines(t):
    lines = t.text().splitlines()
    return "\n".join(lines[:10] + [""] + lines[10:30] + ["   ", ""] + lines[30:]) + "\n\n\n"


def _exponents(t):
    c = t.copy()
    for r in c.rows:
        r[c.col("x")] = "%+.9e" % float(r[c.col("x")])
    return c.text()


VALID_ODD = {
    "UTF-8 BOM": _bom,
    "CRLF line ends": lambda t: t.text(eol="\r\n"),
    "CR line ends": lambda t: t.text(eol="\r"),
    "quoted cells": _quoted,
    "shuffled columns": _shuffled,
    "spaces around cells": _spaces,
    "extra numeric columns": _extra_columns,
    "blank lines": _blank_lines,
    "signed exponents": _exponents,
}


@pytest.mark.parametrize("case", sorted(VALID_ODD))
def test_valid_but_odd_file_gives_the_same_model(base, work, capsys, case):
    path = work / "odd.csv"
    path.write_bytes(VALID_ODD[case](base.table).encode("utf-8"))
    out = work / "odd.json"
    ok(["fit", "flow_xyzcb", path, "--out", out] + FIT_FAST, capsys)
    clean, odd = parameters(base.model), parameters(out)
    assert clean.keys() == odd.keys()
    np.testing.assert_allclose([odd[k] for k in clean], list(clean.values()), rtol=1e-9, atol=1e-12)


def test_fast_reader_and_cell_by_cell_reader_agree(base, flow, work, monkeypatch):
    """The numpy reader of plain files and the csv reader used for messages give the same
    campaign (commands, tools, points, extra columns, line numbers)."""
    import vecpin.measurement.campaign as cm
    path = work / "odd.csv"
    path.write_text(_extra_columns(base.table))
    fast = cm.read_campaign(path, flow)
    monkeypatch.setattr(cm, "_parse_fast", lambda *a: None)
    slow = cm.read_campaign(path, flow)
    for a, b in ((fast.q, slow.q), (fast.tool, slow.tool), (fast.xyz, slow.xyz), (fast.lines, slow.lines),
                 (fast.extra["humidity"], slow.extra["humidity"])):
        np.testing.assert_array_equal(a, b)
    raw = np.genfromtxt(path, delimiter=",", names=True)  # a second reader
    np.testing.assert_allclose(fast.xyz[:, 0], raw["x"] * 1e-3, rtol=1e-15)


def test_duplicated_rows_are_warned_about(base, work, capsys):
    c = base.table.copy()
    c.rows = c.rows[:20] + c.rows[19:20] + c.rows[20:]  # row 21 (line) pasted twice; time stays monotone
    path = c.write(work / "dup.csv")
    cap = ok(["fit", "flow_xyzcb", path, "--out", work / "dup.json"] + FIT_FAST, capsys)
    warn = [ln for ln in cap.err.splitlines() if ln.startswith("vecpin: warning:")]
    assert len(warn) == 1 and str(path) in warn[0] and "row 22 = row 21" in warn[0] and "pasted twice" in warn[0]


# ============================================================ 3. options outside their meaning
def _argv(prefix):
    """Argv builders of one command: ``prefix(base, work)`` then the options given."""
    return lambda *options: lambda b, w: [*prefix(b, w), *options]


_simulate = _argv(lambda b, w: ["simulate", "flow_xyzcb", "--out", w / "s"])
_tables = _argv(lambda b, w: ["tables", b.model, "--out", w / "t"])
_diagnose = _argv(lambda b, w: ["diagnose", "flow_xyzcb", b.csv, "--out", w / "d"])
_fit = _argv(lambda b, w: ["fit", "flow_xyzcb", b.csv, "--out", w / "m.json"])


OPTION_REFUSALS = {  # name -> (argv builder, fragments)
    # fit
    "fit --prior-scale 0": (_fit("--prior-scale", "0"), ["--prior-scale 0", "positive"]),
    "fit --prior-scale -1": (_fit("--prior-scale", "-1"), ["--prior-scale -1", "positive"]),
    "fit --tracker-sigma-mm nan": (_fit("--tracker-sigma-mm", "nan"), ["--tracker-sigma-mm nan", "positive"]),
    "fit --repeatability-mm -0.006": (_fit("--repeatability-mm", "-0.006"), ["--repeatability-mm", "positive"]),
    "fit --tracker-noise negative": (_fit("--tracker-noise", "-1", "0", "0", "0"),
                                     ["--tracker-noise", "four numbers >= 0"]),
    "fit --ballbar-sigma-mm 0": (_fit("--ballbar-sigma-mm", "0"), ["--ballbar-sigma-mm", "positive"]),
    "fit --folds 1": (_fit("--folds", "1"), ["--folds 1", "at least 2 folds"]),
    "fit --folds 0 (fixed model)": (lambda b, w: ["fit", "flow_xyzcb", b.csv, "--out", w / "m.json", "--folds", "0"]
                                    + FIT_FAST, ["--folds 0", "at least 2 folds"]),
    "fit --folds 1000": (_fit("--folds", "1000"), ["--folds 1000", "30 distinct commands", "at most 30 folds"]),
    "fit --order -1": (_fit("--order", "-1"), ["--order -1", ">= 0"]),
    "fit --order six": (_fit("--order", "six"), ["--order 'six'", "whole number"]),
    "fit --order 40": (_fit("--order", "40", "--model", "ap", "--basis", "chebyshev"),
                       ["180 equations", "lower --order"]),
    "fit --order 500 --underdetermined": (_fit("--order", "500", "--model", "6dof", "--basis", "chebyshev",
                                               "--underdetermined"), ["--order 500", "GB", "lower --order"]),
    "fit --multilateration, one station": (_fit("--multilateration"), ["--multilateration", "1 tracker station",
                                                                       "at least 4", "without --multilateration"]),
    # orders
    "orders 7-0": (lambda b, w: ["orders", "flow_xyzcb", b.csv, "--orders", "7-0"], ["--orders '7-0'", "0-7"]),
    "orders -1": (lambda b, w: ["orders", "flow_xyzcb", b.csv, "--orders", "-1"], ["--orders '-1'", ">= 0"]),
    "orders six": (lambda b, w: ["orders", "flow_xyzcb", b.csv, "--orders", "six"], ["--orders 'six'", "0-7"]),
    "orders 0-500": (lambda b, w: ["orders", "flow_xyzcb", b.csv, "--orders", "0-500"],
                     ["--orders", "unknowns", "determines orders up to"]),
    "orders --folds 0": (lambda b, w: ["orders", "flow_xyzcb", b.csv, "--orders", "1", "--folds", "0"],
                         ["--folds 0", "at least 2"]),
    "orders --multilateration": (lambda b, w: ["orders", "flow_xyzcb", b.csv, "--orders", "1",
                                               "--multilateration"], ["--multilateration", "at least 4"]),
    # simulate
    "simulate --points 0": (_simulate("--points", "0"), ["--points 0", "whole number 1 or more"]),
    "simulate --points -5": (_simulate("--points", "-5"), ["--points -5"]),
    "simulate --points 2 (unreadable)": (_simulate("--points", "2"),
                                         ["--points 2", "at least 5", "--points 3 or more"]),
    "simulate --points 1e8": (_simulate("--points", "100000000"), ["200,000,035 rows", "at most 1,300,000", "600 GB"]),
    "simulate --seed -1": (_simulate("--seed", "-1"), ["--seed -1", ">= 0"]),
    "simulate --stations 0": (_simulate("--stations", "0"), ["--stations 0", "1 .. 10000"]),
    "simulate --tools -100": (_simulate("--tools", "-100"), ["--tools -100", "mm from the gauge line"]),
    "simulate --tools 0.2 0.3 (metres)": (_simulate("--tools", "0.2", "0.3"), ["--tools 0.2 0.3", "not metres"]),
    "simulate --mean-error nan": (_simulate("--mean-error", "nan"), ["--mean-error nan", "mm > 0"]),
    "simulate --mean-error -1": (_simulate("--mean-error", "-1"), ["--mean-error -1", "mm > 0"]),
    "simulate --effect strength=abc": (_simulate("--effect", "gantry_skew:axes=Y,about=x,depends=X,strength=abc"),
                                       ["--effect", "strength='abc'"]),
    "simulate --effect unknown": (_simulate("--effect", "wobble"), ["--effect 'wobble'", "known:"]),
    "simulate --validation-count 0": (_simulate("--validation-count", "0"),
                                      ["--validation-count 0", "at least 5 rows"]),
    "simulate --ballbar -3": (_simulate("--ballbar", "-3"), ["--ballbar -3", "0 or more"]),
    "simulate --repeat -1 3": (_simulate("--repeat", "-1", "3"), ["--repeat -1 3", "at least 1 command"]),
    "simulate --tracker nan,0,0": (_simulate("--tracker", "nan,0,0"), ["--tracker", "finite"]),
    "simulate --exclude everything": (_simulate("--exclude", "X=-10:7000"), ["--exclude", "make them smaller"]),
    "simulate --exclude unknown axis": (_simulate("--exclude", "Q=0:1"), ["--exclude", "no axis 'Q'"]),
    "simulate --exclude reversed": (_simulate("--exclude", "X=500:0"), ["--exclude 'X=500:0'", "X=0:500"]),
    # tables
    "tables --table-points -5": (_tables("--table-points", "-5"), ["--table-points -5", "at least 2 points"]),
    "tables --table-points 1e7": (_tables("--table-points", "10000000"),
                                  ["--table-points 10000000", "100000 or fewer"]),
    "tables --max-tables -1": (_tables("--max-tables", "-1"), ["--max-tables -1", ">= 0"]),
    "tables --max-tables 70 (840D)": (_tables("--max-tables", "70", "--controller", "siemens-840d",
                                              "--profile", PROFILE), ["at most 64", "--max-tables 64 or fewer"]),
    "tables --axis-map X=X1 Y=X1": (_tables("--axis-map", "X=X1", "--axis-map", "Y=X1"),
                                    ["--axis-map", "X, Y", "own NC axis"]),
    "tables --axis-map Q=X1": (_tables("--axis-map", "Q=X1"), ["--axis-map Q=X1", "no axis 'Q'"]),
    "tables --axis-map X": (_tables("--axis-map", "X"), ["--axis-map", "JOINT=NCNAME"]),
    "tables --forbid-output Q": (_tables("--forbid-output", "Q"), ["--forbid-output Q", "no axis 'Q'"]),
    "tables --modulo B (less than a turn)": (_tables("--modulo", "B"),
                                             ["--modulo B", "less than a turn", "leave out --modulo B"]),
    "tables --modulo X (linear)": (_tables("--modulo", "X"), ["--modulo X", "linear"]),
    "tables --tools -100": (_tables("--tools", "-100"), ["--tools -100", "mm from the gauge line"]),
    "tables --tools nan": (_tables("--tools", "nan"), ["--tools nan"]),
    "tables --sign-test Q": (_tables("--sign-test", "Q", "--controller", "siemens-840d", "--profile", PROFILE),
                             ["--sign-test Q", "neither an axis"]),
    "tables --profile missing": (lambda b, w: ["tables", b.model, "--out", w / "t", "--profile", w / "none.json"],
                                 ["--profile", "no such file"]),
    # diagnose
    "diagnose --alpha nan": (_diagnose("--alpha", "nan"), ["--alpha nan", "between 0 and 1"]),
    "diagnose --alpha 2": (_diagnose("--alpha", "2"), ["--alpha 2", "between 0 and 1"]),
    "diagnose --folds 1": (_diagnose("--folds", "1"), ["--folds 1", "at least 2"]),
    "diagnose --folds 500": (_diagnose("--folds", "500"), ["--folds 500", "at most 30 folds"]),
    "diagnose --effects ,": (_diagnose("--effects", ","), ["--effects ','", "comma list"]),
    "diagnose --effects bogus": (_diagnose("--effects", "bogus"),
                                 ["--effects 'bogus'", "unknown effect 'bogus'", "known:"]),
    "diagnose --multilateration": (_diagnose("--multilateration"), ["--multilateration", "at least 4"]),
    # view
    "view --row 5000": (lambda b, w: ["view", b.model, b.csv, "--row", "5000", "--html", w / "v.html"],
                        ["--row 5000", "rows 2 .. 61", "the header is row 1"]),
    "view --row -1": (lambda b, w: ["view", b.model, b.csv, "--row", "-1", "--html", w / "v.html"],
                      ["--row -1", "rows 2 .. 61"]),
    "view --row 1": (lambda b, w: ["view", b.model, b.csv, "--row", "1", "--html", w / "v.html"],
                     ["--row 1", "rows 2 .. 61"]),
    "view --exaggerate nan": (lambda b, w: ["view", b.model, b.csv, "--exaggerate", "nan", "--html", w / "v.html"],
                              ["--exaggerate 'nan'", "factor > 0"]),
    "view --exaggerate inf": (lambda b, w: ["view", b.model, b.csv, "--exaggerate", "inf", "--html", w / "v.html"],
                              ["--exaggerate 'inf'"]),
    "view --exaggerate errors=-3": (lambda b, w: ["view", b.model, b.csv, "--exaggerate", "errors=-3", "--html",
                                                  w / "v.html"], ["--exaggerate 'errors=-3'", "GROUP=FACTOR"]),
    "view --show compensated --no-tables": (lambda b, w: ["view", b.model, b.csv, "--show", "compensated",
                                                          "--no-tables", "--html", w / "v.html"],
                                            ["--show compensated", "drop --no-tables"]),
    # report
    "report --orders 7-0": (lambda b, w: ["report", b.model, b.csv, "--out", w / "r", "--orders", "7-0"],
                            ["--orders '7-0'"]),
    "report --orders 0-300": (lambda b, w: ["report", b.model, b.csv, "--out", w / "r", "--orders", "0-300",
                                            "--quiet"], ["--orders", "determines orders up to"]),
    # demo
    "demo --order -1": (lambda b, w: ["demo", "--out", w / "demo", "--order", "-1"], ["--order -1", "whole number"]),
    "demo --order 99": (lambda b, w: ["demo", "--out", w / "demo", "--order", "99"],
                        ["--order 99", "equations", "order 6"]),
    "demo --seed -1": (lambda b, w: ["demo", "--out", w / "demo", "--seed", "-1"], ["--seed -1", ">= 0"]),
    # plan
    "plan --points 0": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--points", "0"], ["--points 0"]),
    "plan --points 1e7": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--points", "10000000"],
                          ["--points 10000000", "at most 10000", "plan fewer"]),
    "plan --tools nan": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--tools", "nan"],
                         ["--tools", "mm from the gauge line"]),
    "plan --tools -100": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--tools", "-100"], ["--tools"]),
    "plan --tracker nan,0,0": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--tracker", "nan,0,0"],
                               ["--tracker", "finite"]),
    "plan --order 99": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--points", "20", "--order", "99"],
                        ["--order 99", "unknowns", "plan more --points or a lower --order"]),
    "plan --candidates 0": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--candidates", "0"],
                            ["--candidates 0", "between --points"]),
    "plan --seed -1": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--seed", "-1"], ["--seed -1"]),
    "plan --tool-radius-mm -1": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--tool-radius-mm", "-1"],
                                 ["--tool-radius-mm -1", ">= 0"]),
    "plan --target-clearance-mm nan": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p",
                                                     "--target-clearance-mm", "nan"], ["--target-clearance-mm nan"]),
    "plan --rapid-mm-min 0": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--rapid-mm-min", "0"],
                              ["--rapid-mm-min 0", "> 0"]),
    "plan --zone X=5:1": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--zone", "X=5:1"],
                          ["--zone 'X=5:1'", "X=1:5"]),
    "plan --exclude Q=0:1": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--exclude", "Q=0:1"],
                             ["--exclude", "no axis 'Q'"]),
    "plan --dwell -1": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--dwell", "-1", "--order", "1"],
                        ["--dwell -1", "> 0"]),
    # import
    "import --tool-mm -5": (lambda b, w: ["import", b.csv, "--machine", "flow_xyzcb", "--out", w / "i.csv",
                                          "--tool-mm", "-5"], ["--tool-mm -5", "mm"]),
    "import --columns x": (lambda b, w: ["import", b.csv, "--machine", "flow_xyzcb", "--out", w / "i.csv",
                                         "--columns", "x"], ["--columns 'x'", "FIELD=EXPORT COLUMN"]),
    "import --units in (mm file)": (lambda b, w: ["import", b.csv, "--machine", "flow_xyzcb", "--out", w / "i.csv",
                                                  "--units", "in"], ["column 'x'", "give --units mm"]),
    # assess
    "assess nothing": (lambda b, w: ["assess"], ["give a campaign CSV", "--mean-error"]),
    "assess --mean-error nan": (lambda b, w: ["assess", "--mean-error", "nan", "--long-term", "0.01"],
                                ["--mean-error", "positive"]),
    "assess --max-error below the mean": (lambda b, w: ["assess", "--mean-error", "0.5", "--long-term", "0.01",
                                                        "--max-error", "0.1"], ["--max-error 0.1", "--mean-error 0.5"]),
    "assess --long-term -1": (lambda b, w: ["assess", "--mean-error", "0.5", "--long-term", "-1"],
                              ["--long-term -1", "positive"]),
    "assess --session-gap-min -1": (lambda b, w: ["assess", b.csv, "--machine", "flow_xyzcb", "--session-gap-min",
                                                  "-1"], ["--session-gap-min -1", "minutes > 0"]),
    "assess --tracker-noise negative": (lambda b, w: ["assess", b.csv, "--machine", "flow_xyzcb", "--tracker-noise",
                                                      "-1", "0", "0", "0"], ["--tracker-noise", ">= 0"]),
    "assess CSV without --machine": (lambda b, w: ["assess", b.csv], ["needs --machine"]),
    "assess CSV without repeats": (lambda b, w: ["assess", b.csv, "--machine", "flow_xyzcb"],
                                   ["no command is measured twice", "plan repeated points", "repeat_points"]),
    # verify
    "verify without a machine": (lambda b, w: ["verify", b.val, b.val], ["needs --machine, or --model-file"]),
    "verify --machine and --model-file disagree": (lambda b, w: ["verify", b.val, b.val, "--machine", "trunnion_xyzbc",
                                                            "--model-file", b.model],
                                              ["--machine trunnion_xyzbc", "--model-file", "use files of one machine"]),
    "verify --tables missing": (lambda b, w: ["verify", b.val, b.val, "--machine", "flow_xyzcb", "--tables",
                                              w / "none"], ["--tables", "no such file or folder"]),
    "evaluate --sign-test-file missing": (lambda b, w: ["evaluate", b.model, b.csv, "--sign-test-file", w / "none.json"],
                                     ["--sign-test-file", "no such file"]),
    "plan --compare missing (before planning)": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--compare",
                                                               w / "none.csv"], ["none.csv", "no such plan file"]),
    "plan --feed inf": (lambda b, w: ["plan", "flow_xyzcb", "--out", w / "p", "--feed", "inf"],
                        ["--feed inf", "mm/min > 0"]),
    "simulate --plan not a plan": (lambda b, w: ["simulate", "flow_xyzcb", "--out", w / "s", "--plan", b.csv],
                                   ["row 1", "column 'point'", "plan template"]),
    # info
    "info unknown machine": (lambda b, w: ["info", "flow_xyzcbb"], ["'flow_xyzcbb'", "bundled:"]),
    "info --tool-link unknown": (lambda b, w: ["info", "flow_xyzcb", "--tool-link", "holder"],
                                 ["no link named 'holder'", "--tool-link NAME"]),
    "info --tool-axis w": (lambda b, w: ["info", "flow_xyzcb", "--tool-axis=w"], ["--tool-axis 'w'", "+x, -x"]),
}


@pytest.mark.parametrize("case", sorted(OPTION_REFUSALS))
def test_option_outside_its_meaning(base, work, capsys, case):
    build, fragments = OPTION_REFUSALS[case]
    refused(build(base, work), capsys, *fragments)


def test_max_tables_0_and_every_output_forbidden_give_pitch_tables(base, work, capsys):
    out = ok(["tables", base.model, "--out", work / "t0", "--max-tables", "0", "--quiet"], capsys).out
    assert "tables: xx yy zz cc bb  (5 tables" in out and "--max-tables 0: pitch tables only" in out
    argv = ["tables", base.model, "--out", work / "t1", "--max-tables", "3", "--quiet"]
    for a in "XYZCB":
        argv += ["--forbid-output", a]
    out = ok(argv, capsys).out
    assert "tables: xx yy zz cc bb  (5 tables" in out and "every cross table is forbidden" in out
    assert json.loads((work / "t1" / "tables.json").read_text())["tables"][0]["name"] == "xx"


def test_limits_are_checked_before_memory_is_spent(base, work, capsys, monkeypatch):
    """--points 1e8 (simulate), 1e7 (plan; --table-points, tables) and --orders 0-500 are refused before any
    array is allocated: the heavy functions are never reached."""
    import vecpin.compensation.plan as cp
    import vecpin.planning.candidates as pp
    import vecpin.selection.choice as ch
    import vecpin.simulation.simulate as ss

    def never(*a, **k):
        raise AssertionError("reached the computation")
    for mod, name in ((ss, "design_commands"), (pp, "candidate_commands"), (cp, "TableProblem"),
                      (ch, "_Problem")):
        monkeypatch.setattr(mod, name, never)
    refused(["simulate", "flow_xyzcb", "--out", work / "s", "--points", "100000000"], capsys, "--points")
    refused(["plan", "flow_xyzcb", "--out", work / "p", "--points", "10000000"], capsys, "--points 10000000")
    refused(["tables", base.model, "--out", work / "t", "--table-points", "10000000"], capsys, "--table-points 10000000")
    refused(["orders", "flow_xyzcb", base.csv, "--orders", "0-500"], capsys, "--orders")


# ============================================================ 4. URDFs through the commands
def _robot(joint_name="X", axis="1 0 0", limit="<limit lower='0' upper='1' effort='1' velocity='1'/>"):
    return (f"<robot name='r'><link name='base'/><link name='spindle'/><joint name='{joint_name}' type='prismatic'>"
            f"<parent link='base'/><child link='spindle'/><axis xyz='{axis}'/>{limit}</joint></robot>")


URDF_REFUSALS = {  # file name -> (text, command, fragments)
    "zero_axis.urdf": (_robot(axis="0 0 0"), "simulate", ["joint 'X' has a zero <axis"]),
    "joint_x.urdf": (_robot(joint_name="x"), "simulate", ["named like the campaign column 'x'", "rename the joint"]),
    "joint_tool.urdf": (_robot(joint_name="tool"), "plan", ["campaign column 'tool'", "rename the joint"]),
    "joint_comma.urdf": (_robot(joint_name="X,1"), "fit", ["space, comma or quote", "rename the joint"]),
    "no_limit.urdf": (_robot(limit=""), "info", ["joint 'X' has no <limit>"]),
    "robot.urdf.xacro": ("<robot name='r' xmlns:xacro='http://www.ros.org/wiki/xacro'/>", "info",
                         ["expand the xacro first"]),
    "binary.urdf": ("\x89PNG\r\n\x1a\n\x00\x00", "simulate", ["binary content"]),
    "deep.urdf": (None, "info", ["more than 256 joints"]),
}


@pytest.mark.parametrize("fname", sorted(URDF_REFUSALS))
def test_urdf_that_is_no_machine(base, work, capsys, fname):
    text, command, fragments = URDF_REFUSALS[fname]
    path = work / fname
    if text is None:  # a 5,000-deep chain: once a segmentation fault in the parser
        links = "".join(f"<link name='l{i}'/>" for i in range(5001))
        joints = "".join(f"<joint name='j{i}' type='fixed'><parent link='l{i}'/><child link='l{i + 1}'/></joint>"
                         for i in range(5000))
        text = f"<robot name='deep'>{links}{joints}</robot>"
    path.write_bytes(text.encode("latin-1"))
    argv = {"info": ["info", path], "simulate": ["simulate", path, "--out", work / "s"],
            "plan": ["plan", path, "--out", work / "p"],
            "fit": ["fit", path, base.csv, "--out", work / "m.json"]}[command]
    refused(argv, capsys, str(path), *fragments)


def test_mimic_joint_is_not_an_independent_axis(work, capsys):
    """W follows Z (mimic, multiplier -0.5): it is no axis and no campaign column, and the
    tool tip moves by X, Y and Z / 2 (closed form)."""
    import vecpin
    lim = "<limit lower='0' upper='1' effort='1' velocity='1'/>"
    joints = [("X", "base", "a", "1 0 0", ""), ("Y", "a", "b", "0 1 0", ""), ("Z", "b", "c", "0 0 1", ""),
              ("W", "c", "spindle", "0 0 1", "<mimic joint='Z' multiplier='-0.5'/>")]
    text = ("<robot name='mimic'>" + "".join(f"<link name='{n}'/>" for n in ("base", "a", "b", "c", "spindle"))
            + "".join(f"<joint name='{n}' type='prismatic'><parent link='{p}'/><child link='{c}'/><axis xyz='{a}'/>"
                      f"{lim}{x}</joint>" for n, p, c, a, x in joints) + "</robot>")
    path = work / "mimic.urdf"
    path.write_text(text)
    out = ok(["info", path], capsys).out
    m = vecpin.Machine.load(path)
    assert m.axis_names == ["X", "Y", "Z"] and [j.name for j in m.mimic_joints] == ["W"] and "3 axes" in out
    q = np.array([[0.1, 0.2, 0.4], [0.0, 0.0, 0.0]])
    tip = m.tool_tip(q, 0.0)
    np.testing.assert_allclose(tip[0] - tip[1], [0.1, 0.2, 0.2], atol=1e-12)
    ok(["simulate", path, "--out", work / "s", "--points", "10", "--validation-count", "5"], capsys)
    assert (work / "s" / "campaign.csv").read_text().splitlines()[0].split(",")[:4] == ["X", "Y", "Z", "tool"]


# ============================================================ 5. model, table and profile files
def _model_edit(base, work, name, edit):
    d = json.loads(base.model.read_text())
    edit(d)
    p = work / name
    p.write_text(json.dumps(d))
    return p


MODEL_REFUSALS = {  # name -> (editor or raw text, field named, command)
    "NaN parameter": (lambda d: d["parameters"][8].__setitem__("value", float("nan")), "field 'parameters'",
                      "evaluate"),
    "non-orthonormal rotation": (lambda d: d["tracker"]["rotation"][0].__setitem__(0, 1.5),
                                 "field 'tracker.rotation'", "tables"),
    "mirror rotation": (lambda d: d["tracker"].__setitem__("rotation", [[1, 0, 0], [0, 1, 0], [0, 0, -1]]),
                        "field 'tracker.rotation'", "view"),
    "URDF edited": (lambda d: d["machine"].__setitem__("urdf", d["machine"]["urdf"].replace("6.101", "6.2")),
                    "field 'machine.urdf'", "report"),
    "version 9": (lambda d: d.__setitem__("version", 9), "field 'version'", "evaluate"),
    "not a model": (lambda d: d.__setitem__("format", "vecpin-tables"), "field 'format'", "verify"),
    "parameter missing": (lambda d: d["parameters"].pop(), "field 'parameters'", "evaluate"),
    "field missing": (lambda d: d.pop("tracker"), "field 'tracker'", "tables"),
}


@pytest.mark.parametrize("case", sorted(MODEL_REFUSALS))
def test_model_file_refused_naming_file_and_field(base, work, capsys, case):
    edit, field, command = MODEL_REFUSALS[case]
    p = _model_edit(base, work, "bad.json", edit)
    argv = {"evaluate": ["evaluate", p, base.csv], "tables": ["tables", p, "--out", work / "t"],
            "view": ["view", p, base.csv, "--html", work / "v.html"], "report": ["report", p, base.csv, "--out",
                                                                                 work / "r"],
            "verify": ["verify", base.val, base.val, "--model-file", p]}[command]
    refused(argv, capsys, str(p), field)


@pytest.mark.parametrize("case", ["truncated", "100,000-deep JSON", "empty", "latin-1"])
def test_damaged_model_file(base, work, capsys, case):
    p = work / "model.json"
    raw = {"truncated": base.model.read_bytes()[:5000], "100,000-deep JSON": b"[" * 100_000 + b"]" * 100_000,
           "empty": b"", "latin-1": "{\"format\": \"vecpin-model\", \"note\": \"\xb0C\"}".encode("latin-1")}[case]
    p.write_bytes(raw)
    refused(["evaluate", p, base.csv], capsys, str(p), "model file")


def test_tables_file_of_another_machine(base, work, capsys):
    ok(["tables", base.model, "--out", work / "t", "--quiet"], capsys)
    d = json.loads((work / "t" / "tables.json").read_text())
    d["machine"] = "trunnion_xyzbc"
    (work / "t" / "tables.json").write_text(json.dumps(d))
    refused(["simulate", "flow_xyzcb", "--out", work / "s", "--points", "10", "--tables", work / "t"], capsys,
            "--tables", "for machine 'trunnion_xyzbc'", "not 'flow_xyzcb'")
    (work / "t" / "tables.json").write_text("{\"format\": ")
    refused(["verify", base.val, base.val, "--machine", "flow_xyzcb", "--tables", work / "t"], capsys,
            "--tables", "not a vecpin table file")


def test_controller_profile_with_a_bad_field(base, work, capsys):
    d = json.loads(Path(PROFILE).read_text())
    d["axes"]["X"]["detection_unit"] = -1
    p = work / "profile.json"
    p.write_text(json.dumps(d))
    refused(["tables", base.model, "--out", work / "t", "--controller", "siemens-840d", "--profile", p], capsys,
            str(p), "detection_unit")


# ============================================================ 6. models and campaigns of other machines
@pytest.fixture(scope="module")
def sister(base):
    """A second flow_xyzcb-like machine (same axes and limits, the B axis 150 mm off the C
    axis) with its own campaign and tracker pose."""
    import vecpin
    text = vecpin.Machine.load("flow_xyzcb").urdf_xml
    d = base.dir / "sister"
    d.mkdir()
    urdf = d / "sister.urdf"
    a = text.index('<joint name="B"')
    b = text.index('<origin xyz="0 0 0"', a)
    urdf.write_text(text[:b] + '<origin xyz="0.15 0 0"' + text[b + len('<origin xyz="0 0 0"'):])
    assert main(["simulate", str(urdf), "--out", str(d / "sim"), "--seed", "8", "--points", "30",
                 "--validation-count", "10"]) == 0
    return SimpleNamespace(urdf=urdf, csv=d / "sim" / "campaign.csv")


def test_model_of_one_machine_on_another_machines_campaign(base, sister, work, capsys):
    refused(["evaluate", base.model, sister.csv], capsys, str(sister.csv), "not this machine's campaign")
    refused(["evaluate", base.model, sister.csv, "--reregister"], capsys, str(sister.csv),
            "not this machine's campaign")
    refused(["view", base.model, sister.csv, "--html", work / "v.html", "--no-tables"], capsys, str(sister.csv),
            "not this machine's campaign")


def test_model_on_a_campaign_from_another_tracker_position(base, work, capsys):
    """The validation file measured after the tracker was moved 1 m: refused without
    --reregister (the 'reduction' would be the move), judged with it."""
    v = Table(base.val.read_text())
    for r in v.rows:
        r[v.col("x")] = "%.6f" % (float(r[v.col("x")]) + 1000.0)
    moved = v.write(work / "moved.csv")
    refused(["evaluate", base.model, moved], capsys, str(moved), "tracker was moved", "give --reregister")
    out = ok(["evaluate", base.model, moved, "--reregister"], capsys).out
    assert "re-registered" in out and "reduction of the mean" in out


def test_models_of_two_machines_in_one_report(base, sister, work, capsys):
    m2 = work / "sister.json"
    ok(["fit", sister.urdf, sister.csv, "--out", m2] + FIT_FAST, capsys)
    refused(["report", base.model, m2, base.csv, "--out", work / "r"], capsys, "model 1", "model 2",
            "use files of one machine")
    refused(["verify", base.val, base.val, "--machine", sister.urdf, "--model-file", base.model], capsys,
            "use files of one machine")


def test_campaign_of_another_machine_fitted(base, sister, work, capsys):
    """The sister's campaign fitted as flow_xyzcb: same axis names and limits, so only the
    registration can tell - and it does."""
    refused(["fit", "flow_xyzcb", sister.csv, "--out", work / "m.json"] + FIT_FAST, capsys, str(sister.csv),
            "not this machine's campaign")
    refused(["verify", sister.csv, base.val, "--machine", "flow_xyzcb"], capsys, str(sister.csv),
            "not this machine's campaign")


# ============================================================ 7. output paths: refused before the work
OUTPUTS = {  # command -> (argv with OUT, heavy function that must not be reached, kind of output)
    "simulate": (lambda b, o: ["simulate", "flow_xyzcb", "--out", o, "--points", "10"],
                 ("vecpin.workflows.simulating", "simulate"), "dir"),
    "fit": (lambda b, o: ["fit", "flow_xyzcb", b.csv, "--out", o] + FIT_FAST,
            ("vecpin.workflows.fitting", "fit_campaign"), "file"),
    "evaluate --json": (lambda b, o: ["evaluate", b.model, b.csv, "--json", o],
                        ("vecpin.workflows.evaluation", "evaluate"), "file"),
    "tables": (lambda b, o: ["tables", b.model, "--out", o, "--quiet"], ("vecpin.workflows.tables", "plan_tables"),
               "dir"),
    "diagnose": (lambda b, o: ["diagnose", "flow_xyzcb", b.csv, "--out", o, "--quiet"],
                 ("vecpin.diagnosis.diagnose", "diagnose"), "dir"),
    "view --html": (lambda b, o: ["view", b.model, b.csv, "--html", o], ("vecpin.compensation.plan", "plan_tables"),
                    "file"),
    "report": (lambda b, o: ["report", b.model, b.csv, "--out", o, "--quiet"],
               ("vecpin.compensation.plan", "plan_tables"), "dir"),
    "demo": (lambda b, o: ["demo", "--out", o, "--quiet"], ("vecpin.workflows.demo", "simulate"), "dir"),
    "plan": (lambda b, o: ["plan", "flow_xyzcb", "--out", o, "--quiet"], ("vecpin.workflows.planning", "make_plan"),
             "dir"),
    "import": (lambda b, o: ["import", b.csv, "--machine", "flow_xyzcb", "--out", o],
               ("vecpin.workflows.importing", "import_export"), "file"),
    "assess --json": (lambda b, o: ["assess", "--mean-error", "0.5", "--long-term", "0.01", "--json", o],
                      ("vecpin.workflows.assessing", "assess_numbers"), "file"),
    "verify --out": (lambda b, o: ["verify", b.val, b.val, "--machine", "flow_xyzcb", "--out", o],
                     ("vecpin.workflows.verifying", "verify"), "dir"),
}


def _never_reach(monkeypatch, target):
    import importlib
    mod = importlib.import_module(target[0])

    def never(*a, **k):
        raise AssertionError(f"{target[1]} ran before the output path was checked")
    monkeypatch.setattr(mod, target[1], never)


@pytest.mark.parametrize("command, problem", [  # an output folder is created with its parents, a file's must exist
    (c, p) for c in sorted(OUTPUTS) for p in ("a file in the way", "no permission", "missing folder")
    if not (p == "missing folder" and OUTPUTS[c][2] == "dir")])
def test_output_path_refused_before_the_work(base, work, capsys, monkeypatch, command, problem):
    build, target, kind = OUTPUTS[command]
    blocker = work / "blocker"
    blocker.write_text("a file, not a folder")
    name = "out.json" if kind == "file" else "out"
    out = {"a file in the way": blocker / name, "missing folder": work / "no" / "such" / name,
           "no permission": work / "locked" / name}[problem]
    if problem == "no permission":  # running as root, so deny by the check's own test
        import vecpin.fileio as fio
        (work / "locked").mkdir()
        real = fio.os.access
        monkeypatch.setattr(fio.os, "access", lambda p, mode: False if "locked" in str(p) else real(p, mode))
    _never_reach(monkeypatch, target)
    what = {"a file in the way": "is a file, not a folder", "no permission": "no permission",
            "missing folder": "does not exist"}[problem]
    refused(build(base, out), capsys, str(out), what, "give" if problem != "missing folder" else "create it")
    assert not out.exists()


# ============================================================ 8. all-or-nothing results, byte-identical reruns
def _interrupt_after(monkeypatch, n_files: int):
    """Stage ``n_files`` files of a result, then interrupt (as Ctrl-C would)."""
    from vecpin.fileio import OutputSet
    real = OutputSet.path
    count = {"n": 0}

    def path(self, name):
        count["n"] += 1
        if count["n"] > n_files:
            raise KeyboardInterrupt
        return real(self, name)
    monkeypatch.setattr(OutputSet, "path", path)


SETS = {  # command -> argv with OUT (a folder result of several files)
    "simulate": lambda b, o: ["simulate", "flow_xyzcb", "--out", o, "--points", "10", "--seed", "1"],
    "tables (840D files)": lambda b, o: ["tables", b.model, "--out", o, "--controller", "siemens-840d", "--profile",
                                         PROFILE, "--quiet"],
    "plan": lambda b, o: ["plan", "flow_xyzcb", "--out", o, "--points", "12", "--order", "1", "--candidates", "150",
                          "--no-sight", "--quiet"],
    "report": lambda b, o: ["report", b.model, b.csv, "--out", o, "--quiet"],
    "verify": lambda b, o: ["verify", b.val, b.csv, "--model-file", b.model, "--out", o, "--quiet"],  # two runs
    "diagnose": lambda b, o: ["diagnose", "flow_xyzcb", b.csv, "--out", o, "--quiet", "--effects", "thermal",
                              "--model", "ap", "--order", "2", "--basis", "chebyshev"],
}


@pytest.mark.parametrize("command", sorted(SETS))
def test_interrupted_result_leaves_the_previous_set_and_reruns_are_identical(base, work, capsys, monkeypatch,
                                                                            command):
    out = work / "out"
    ok(SETS[command](base, out), capsys)
    before = files_of(out)
    assert len(before) >= 2
    ok(SETS[command](base, work / "again"), capsys)
    again = files_of(work / "again")
    assert again.keys() == before.keys()
    assert [k for k in before if before[k] != again[k]] == []  # byte-identical rerun
    _interrupt_after(monkeypatch, 1)
    rc = main([str(a) for a in SETS[command](base, out)])
    err = capsys.readouterr().err
    assert rc == 130 and "interrupted" in err and "Traceback" not in err
    after = files_of(out)
    assert after == before  # the previous set, whole
    assert not [p for p in out.iterdir() if p.name.startswith(".vecpin-staging")]


def test_reruns_of_single_file_results_are_identical(base, work, capsys):
    for k in (1, 2):
        ok(["fit", "flow_xyzcb", base.csv, "--out", work / f"m{k}.json"] + FIT_FAST, capsys)
        ok(["import", base.csv, "--machine", "flow_xyzcb", "--out", work / f"i{k}.csv"], capsys)
        ok(["evaluate", base.model, base.val, "--json", work / f"e{k}.json"], capsys)
        ok(["assess", "--mean-error", "0.5", "--long-term", "0.01", "--json", work / f"a{k}.json"], capsys)
        ok(["view", base.model, base.csv, "--html", work / f"v{k}.html", "--no-tables"], capsys)
    for stem in ("m", "i", "e", "a", "v"):
        suffix = {"i": ".csv", "v": ".html"}.get(stem, ".json")
        assert (work / f"{stem}1{suffix}").read_bytes() == (work / f"{stem}2{suffix}").read_bytes(), stem
    text = (work / "m1.json").read_text()
    assert "seconds" not in text and "time" not in json.loads(text)["fit"]


def test_simulate_never_writes_a_campaign_it_cannot_read(flow, work, monkeypatch, capsys):
    """Whatever the options, a simulated file that read_campaign would refuse is not written:
    here the simulated temperatures are forced to °F."""
    import vecpin.simulation.simulate as ss
    real = ss.workshop_temperature
    monkeypatch.setattr(ss, "workshop_temperature", lambda t, rng: real(t, rng) * 1.8 + 32)
    refused(["simulate", "flow_xyzcb", "--out", work / "s", "--points", "10"], capsys, "would not be readable",
            "temperature", "change the simulation options")
    assert not (work / "s" / "campaign.csv").exists()


# ============================================================ 9. meshes
def _meshed_machine(folder: Path) -> Path:
    """flow_xyzcb with its base drawn by a relative STL mesh (meshes/tet.stl)."""
    import vecpin
    (folder / "meshes").mkdir(parents=True)
    shutil.copy(HOSTILE / "tet.stl", folder / "meshes" / "tet.stl")
    text = vecpin.Machine.load("flow_xyzcb").urdf_xml.replace('<box size="6.6 3.2 0.3"/>',
                                                               '<mesh filename="meshes/tet.stl"/>', 1)
    assert "tet.stl" in text
    (folder / "meshed.urdf").write_text(text)
    return folder / "meshed.urdf"


def test_relative_mesh_found_when_the_model_file_is_used_elsewhere(work, capsys, monkeypatch):
    urdf = _meshed_machine(work / "machine")
    ok(["simulate", urdf, "--out", work / "sim", "--points", "20", "--validation-count", "5"], capsys)
    model = work / "elsewhere" / "model.json"
    model.parent.mkdir()
    ok(["fit", urdf, work / "sim" / "campaign.csv", "--out", model] + FIT_FAST, capsys)
    monkeypatch.chdir(work / "elsewhere")  # another working folder, the model file away from the URDF
    out = ok(["view", model, work / "sim" / "campaign.csv", "--html", work / "v.html", "--no-tables"], capsys).out
    assert "note:" not in out
    page = (work / "v.html").read_text()
    assert "meshcat" in page.lower()


def test_missing_mesh_draws_without_it_with_a_note(work, capsys):
    urdf = _meshed_machine(work / "machine")
    ok(["simulate", urdf, "--out", work / "sim", "--points", "20", "--validation-count", "5"], capsys)
    model = work / "model.json"
    ok(["fit", urdf, work / "sim" / "campaign.csv", "--out", model] + FIT_FAST, capsys)
    shutil.rmtree(work / "machine" / "meshes")
    out = ok(["view", model, work / "sim" / "campaign.csv", "--html", work / "v.html", "--no-tables"], capsys).out
    assert "note: drawn without 1 mesh file(s) not found (meshes/tet.stl" in out and (work / "v.html").is_file()
    ok(["report", model, work / "sim" / "campaign.csv", "--out", work / "r", "--quiet"], capsys)
    assert "drawn without 1 mesh file(s)" in (work / "r" / "index.html").read_text()
    assert (work / "r" / "scene.html").is_file()


def test_mesh_resolution_against_the_files(work):
    """resolve_meshes makes found meshes absolute (relative and package:// names) and drops
    the visuals of missing ones."""
    from vecpin.viz.scene import resolve_meshes
    (work / "pkg" / "meshes").mkdir(parents=True)
    (work / "pkg" / "meshes" / "a.stl").write_text("solid a\nendsolid a\n")
    xml = ("<robot name='r'><link name='l'><visual><geometry><mesh filename='package://pkg/meshes/a.stl'/></geometry>"
           "</visual><visual><geometry><mesh filename='meshes/gone.stl'/></geometry></visual>"
           "<visual><geometry><box size='1 1 1'/></geometry></visual></link></robot>")
    out, missing = resolve_meshes(xml, [work])
    assert missing == ["meshes/gone.stl"]
    assert str((work / "pkg" / "meshes" / "a.stl").resolve()) in out and "gone.stl" not in out and "<box" in out


# ============================================================ 10. more ways a campaign goes wrong
def test_campaign_without_station_0(base, work, capsys):
    """Rows of stations 1 and 2 only: the model's tracker pose (station 0) describes none."""
    c = base.table.copy().add_column("station", [str(1 + k % 2) for k in range(len(base.table.rows))])
    path = c.write(work / "stations12.csv")
    refused(["evaluate", base.model, path], capsys, str(path), "column 'station'", "no tracker rows of station 0",
            "number the stations from 0")
    refused(["view", base.model, path, "--html", work / "v.html", "--no-tables"], capsys, "no tracker rows of station 0")


def test_tool_column_varying_row_to_row(base, work, capsys, rng):
    """A measured tool length on every row (60 different lengths): the printout sums them up
    and the tables are posed on four lengths spanning them (not 60 x the pseudo-points)."""
    c = base.table.copy()
    for r in c.rows:
        r[c.col("tool")] = "%.6f" % (float(r[c.col("tool")]) + rng.normal(0, 0.002))
    path = c.write(work / "tools.csv")
    out = ok(["fit", "flow_xyzcb", path, "--out", work / "m.json"] + FIT_FAST, capsys).out
    assert "60 different tool lengths" in out and "tool 214." not in out
    out = ok(["tables", work / "m.json", "--out", work / "t", "--quiet"], capsys).out
    assert "60 different tool lengths in the fit: the tables are fitted on 4" in out


def test_import_of_fahrenheit_temperatures(base, work, capsys):
    """An export with °F in an unlabelled temperature column is not written as °C (the
    campaign would not read back); with --temperature-unit F it is converted: (F - 32) / 1.8."""
    c = base.table.copy()
    celsius = np.array([float(r[c.col("temperature")]) for r in c.rows])
    for r, t in zip(c.rows, celsius):
        r[c.col("temperature")] = "%.4f" % (t * 1.8 + 32)
    export = c.write(work / "export.csv")
    out = work / "campaign.csv"
    refused(["import", export, "--machine", "flow_xyzcb", "--out", out], capsys, str(export), "column 'temperature'",
            "look like °F", "give --temperature-unit F")
    assert not out.exists()
    ok(["import", export, "--machine", "flow_xyzcb", "--out", out, "--temperature-unit", "F"], capsys)
    got = np.genfromtxt(out, delimiter=",", names=True)["temperature"]
    np.testing.assert_allclose(got, celsius, atol=1e-4)


def test_import_never_replaces_a_campaign_with_one_that_does_not_read_back(base, work, capsys, monkeypatch):
    """The imported campaign is staged and read back before it replaces the old file."""
    import vecpin.measurement.importwrite as imp
    out = work / "campaign.csv"
    out.write_text("the previous campaign\n")
    real = imp.campaign_text
    monkeypatch.setattr(imp, "campaign_text", lambda c, m: real(c, m).replace(",", ";"))
    refused(["import", base.csv, "--machine", "flow_xyzcb", "--out", out], capsys, str(out), "would not be readable",
            "nothing was written")
    assert out.read_text() == "the previous campaign\n"
    assert not [p for p in work.iterdir() if p.name.startswith(".vecpin-staging")]
