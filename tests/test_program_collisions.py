"""Issue 41: vecpin's measurement programs, run by the tests' own interpreters (G-code:
tests/gcode.py; HEIDENHAIN conversational: tests/heidenhain.py, both from the controls'
manuals, no vecpin code), put the target holder into no part of the machine at any
position they pass, and stop at exactly the planned commands: on a trunnion
(trunnion_xyzac), an all-table machine (xyzac_trt) and a head machine (flow_xyzcb).

The judge of a collision is vecpin's holder geometry
(:meth:`SightLine.collisions`, the machine's URDF solids), posed here at every move's
ends and at its quarter points as the interpreters report them; no rapid runs past a
point toward the work (Z+ lifts the tool on these machines). Issue 42: a sign test moves
the axis under test alone (after lifting Z before a rotary axis turns), and an address
of another axis is refused naming the profile field."""
import re

import numpy as np
import pinocchio as pin
import pytest

from gcode import GCodeError, Start, run
from vecpin.errors import InputError
from vecpin.export.signtest import SignTest, check_address, program
from vecpin.planning.ncprogram import write_program
from vecpin.planning.plan import PlanSettings, make_plan
from vecpin.planning.sightline import SightLine, _joint_placements

TOL = 5e-4
NAMES = ["trunnion_xyzac", "xyzac_trt", "flow_xyzcb"]


@pytest.fixture(scope="module")
def runs(machines):
    """Per machine: the plan (12 commands, two holders, no nests), its geometry and the
    plan program in G-code and Klartext (the validation run in Klartext)."""
    out = {}
    for name in NAMES:
        m = machines[name]
        p = make_plan(m, PlanSettings(n_commands=12, order=1, candidates=80, validation_points=10, n_validation=6,
                                      nests=0))
        sl = SightLine(m, p.tracker)
        out[name] = (m, p, sl, {d: write_program(d, m, p.template, p.steps, sight=sl) for d in ("gcode", "heidenhain")},
                     write_program("heidenhain", m, p.validation_template, p.steps, sight=sl, program_number=1001))
    return out


def _axes(m):
    return {a.name: (a.lower_user, a.upper_user) for a in m.axes}


def _visited(prog, m, tools):
    """(positions (k, n) mm/deg, holder [m] at each) of every move's ends and quarter
    points from a known position; the holder is the one the last stop before the move
    mounts (its message names the length)."""
    pos, hold = [], []
    mounts = [(ln, float(re.search(r"holder of ([\d.]+) mm", c, re.I).group(1)) / 1000.0)
              for ln, c in prog.stops if re.search(r"holder of ([\d.]+) mm", c, re.I)]  # what each stop mounts
    assert [x for _, x in mounts] == pytest.approx(tools)
    for mv in prog.moves:
        L = max([(ln, x) for ln, x in mounts if ln < mv.line] or [mounts[0]])[1]
        if any(mv.pos[a] is None for a in m.axis_names):  # a move from where the machine stood: not known yet
            continue
        if any(mv.before[a] is None for a in m.axis_names):
            pos.append([mv.pos[a] for a in m.axis_names])
            hold.append(L)
            continue
        a, b = (np.array([d[x] for x in m.axis_names]) for d in (mv.before, mv.pos))
        for t in (0.0, 0.25, 0.5, 0.75, 1.0):
            pos.append(a + t * (b - a))
            hold.append(L)
    return np.array(pos, float), np.array(hold)


@pytest.mark.parametrize("dialect", ["gcode", "heidenhain"])
@pytest.mark.parametrize("name", NAMES)
def test_every_position_the_program_passes_is_free_and_the_stops_are_the_plan(runs, name, dialect):
    m, p, sl, texts, _ = runs[name]
    t = p.template
    prog = run(texts[dialect], dialect, _axes(m), Start())
    assert {mv.frame for mv in prog.moves} == {"machine"}
    # one holder change per holder length, in the plan's order: the stops name them
    tools = list(dict.fromkeys(float(x) for x in t.tool))
    assert len(prog.stops) == len(tools)
    q, hold = _visited(prog, m, tools)
    hits = sl.collisions(m.to_si(q), hold)
    assert not np.any(hits != ""), f"{np.sum(hits != '')} positions collide: {set(hits[hits != ''])}"
    # at each dwell the machine stands at the plan's command, reached at the feed, never from below on Z
    at = [prog.moves[max(i for kind, i in prog.events[:j] if kind == "move")]
          for j, e in enumerate(prog.events) if e[0] == "dwell"]
    np.testing.assert_allclose([[mv.pos[a] for a in m.axis_names] for mv in at], m.to_user(t.q), atol=TOL)
    assert all(mv.code == 1 and mv.before["Z"] >= mv.pos["Z"] - TOL for mv in at)
    header = " ".join(prog.comments[:40]).lower()
    assert "approach clearance 5 mm / 1 deg" in header and "clear of it" in header


