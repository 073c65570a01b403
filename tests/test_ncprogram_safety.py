"""The measurement and sign-test programs are safe to run as written, judged by the
tests' own interpreter (tests/gcode.py, from the controls' documentation, no vecpin code)
on a control that starts in inch mode, with tool length compensation on, a work offset
and incremental mode: every move in machine coordinates, units and the cancelled
compensations before the first move, every planned point reached with the plan's axis
values (the rows of the template), the tool lifted to the safe height before every move
that swings a rotary axis or travels, the dwells, the header's point count, and the
units the program changed restored (LinuxCNC) or named in the header."""
import re

import numpy as np
import pytest

from gcode import GCodeError, Start, run
from vecpin.cli import main
from vecpin.errors import InputError
from vecpin.export.signtest import SignTest, program
from vecpin.planning.ncprogram import DIALECTS, write_program
from vecpin.planning.plan import PlanSettings, make_plan

TOL = 5e-4          # values are written with 3 decimals
APPROACH = {"mm": 5.0, "deg": 1.0}  # the plans' default approach distances


@pytest.fixture(scope="module")
def plans(machines):
    """A head machine (X Y Z C B, the tool on a 215/313 mm holder) with repeated points and
    a trunnion (X Y Z A C on the table) with three table nests."""
    flow, trunnion = machines["flow_xyzcb"], machines["trunnion_xyzac"]
    return {"flow_xyzcb": make_plan(flow, PlanSettings(n_commands=16, order=1, candidates=200, validation_points=30,
                                                       repeat_points=2, repeat_times=2)),
            "trunnion_xyzac": make_plan(trunnion, PlanSettings(n_commands=24, model="6dof", order=1, candidates=300,
                                                               validation_points=30))}


def _axes(m):
    return {a.name: (a.lower_user, a.upper_user) for a in m.axes}


def _check_safe_moves(prog, m, safe, step):
    """Every move that starts or ends with Z below ``safe`` moves Z alone, or moves every
    axis by at most the approach distance (the final approach); a move from an unknown
    position moves Z alone to at least ``safe``; Z is at ``safe`` or above at every stop
    and at the end. Returns the number of large moves (all made at the safe height)."""
    large = 0
    for mv in prog.moves:
        low = any(v is None or v < safe - TOL for v in (mv.before["Z"], mv.pos["Z"]))
        if set(mv.axes) == {"Z"}:
            continue
        d = [abs(mv.pos[a] - mv.before[a]) if mv.before[a] is not None else np.inf for a in m.axis_names]
        small = all(x <= s + TOL for x, s in zip(d, step))
        if not small:
            large += 1
        assert small or not low, f"line {mv.line}: a move of {mv.axes} with Z at {mv.before['Z']} -> {mv.pos['Z']}"
    at = [None]
    for e in prog.events:
        if e[0] == "move":
            at[0] = prog.moves[e[1]].pos["Z"]
        elif e[0] == "stop":
            assert at[0] is not None and at[0] >= safe - TOL, f"stop {e[1]} with Z at {at[0]}"
    last = prog.moves[-1]  # a final lift, unless the last point stands at the safe height or above
    assert (last.axes == ("Z",) or last.before["Z"] >= safe - TOL) and last.pos["Z"] >= safe - TOL
    return large


