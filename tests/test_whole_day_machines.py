"""Issue 41: the whole day, literally from the docs, on an arm (its plan included), the
all-table machine and a trunnion with a HEIDENHAIN program (docs/whole-day-machines.md).

Each section of the page runs as written, in order, in an empty folder of its own: its
Python blocks in a fresh ``python`` and its shell blocks with bash, except that a shell
block of nothing but ``vecpin`` commands runs each command in this process
(``vecpin.cli.main``, the console script's function, with the same words: the imports
are paid once, not per command). Then the programs the plan and the sign test wrote are
run by interpreters written from the controls' manuals with no vecpin code: G-code
(tests/gcode.py), HEIDENHAIN conversational (tests/heidenhain.py), URScript and the joint
list (tests/robot_programs.py). They must stop at exactly the plan's commands, and every
position they pass (each move's ends and points along it: at most 5 deg and 25 mm apart,
in axis space as the controls interpolate) is posed with the machine's URDF geometry by
tests/collision_judge.py (Pinocchio and Coal, no vecpin code): the target holder's axis
meets no solid (on the arm the holder a capsule of the radius its program states, on
every move, approach, retract and via poses included). Last, verify's reduction of the validation error."""
from __future__ import annotations

import contextlib
import csv
import io
import json
import re
import shlex
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from collision_judge import ROBOTS, judge
from gcode import Start, run
from robot_programs import joint_names, read_joint_list, run_urscript
from test_docs import blocks, environment
from vecpin.cli import main

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "whole-day-machines.md"
TOL = 5e-4          # mm / deg: the programs' 3 decimals
STEP_DEG, STEP_MM = 5.0, 25.0


def sections() -> dict[str, list[tuple[int, str, str]]]:
    """{the folder a section works in: its blocks}, in the page's order."""
    text = PAGE.read_text(encoding="utf-8")
    heads = [(text[:m.start()].count("\n") + 1, m.group(1)) for m in re.finditer(r"^## (.+)$", text, re.M)]
    out: dict[str, list] = {}
    for line, lang, body in blocks(PAGE):
        if lang not in ("bash", "python"):
            continue
        if not any(h <= line for h, _ in heads):
            continue
        folder = re.search(r"\b(\w+)/(?:plan|export)", body).group(1)
        out.setdefault(folder, []).append((line, lang, body))
    return out


def _commands(body: str) -> list[str]:
    lines = re.sub(r"\\\n\s*", " ", body).splitlines()
    return [ln.strip() for ln in lines if ln.strip()]


