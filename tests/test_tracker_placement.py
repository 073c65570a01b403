"""Where the tracker stands: it must see the tool tips past the machine's own geometry.

The front (-y) set-up of a gantry is blocked by a trunnion's column (the column of the
bundled trunnions stands on -y): before the placement looked at the geometry, every
simulated and planned trunnion campaign was "measured" through the column. Judged with
the line-of-sight test (its closed forms are tested in test_planning.py) on other
commands than those the placement chose by.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import qmc

from vecpin.kinematics.machine import Machine
from vecpin.measurement.tracker import TrackerNoise
from vecpin.planning.sightline import SightLine, default_tracker_position, tracker_side
from vecpin.simulation.truth import place_tracker


def _visible(m: Machine, position: np.ndarray) -> float:
    u = qmc.Halton(m.n_axes, seed=7).random(200)  # not the placement's own commands (seed 0)
    q = m.lower + u * (m.upper - m.lower)
    return 1.0 - SightLine(m, position).check(q, 0.25).blocked.mean()


@pytest.mark.parametrize("name", ["trunnion_xyzac", "trunnion_xyzbc", "spar_mill_23"])
def test_blocked_front_moves_the_tracker_where_it_sees(name):
    m = Machine.load(name)
    az, _ = tracker_side(m)
    assert az != 0.0  # the front is hidden on these machines
    assert _visible(m, default_tracker_position(m)) > 0.6
    for seed in (0, 1):
        assert _visible(m, place_tracker(m, np.random.default_rng(seed), TrackerNoise(), 2.0).position_in_machine) > 0.6


@pytest.mark.parametrize("name", ["flow_xyzcb", "cincinnati_20v", "ingersoll_xyzca"])
def test_open_front_keeps_the_usual_set_up(name):
    m = Machine.load(name)
    assert tracker_side(m)[0] == 0.0
    p = default_tracker_position(m)
    u = qmc.Halton(m.n_axes, seed=0).random(256)
    tips = m.tool_tip(m.lower + u * (m.upper - m.lower), 0.25, frame="base")
    assert p[1] == pytest.approx(tips[:, 1].min() - 2.0) and p[2] == pytest.approx(tips[:, 2].min())


def test_trunnion_column_side_is_the_blocked_one():
    """Independent of the search: a straight line from the front position to the table
    centre crosses the column box of the URDF (y = -0.55 +- 0.15 m, x +- 0.45, z -0.6..1.4)."""
    m = Machine.load("trunnion_xyzac")
    u = qmc.Halton(m.n_axes, seed=0).random(256)
    tips = m.tool_tip(m.lower + u * (m.upper - m.lower), 0.25, frame="base")
    lo, hi = tips.min(0), tips.max(0)
    front = np.array([(lo[0] + hi[0]) / 2, lo[1] - 2.0, lo[2]])
    centre = (lo + hi) / 2
    t = (-0.55 - front[1]) / (centre[1] - front[1])  # where the line reaches the column's mid-plane
    at = front + t * (centre - front)
    assert 0 < t < 1 and abs(at[0]) < 0.45 and -0.6 < at[2] < 1.4
    assert _visible(m, front) < 0.1


def test_scene_camera_looks_from_the_trackers_side():
    """The scene's camera stands where the tracker stands (the side from which the tips
    are in sight), not behind a trunnion's column: its direction from the workspace
    centre is within 45 degrees of the tracker's, and it is above the centre."""
    from vecpin.measurement.noise import NoiseModel
    from vecpin.models import make_model
    from vecpin.simulation.simulate import Design, simulate
    from vecpin.viz.scene import _camera, to_machine_frame
    m = Machine.load("trunnion_xyzac")
    sim = simulate(m, seed=1, design=Design(n_commands=60, nests=0))
    model = make_model("ap", m, 1, basis="chebyshev")
    model.fit(sim.campaign, NoiseModel.default(m))
    tips = m.tool_tip(sim.campaign.q, sim.campaign.tool, frame="base")
    centre = 0.5 * (tips.min(0) + tips.max(0))
    cam = np.array(_camera(model, centre, 0.9))
    world = np.array([cam[0], -cam[2], cam[1]])  # meshcat's Y-up 'rotated' frame -> machine frame
    tracker = to_machine_frame(model, np.zeros((1, 3)))[0] - centre
    cos = world[:2] @ tracker[:2] / np.linalg.norm(world[:2]) / np.linalg.norm(tracker[:2])
    assert cos > np.cos(np.radians(45)) and world[2] > 0 and tracker[1] > 0  # the open (+y) side