@pytest.mark.parametrize("dialect", list(DIALECTS))
@pytest.mark.parametrize("name", ["flow_xyzcb", "trunnion_xyzac"])
def test_plan_program_runs_safely_on_a_control_in_inch_mode_with_offsets(plans, machines, name, dialect):
    p, m = plans[name], machines[name]
    t = p.template
    text = write_program(dialect, m, t, p.steps, dwell_s=3.0, nest_dwell_s=12.0, feed_mm_min=800.0)
    start = Start()
    prog = run(text, dialect, _axes(m), start)
    # machine coordinates: absolute in the machine frame or an increment from a known machine position
    assert {mv.frame for mv in prog.moves} <= {"machine", "incremental"}
    assert prog.moves[0].frame == "machine"
    # every planned point: the machine at each dwell is at the template's tool rows, in order
    tool_rows = np.flatnonzero(t.instrument != "nest") if t.instrument is not None else np.arange(len(t))
    at_dwell, last = [], []
    for k, e in enumerate(prog.events):
        if e[0] == "dwell":
            mv = prog.moves[max(i for kind, i in prog.events[:k] if kind == "move")]
            at_dwell.append([mv.pos[a] for a in m.axis_names])
            last.append(mv)
    want = m.to_user(t.q[tool_rows])
    assert len(at_dwell) == len(tool_rows)
    np.testing.assert_allclose(np.array(at_dwell), want, atol=TOL)
    # each point reached at the feed from the approach position the plan's approach column names (issue 41):
    # never from below on Z (Z+ lifts the tool on these machines), so no move passes a point toward the work
    step = np.array([APPROACH[a.unit] for a in m.axes])
    z = m.axis_names.index("Z")
    for mv, q, s in zip(last, want, t.approach[tool_rows]):
        assert mv.code == 1 and mv.feed == 800.0
        np.testing.assert_allclose(q - [mv.before[a] for a in m.axis_names], s * step, atol=TOL)
        assert s[z] <= 0 and mv.before["Z"] >= q[z] - TOL
    # the dwell covers the tool target and every nest read there
    is_nest = np.r_[t.instrument == "nest", False] if t.instrument is not None else np.zeros(len(t) + 1, bool)
    nests = [int(np.argmin(is_nest[i + 1:])) for i in tool_rows]
    assert prog.dwells == pytest.approx([3.0 + 12.0 * k for k in nests])
    assert (sum(nests) > 0) == (name == "trunnion_xyzac")
    # retracts: Z to the top of its travel before anything swings or travels, at the stops and at the end
    safe = m.axis("Z").upper_user
    assert _check_safe_moves(prog, m, safe, step) >= len(tool_rows)  # linear, then rotary moves: most points
    # the header counts the plan's rows
    counted = [int(x) for c in prog.comments[:12] for x in re.findall(r"^(\d+) points", c, re.I)]
    assert counted == [len(t)]
    # every row of the plan is read at one dwell where the machine stands at its axis values: the
    # comment before each dwell names the points read there (tool target, then the nests in order)
    row_of = {int(pt): k for k, pt in enumerate(t.point)}
    read, comment = [], ""
    for e in prog.events:
        if e[0] == "comment":
            comment = e[1]
        elif e[0] == "dwell":
            pts = [int(x) for x in re.findall(r"\bP(\d+)\b", comment.upper())]
            assert pts and pts[0] == int(t.point[tool_rows[e[1]]])
            for pt in pts:
                np.testing.assert_allclose(at_dwell[e[1]], m.to_user(t.q[row_of[pt]]), atol=TOL)
            read += pts
    assert read == [int(x) for x in t.point]  # each row once, in the plan's order
    if name == "trunnion_xyzac":
        said = re.findall(r"(\w+) AS (P\d+)", " ".join(prog.comments).upper())
        named = [(str(t.target[i]).upper(), f"P{int(t.point[i]):04d}") for i in np.flatnonzero(t.instrument == "nest")]
        assert [x for x in said if x in named] == named
    # units: LinuxCNC restores the inch mode it found; Siemens and Fanuc say what stays
    if dialect == "gcode":
        assert prog.units_at_end == start.units
    elif dialect == "heidenhain":  # its units are the program's own (BEGIN PGM ... MM): no modal state to restore
        assert prog.units_at_end == "mm" and "L M129" in " ".join(prog.comments[:20])
    else:
        unit = "G21" if dialect == "fanuc" else "G710"
        header = " ".join(prog.comments[:20])
        assert unit in header and "M30" in header[header.index(unit):]
    if dialect == "fanuc":
        assert all(";" not in c for c in prog.comments) and ";" not in text


def test_holder_changes_stop_with_the_tool_lifted(plans, machines):
    p, m = plans["flow_xyzcb"], machines["flow_xyzcb"]
    prog = run(write_program("siemens-840d", m, p.template, p.steps), "siemens-840d", _axes(m))
    assert len(prog.stops) == 3  # the first holder, 312.86, and 214.88 again for the repeats
    # (the stops' Z is checked by _check_safe_moves in the test above)


