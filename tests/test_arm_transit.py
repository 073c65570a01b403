"""Issue 41: every move of an arm's program free of the arm, by a judge vecpin did not write.

A 20-point program on the bundled UR5 (the points anywhere in the joints' travel, as a
plan's candidates are, each free and approachable with both holders; one pass per
holder, the second reversed, as a plan orders them) is routed by
:func:`vecpin.planning.armprogram.arm_route` and written as URScript; the program is run
by the reader written from the Script Manual (tests/robot_programs.py) and every joint
move it makes, approach, measure, retract and via poses alike, is posed every 5 deg by
tests/collision_judge.py (Pinocchio and Coal on the URDF, no vecpin code) with the
holder a capsule of the radius the program states: none may meet the arm. The direct
moves of the same order do (the test would prove nothing otherwise)."""
from __future__ import annotations

import re

import numpy as np

from collision_judge import judge
from robot_programs import run_urscript
from vecpin.kinematics.machine import Machine
from vecpin.measurement.plantemplate import PlanTemplate
from vecpin.planning.armpose import screen_approaches
from vecpin.planning.armprogram import arm_route, write_arm_program
from vecpin.planning.sightline import SightLine

HOLDERS = (0.21488, 0.31286)   # m: the docs' UR5 plan's holders
CLEARANCE = 0.005              # m: the approach pose's clearance (the plan's default)
RADIUS = 0.010                 # m: the holder's radius (the plan's default)


def _judged_hits(text: str, radius: float, stop: int = 0) -> list[tuple[str, str]]:
    """(from, to) point names of every move of the URScript ``text`` whose path, posed
    every 5 deg, puts the holder into the UR5 (the first ``stop`` of them, 0: all)."""
    prog = run_urscript(text)
    j = judge("ur5", radius)
    names = [j.model.names[k] for k in range(1, j.model.njoints)]
    out = []
    for (_, p0, a, _), (_, p1, b, holder) in zip(prog.moves[:-1], prog.moves[1:]):
        n = int(np.ceil(max(np.degrees(np.abs(b - a)).max() / 5.0, 1)))
        path = np.degrees(a + np.linspace(0, 1, n + 1)[:, None] * (b - a))
        if j.colliding([dict(zip(names, p)) for p in path], holder):
            out.append((p0, p1))
            if len(out) == stop:
                break
    return out


def test_a_20_point_program_has_no_colliding_move():
    m = Machine.load("ur5")
    sight = SightLine(m, np.array([0.054, -2.815, -0.958]), tool_radius=RADIUS)
    rng = np.random.default_rng(3)
    q = m.lower + rng.random((40, m.n_axes)) * (m.upper - m.lower)
    for L in HOLDERS:   # free and approachable along the tool axis with both holders
        q = q[screen_approaches(m, q, CLEARANCE, sight, np.array([L])) == ""]
    q = q[:20]
    assert len(q) == 20
    t = PlanTemplate(point=np.arange(1, 41), q=np.vstack([q, q[::-1]]), tool=np.repeat(HOLDERS, 20))
    poses, left = arm_route(m, t, CLEARANCE, (4.0, 15.0, 2.0), 1, sight)
    assert left == []
    text = write_arm_program("urscript", m, t, CLEARANCE, route=(poses, left), radius=sight.holder_radius)
    radius = float(re.search(r"cylinder of radius ([\d.]+) mm", text).group(1)) / 1000
    assert radius == RADIUS
    assert _judged_hits(text, radius) == []
    direct = write_arm_program("urscript", m, t, CLEARANCE, route=([p for p in poses if p.kind != "via"], []))
    assert len(_judged_hits(direct, radius, stop=5)) == 5   # the moves the vias free do meet the arm


def test_the_holder_radius_counts_as_the_judge_counts_it():
    """Poses where the holder's axis clears the arm but a 10 mm holder does not: vecpin's
    check (the solids grown by the radius) finds them, and the judge's capsule of 10 mm
    meets the arm there too, of 0.5 mm not; where vecpin's check finds a 10 mm holder
    free, the judge does too."""
    m = Machine.load("ur5")
    thin = SightLine(m, np.zeros(3), tool_radius=0.0)
    thick = SightLine(m, np.zeros(3), tool_radius=RADIUS)
    q = m.lower + np.random.default_rng(5).random((400, m.n_axes)) * (m.upper - m.lower)
    edge = q[(thin.collisions(q, HOLDERS[1]) == "") & (thick.collisions(q, HOLDERS[1]) != "")]
    assert len(edge) >= 3
    names = list(judge("ur5").model.names[1:])
    wide, narrow = judge("ur5", RADIUS), judge("ur5", 0.0005)
    pos = [dict(zip(names, np.degrees(x))) for x in edge]
    assert len(narrow.colliding(pos, HOLDERS[1])) == 0
    assert len(wide.colliding(pos, HOLDERS[1])) == len(edge)
    free = q[thick.collisions(q, HOLDERS[1]) == ""]
    assert len(free) > 300 and wide.colliding([dict(zip(names, np.degrees(x))) for x in free], HOLDERS[1]) == []