def test_the_validation_run_in_klartext_is_free_too(runs):
    for name in NAMES:
        m, p, sl, _, text = runs[name]
        assert text.splitlines()[0] == "0 BEGIN PGM VALID MM" and text.rstrip().endswith("END PGM VALID MM")
        prog = run(text, "heidenhain", _axes(m), Start())
        q, hold = _visited(prog, m, [float(p.validation_template.tool[0])])
        assert not np.any(sl.collisions(m.to_si(q), hold) != "")
        assert len(prog.dwells) == len(p.validation_template)


def test_the_klartext_interpreter_refuses_what_a_measurement_program_must_not_do():
    axes = {"X": (-500.0, 500.0), "Z": (-450.0, 0.0)}
    good = ["0 BEGIN PGM T MM", "1 L M129", "2 L X+10.000 Z+0.000 R0 FMAX M91", "3 L X+12.000 R0 F500 M91",
            "4 CYCL DEF 9.0 DWELL TIME", "5 CYCL DEF 9.1 DWELL 2.5", "6 END PGM T MM"]
    prog = run("\n".join(good) + "\n", "heidenhain", axes, Start())
    assert prog.dwells == [2.5] and [mv.pos["X"] for mv in prog.moves] == [10.0, 12.0]
    for k, bad, said in ((2, "2 L X+10.000 Z+0.000 R0 FMAX", "tool length"),       # workpiece coordinates
                         (1, "1 L M0", "M0"), (2, "2 L X+10.000 Z+0.000 RL FMAX M91", "radius"),
                         (3, "3 L X+12.000 R0 M91", "without a feed"), (5, "5 L X+1 R0 FMAX M91", "9.1 DWELL")):
        lines = list(good)
        lines[k] = bad
        with pytest.raises(GCodeError, match=said):
            run("\n".join(lines) + "\n", "heidenhain", axes, Start())
    with pytest.raises(GCodeError, match="TCPM"):  # M128 left on by the control
        tcpm = good[:1] + [g.replace("1 L M129", "1 L M128") for g in good[1:]]
        run("\n".join(tcpm) + "\n", "heidenhain", axes, Start())


@pytest.mark.parametrize("dialect", ["heidenhain", "linuxcnc", "siemens"])
def test_a_sign_test_moves_the_axis_under_test_alone_after_the_lift(machines, dialect):
    m = machines["trunnion_xyzac"]
    st = SignTest(dialect, m.name, "aa", "A", "A", "deg", "deg", (-100.0, 20.0), (0.01, -0.02), ["A.COM"], "rule")
    _, text = program(st, dialect, "A", ("Z", 0.0))
    prog = run(text, {"linuxcnc": "gcode", "siemens": "siemens-840d"}.get(dialect, dialect), _axes(m), Start())
    assert prog.moves[0].axes == ("Z",) and prog.moves[0].pos["Z"] == 0.0   # lifted before A turns
    assert all(mv.axes == ("A",) for mv in prog.moves[1:]) and len(prog.stops) == 2


def test_an_address_of_another_axis_is_refused_naming_the_field():
    others = {"X": "X", "Y": "Y", "Z": "Z"}
    with pytest.raises(InputError, match=r"'axes\.X\.program_name'.*address of axis Z"):
        check_address("Z", "siemens", "X", "profile p.json", others)
    check_address("X", "siemens", "X", "profile p.json", others)


def test_the_batched_joint_placements_are_pinocchios(machines):
    """The holder checks pose every solid with placements computed for all poses at once:
    they are Pinocchio's forwardKinematics, pose by pose."""
    for name in ("trunnion_xyzac", "flow_xyzcb", "ur5"):
        m = machines[name]
        q = m.lower + np.random.default_rng(3).random((6, m.n_axes)) * (m.upper - m.lower)
        qf = m.full_q(q)
        got = _joint_placements(m.model, qf)
        data = m.model.createData()
        for i in range(len(q)):
            pin.forwardKinematics(m.model, data, qf[i])
            for j in range(m.model.njoints):
                np.testing.assert_allclose(got[i, j], data.oMi[j].homogeneous, atol=1e-12)