def test_safe_height_option(plans, machines, tmp_path, capsys):
    """--safe-z: Z goes to that machine position (or higher, where a point is higher)
    before every large move; outside the travel it is refused naming the option."""
    p, m = plans["flow_xyzcb"], machines["flow_xyzcb"]
    text = write_program("gcode", m, p.template, p.steps, safe_z_mm=700.0)
    prog = run(text, "gcode", _axes(m))
    step = np.array([APPROACH[a.unit] for a in m.axes])
    assert _check_safe_moves(prog, m, 700.0, step) > 0
    lifts = [mv.pos["Z"] for mv in prog.moves if mv.axes == ("Z",) and mv.before["Z"] is not None
             and mv.pos["Z"] > mv.before["Z"]]
    assert min(lifts) == pytest.approx(700.0) and max(lifts) < m.axis("Z").upper_user
    with pytest.raises(InputError, match="`safe_z_mm` 2000"):
        write_program("gcode", m, p.template, p.steps, safe_z_mm=2000.0)
    with pytest.raises(InputError, match="`retract` C"):
        write_program("gcode", m, p.template, p.steps, retract="C")
    args = ["plan", "flow_xyzcb", "--points", "16", "--order", "1", "--candidates", "200", "--quiet",
            "--out", str(tmp_path / "p")]
    for bad, said in ((["--safe-z", "-5"], "--safe-z -5: not a position inside the travel of Z (0 to 1001.8 mm"),
                      (["--safe-z", "nan"], "--safe-z nan"), (["--nest-dwell", "0"], "--nest-dwell 0"),
                      (["--retract-axis", "Q"], "--retract-axis Q: not a linear axis of flow_xyzcb (X, Y, Z)")):
        assert main(args + bad) == 2
        err = capsys.readouterr().err
        assert said in err and "Traceback" not in err
    assert main(args + ["--safe-z", "650", "--nest-dwell", "9", "--dialect", "fanuc"]) == 0
    prog = run((tmp_path / "p" / "O1000.nc").read_text(), "fanuc", _axes(m))
    assert _check_safe_moves(prog, m, 650.0, step) > 0
    # the printed travel of the lifts and plunges is what the program moves Z alone
    printed = float(re.search(r"Z to 650 mm .*?: ([\d.]+) m up and down", capsys.readouterr().out).group(1))
    z_alone = sum(abs(mv.pos["Z"] - mv.before["Z"]) for mv in prog.moves if mv.axes == ("Z",)
                  and mv.before["Z"] is not None)
    assert printed == pytest.approx(z_alone / 1000, abs=0.051)


def test_fanuc_comments_never_hold_a_semicolon(plans, machines):
    p, m = plans["flow_xyzcb"], machines["flow_xyzcb"]
    text = write_program("fanuc", m, p.template, p.steps, title="for a; b (test) 50%")
    assert ";" not in text and text.count("%") == 2
    run(text, "fanuc", _axes(m))


def _sign_test(m, axis, positions):
    a = m.axis(axis)
    return SignTest("c", m.name, axis.lower() * 2, axis, axis, a.unit, a.unit, positions, (0.0, 0.01), [], "rule")


@pytest.mark.parametrize("controller,dialect", [("siemens", "siemens-840d"), ("fanuc", "fanuc"),
                                                ("linuxcnc", "gcode")])
@pytest.mark.parametrize("axis,positions", [("X", (119.082, 2500.0)), ("C", (-100.5, 200.25))])
def test_sign_test_program_runs_in_machine_coordinates_and_mm(machines, controller, dialect, axis, positions):
    """From inch mode with a work offset, the program sets mm, moves only the axis in
    machine coordinates, stops at the two positions, each reached from below at the feed,
    and leaves the units as it found them (LinuxCNC) or says which stay."""
    m = machines["flow_xyzcb"]
    st = _sign_test(m, axis, positions)
    name, text = program(st, controller, axis)
    prog = run(text, dialect, {axis: (m.axis(axis).lower_user, m.axis(axis).upper_user)}, Start())
    assert {mv.frame for mv in prog.moves} <= {"machine", "incremental"} and prog.moves[0].frame == "machine"
    at_stop = []
    for k, e in enumerate(prog.events):
        if e[0] == "stop":
            mv = prog.moves[max(i for kind, i in prog.events[:k] if kind == "move")]
            at_stop.append(mv)
    assert [mv.pos[axis] for mv in at_stop] == pytest.approx(list(positions), abs=TOL)
    for mv in at_stop:
        assert mv.code == 1 and mv.pos[axis] - mv.before[axis] == pytest.approx(5.0 if axis == "X" else 2.0)
    if dialect == "gcode":
        assert prog.units_at_end == "inch"
    else:
        assert any(("G21" if dialect == "fanuc" else "G710") in c for c in prog.comments)