def run_section(folder: Path, chunk: list[tuple[int, str, str]]) -> str:
    """Run a section's blocks in ``folder``; everything they printed."""
    printed = []
    for line, lang, body in chunk:
        cmds = _commands(body)
        if lang == "bash" and all(c.startswith("vecpin ") for c in cmds):
            for c in cmds:
                out, err = io.StringIO(), io.StringIO()
                with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), contextlib.chdir(folder):
                    rc = main(shlex.split(c)[1:])
                assert rc == 0, (f"{PAGE.name}:{line} `{c}` exit {rc}:\n{out.getvalue()[-3000:]}\n"
                                 f"{err.getvalue()[-3000:]}")
                printed.append(out.getvalue())
            continue
        argv = ["bash", "-e", "-o", "pipefail", "-c", body] if lang == "bash" else [sys.executable, "-c", body]
        done = subprocess.run(argv, cwd=folder, env=environment(), capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, (f"{PAGE.name}:{line} ```{lang} failed:\n{done.stdout[-3000:]}\n"
                                      f"{done.stderr[-3000:]}")
        printed.append(done.stdout)
    return "".join(printed)


def urdf_axes(name: str) -> dict[str, tuple[float, float]]:
    """{joint: (lower, upper)} in mm / deg from the URDF's limits, in the URDF's order."""
    out = {}
    for j in ET.parse(ROBOTS / f"{name}.urdf").getroot().iter("joint"):
        if j.get("type") in ("prismatic", "revolute"):
            lim = j.find("limit")
            k = 1000.0 if j.get("type") == "prismatic" else 180.0 / np.pi
            out[j.get("name")] = (float(lim.get("lower")) * k, float(lim.get("upper")) * k)
    return out


def _between(a: np.ndarray, b: np.ndarray, linear: np.ndarray) -> np.ndarray:
    """Positions along a straight move in axis space from ``a`` to ``b`` (both ends
    included), at most STEP_DEG / STEP_MM apart."""
    d = np.abs(b - a)
    n = int(np.ceil(max(np.max(d[linear], initial=0) / STEP_MM, np.max(d[~linear], initial=0) / STEP_DEG, 1)))
    return a + np.linspace(0.0, 1.0, n + 1)[:, None] * (b - a)


def nc_visited(prog, names: list[str], linear: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(positions (k, n), holder [m] at each) along every move of an NC program run; the
    holder is the one the last stop before the move mounts (its message names it)."""
    mounts = [(ln, float(m.group(1)) / 1000.0) for ln, c in prog.stops
              if (m := re.search(r"holder of ([\d.]+) mm", c, re.I))]
    pos, hold = [], []
    for mv in prog.moves:
        if any(mv.pos[a] is None for a in names):
            continue
        held = [x for ln, x in mounts if ln < mv.line]
        assert held, f"line {mv.line}: a move before any holder is mounted"
        b = np.array([mv.pos[a] for a in names])
        a = b if any(mv.before[x] is None for x in names) else np.array([mv.before[x] for x in names])
        path = _between(a, b, linear)
        pos += list(path)
        hold += [held[-1]] * len(path)
    return np.array(pos), np.array(hold)


def linear_axes(name: str) -> np.ndarray:
    """(n,) True for the URDF's prismatic joints, in urdf_axes' order."""
    return np.array([j.get("type") == "prismatic" for j in ET.parse(ROBOTS / f"{name}.urdf").getroot().iter("joint")
                     if j.get("type") in ("prismatic", "revolute")])


def free(name: str, names: list[str], pos: np.ndarray, hold: np.ndarray) -> None:
    hits = judge(name).colliding([dict(zip(names, p)) for p in pos], hold)
    assert not hits, f"{len(hits)} of {len(pos)} positions put the holder into the machine: " + \
        "; ".join(f"{dict(zip(names, np.round(pos[i], 3)))} ({', '.join(h)})" for i, h in hits[:5])


def template(path: Path, names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """(commands of the tool rows (k, n) mm/deg, their holders mm) of a plan.csv, in order."""
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r.get("instrument", "tracker") != "nest"]
    return np.array([[float(r[a]) for a in names] for r in rows]), np.array([float(r["tool"]) for r in rows])


def _runs(q: np.ndarray) -> np.ndarray:
    """``q`` (k, n) without the rows equal to the one before (a command read again)."""
    keep = np.r_[True, np.abs(np.diff(q, axis=0)).max(axis=1) > TOL]
    return q[keep]


def check_nc(name: str, dialect: str, program: Path, plan: Path) -> None:
    """The NC program stops at the plan's commands, reached at the feed from the side away
    from the work, and passes no position where the holder meets the machine."""
    axes = urdf_axes(name)
    names = list(axes)
    linear = linear_axes(name)
    if dialect == "heidenhain":
        from heidenhain import run as run_klartext
        prog = run_klartext(program.read_text(), axes, Start())
    else:
        prog = run(program.read_text(), dialect, axes, Start())
    assert {mv.frame for mv in prog.moves} == {"machine"}
    q, tools = template(plan, names)
    at = [prog.moves[max(i for kind, i in prog.events[:j] if kind == "move")]
          for j, e in enumerate(prog.events) if e[0] == "dwell"]
    stops = np.array([[mv.pos[a] for a in names] for mv in at])
    np.testing.assert_allclose(_runs(stops), _runs(q), atol=TOL)   # a point read again at standstill: one stop
    assert all(mv.code == 1 and mv.before["Z"] >= mv.pos["Z"] - TOL for mv in at)
    free(name, names, *nc_visited(prog, names, linear))


def check_arm(plan: Path, run_name: str) -> int:
    """The URScript program and the joint list say the same poses, the measured ones are
    the plan's commands, and no pose on the way (joint interpolation) meets the arm, the
    holder a capsule of the radius the program's header states: no move is left to jog by
    hand. Returns the positions judged."""
    names = joint_names(plan / f"{run_name}_joints.csv")
    text = (plan / f"{run_name}.script").read_text()
    prog = run_urscript(text)
    listed = read_joint_list(plan / f"{run_name}_joints.csv")
    assert [(k, p) for k, p, _, _ in prog.moves] == [(k, p) for k, p, _, _ in listed]
    np.testing.assert_allclose([np.degrees(q) for _, _, q, _ in prog.moves], [q for *_, q in listed], atol=2e-6)
    assert [h for *_, h in prog.moves] == pytest.approx([h / 1000 for _, _, h, _ in listed])
    measured = np.array([q for k, _, _, q in listed if k == "measure"])
    q, tools = template(plan / f"{run_name}.csv" if run_name == "validation" else plan / "plan.csv", names)
    np.testing.assert_allclose(measured, q, atol=1e-6)
    assert len(prog.sleeps) == len(measured)
    assert not re.findall(r"^# WARNING: the move (P\d+) -> (P\d+) ", text, re.M)
    radius = float(re.search(r"^# target holder checked as a cylinder of radius ([\d.]+) mm$", text, re.M).group(1))
    j, hit_moves, judged = judge("ur5", radius / 1000), set(), 0
    for i in range(1, len(prog.moves)):
        a, b = np.degrees(prog.moves[i - 1][2]), np.degrees(prog.moves[i][2])
        path = _between(a, b, np.zeros(len(names), bool))
        judged += len(path)
        if j.colliding([dict(zip(names, p)) for p in path], prog.moves[i][3]):
            hit_moves.add((prog.moves[i - 1][1], prog.moves[i][1]))
    assert not hit_moves, f"moves that meet the arm: {sorted(hit_moves)}"
    return judged


DAYS = list(sections())


def test_the_page_has_the_three_days():
    assert DAYS == ["arm", "trt", "trunnion"], DAYS


@pytest.mark.slow   # a whole day of small campaigns: plan, simulate, import, assess, fit, tables, verify
@pytest.mark.parametrize("day", DAYS)
def test_the_day_as_written(day, tmp_path):
    (tmp_path / day).mkdir()
    out = run_section(tmp_path, sections()[day])
    d = tmp_path / day
    if day == "arm":
        assert check_arm(d / "plan", "plan") > 0 and check_arm(d / "plan", "validation") > 0
        assert "robot controller" in out   # what carries the model on an arm: the tables' printout says it
    elif day == "trt":
        for prog in ("plan", "validation"):
            check_nc("xyzac_trt", "gcode", d / "plan" / f"{prog}.ngc", d / "plan" / f"{prog}.csv")
        assert "relative to the table" in out
        # the plan asks for the nests' heights above the face; the simulation, standing in for the operator, fills them
        assert (d / "plan" / "nest_heights.csv").is_file() and (d / "measured" / "nest_heights.csv").is_file()
        assert "heights above the table's face: once the nests are placed" in out
    else:
        check_nc("trunnion_xyzac", "heidenhain", d / "plan" / "PLAN.H", d / "plan" / "plan.csv")
        check_nc("trunnion_xyzac", "heidenhain", d / "plan" / "VALID.H", d / "plan" / "validation.csv")
        check_sign_test(d)
    v = json.loads((d / "verify" / "verify.json").read_text())
    assert v["reduction_of_mean_pct"] > 50.0, v["reduction_of_mean_pct"]


def check_sign_test(d: Path) -> None:
    """The sign test lifts Z, then moves A alone; with the longest holder of the plan
    mounted no position on the way meets the machine, wherever X, Y and C stand."""
    from heidenhain import run as run_klartext
    axes = urdf_axes("trunnion_xyzac")
    names = list(axes)
    prog = run_klartext((d / "tables" / "SIGNTEST_AA.H").read_text(), axes, Start())
    assert prog.moves[0].axes == ("Z",) and all(mv.axes == ("A",) for mv in prog.moves[1:])
    _, tools = template(d / "plan" / "plan.csv", names)
    pos = []
    for x, y, c in ((x, y, c) for x in axes["X"] + (0.0,) for y in axes["Y"] + (0.0,) for c in (0.0, 180.0)):
        last = None     # X, Y and C stand wherever they stood: at the ends and the middle of their travel
        for mv in prog.moves[1:]:
            b = np.array([{"X": x, "Y": y, "C": c, "Z": prog.moves[0].pos["Z"]}.get(a) if mv.pos[a] is None
                          else mv.pos[a] for a in names])
            pos += list(_between(b if last is None else last, b, linear_axes("trunnion_xyzac")))
            last = b
    free("trunnion_xyzac", names, np.array(pos), np.full(len(pos), tools.max() / 1000))