def test_the_interpreter_refuses_unsafe_programs(machines):
    """What the interpreter must catch, on hand-written programs."""
    axes = {"X": (0.0, 1000.0), "Z": (0.0, 500.0)}
    ok = {"gcode": "G21\nG17 G40 G49 G80 G90 G94\nG90 G53 G0 X10 Z400\nG4 P1\nM2\n",
          "fanuc": "%\nO0001\nG21\nG17 G40 G49 G80 G90 G94\nG90 G53 G00 X10. Z400.\nG04 P1000\nM30\n%\n",
          "siemens-840d": "G17 G40 G710 G90 G94\nTRAFOOF\nD0\nSUPA G0 X10 Z400\nG4 F1\nM30\n"}
    for d, text in ok.items():
        prog = run(text, d, axes)
        assert prog.moves[0].pos == {"X": 10.0, "Z": 400.0} and prog.moves[0].frame == "machine"
    bad = [("gcode", "G17 G40 G49 G80 G90 G94\nG90 G53 G0 X10 Z400\nM2\n", "units"),               # no G21
           ("gcode", "G21\nG17 G40 G80 G90 G94\nG90 G53 G0 X10 Z400\nM2\n", "tool length"),       # no G49
           ("gcode", "G21\nG17 G40 G49 G90 G94\nG0 G80 X10 Z400\nM2\n", "one modal group"),
           ("fanuc", "%\nO0001\nG21\nG17 G40 G49 G80 G91 G94\nG53 G00 X10. Z400.\nM30\n%\n", "G91"),
           ("fanuc", "%\nO0001 (A; B)\nG21\nM30\n%\n", "parenthes"),
           ("fanuc", "%\nO0001\nG21\n(READ X; THEN Y)\nM30\n%\n", "parenthes"),
           ("fanuc", "%\nO0001\nG21 G90\nM30\n%\n", "own"),
           ("siemens-840d", "G17 G40 G710 G90 G94\nD0\nSUPA G0 X10 Z400\nM30\n", "TRAORI"),
           ("siemens-840d", "G17 G40 G710 G90 G94\nTRAFOOF\nD0\nG53 G0 X10 Z400\nM30\n", "G53"),
           ("siemens-840d", "G17 G40 G71 G90 G94\nTRAFOOF\nD0\nSUPA G0 X10 Z400\nM30\n", "G71")]
    for d, text, why in bad:
        with pytest.raises(GCodeError, match=why):
            run(text, d, axes)
    # without G53 the point lands where the work offset puts it
    prog = run("G21\nG17 G40 G49 G80 G90 G94\nG0 X10 Z400\nM2\n", "gcode", axes, Start(offset={"X": 5.0}))
    assert prog.moves[0].frame == "work" and prog.moves[0].pos["X"] == 15.0


@pytest.mark.parametrize("approach", ["above", "both", "none"])
def test_other_approaches_on_a_head_table_machine(machines, approach):
    """head_table_bc (B in the head, C under the workpiece): from above, both ways (each
    command twice) and without an approach the program still reaches every planned point
    in machine coordinates with the moves that swing or travel made at the top of Z; from
    above the last move runs down onto the point."""
    m = machines["head_table_bc"]
    p = make_plan(m, PlanSettings(n_commands=20, order=1, candidates=200, validation_points=20, approach=approach))
    t = p.template
    for dialect in DIALECTS:
        prog = run(write_program(dialect, m, t, p.steps), dialect, _axes(m))
        dwell_at = [prog.moves[max(i for kind, i in prog.events[:k] if kind == "move")]
                    for k, e in enumerate(prog.events) if e[0] == "dwell"]
        tool_rows = t.instrument != "nest"   # (the table nests are read at the tool rows' dwells)
        np.testing.assert_allclose([[mv.pos[a] for a in m.axis_names] for mv in dwell_at], m.to_user(t.q[tool_rows]),
                                   atol=TOL)
        step = np.array([APPROACH[a.unit] for a in m.axes])
        assert _check_safe_moves(prog, m, m.axis("Z").upper_user, step) >= tool_rows.sum() // 2  # "both": pairs
        if approach == "above":
            assert all(mv.before["Z"] - mv.pos["Z"] == pytest.approx(5.0) and mv.code == 1 for mv in dwell_at)
