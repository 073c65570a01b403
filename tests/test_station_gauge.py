"""A second tracker station's pose in the fit (issue 24's leftover): what the rows of a
two-station campaign determine, and what they cannot.

Closed form: a rigid motion g of the whole machine (every modelled point, tool and table
alike) with the same motion of every tracker station changes no reading. With one
station E_0 carries g and the model's terms that would repeat it are removed; with two,
the stations' poses together carry it. Tested before the model in the redundancy test
(as now), they are kept and the model loses exactly the terms a one-station fit loses;
tested after it (as before), station 1's dx and ex were removed (held at the start) and
its other components called "barely identifiable". What the rows do determine is gauge
free: station 1's pose relative to station 0 and every tool tip relative to the
workpiece.

Judged against the simulated truth (its trackers' poses and its tip relative to its
table), with scipy's rotations for the poses; the prior on the stations' poses (an
arbitrary number) is changed tenfold both ways to show it decides only the gauge."""
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import qmc

import vecpin.identification.likelihood as likelihood
import vecpin.measurement.instruments.tracker as tracker_module
from vecpin.errors import IdentifiabilityError, VecpinWarning
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.instruments.points import initial_setup
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.planning.plan import PlanSettings, make_plan
from vecpin.simulation.simulate import Design, simulate


@pytest.fixture(scope="module")
def trunnion_plan(machines):
    """The A-C trunnion's default plan (three placed nests, a second station proposed)."""
    m = machines["trunnion_xyzac"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", VecpinWarning)
        plan = make_plan(m, PlanSettings(seed=0))
    assert len(plan.placement.stations) == 2
    return m, plan


def _fit(m, campaign, truth):
    """The truth's own bases (what is left is the parameters' error), its tracker noise."""
    noise = NoiseModel.default(m, "spherical", tracker=truth.tracker.noise)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", VecpinWarning)
        return make_model("6dof", m, 4, bases=truth.family_bases()).fit(campaign, noise)


def _affine(R, t, e):
    """A station's map machine frame -> station frame, p -> A p + a (scipy's rotation vector)."""
    E = Rotation.from_rotvec(e[3:]).as_matrix()
    return R @ E, R @ e[:3] + t


def relative_pose_error_um(setup, truth, points) -> float:
    """Largest displacement [um] at machine-frame ``points`` of the fitted map from station
    0's frame to station 1's against the true one: gauge free (a rigid motion of the
    machine frame moved into both stations cancels)."""
    (A0, a0), (A1, a1) = _affine(*setup.pose(0)), _affine(*setup.pose(1))
    T0, T1 = truth.tracker, truth.stations[0]
    x = T0.to_tracker(points)                                   # true station-0 readings
    fitted = ((x - a0) @ np.linalg.inv(A0).T) @ A1.T + a1
    true = ((x - T0.translation) @ T0.rotation) @ T1.rotation.T + T1.translation
    return float(np.linalg.norm(fitted - true, axis=1).max() * 1e6)


def _table_tips(model, q, tool):
    return model.tool_tip(q, np.full(len(q), tool), model.b_, jacobian=False, frame="workpiece").tip


def _rigid_residual(a, b):
    """(N,3) what is left of b - a after b is moved rigidly onto a (scipy; the part's set-up
    is a rigid motion relative to the table: no machine error)."""
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    R = Rotation.align_vectors(a - ca, b - cb)[0].as_matrix()
    return (b - cb) @ R.T + ca - a


@pytest.mark.parametrize("seed, moved", [(1, (0, 0, 0)), (2, (0, 0, 0)), (3, (0.5, -0.6, 0.2))])
def test_the_two_station_plan_determines_the_second_pose_without_a_warning(trunnion_plan, seed, moved):
    """Fitted, the plan's two-station campaign keeps all six pose unknowns of station 1 (no
    warning names a station), removes exactly the model terms the fit of station 0's rows
    alone removes, and finds station 1 relative to station 0 within 10 um of the truth's at
    the measured points, from a start (the rigid registration of its rows on the nominal
    machine, not the planned position) three times further off (measured: 4.8, 2.4, 4.7
    um from 24, 106, 57 um). Seed 3's tracker stands 0.8 m from where the plan put it, as
    a real set-up may: the fit never sees the planned position."""
    m, plan = trunnion_plan
    where = [plan.placement.stations[0], plan.placement.stations[1] + np.array(moved)]
    sim = simulate(m, seed=seed, plan=plan.template, station_positions=where)
    c, truth = sim.campaign, sim.truth
    both = _fit(m, c, truth)
    alone = _fit(m, c.subset(np.flatnonzero(c.station == 0)), truth)
    rep = both.report_
    assert not [w for w in rep.warnings if "station" in w]
    assert not [n for n in rep.removed + rep.weak if n.startswith("station")]
    assert rep.removed == alone.report_.removed
    points = truth.tool_tip(c.q[c.station == 0], c.tool[c.station == 0])
    start = relative_pose_error_um(initial_setup(m, c), truth, points)
    fitted = relative_pose_error_um(both.setup_, truth, points)
    assert fitted < 10.0 and fitted < start / 3, (fitted, start)


def test_the_pose_prior_decides_only_the_gauge(trunnion_plan, monkeypatch):
    """The prior on the stations' pose corrections (1e-2 m, rad) changed to 1e-3 and 1e-1:
    E_0 moves (a direction of the gauge is held by the priors: the model's bases follow a
    rigid motion of the table's housing only approximately) and with it the part's set-up
    (a rigid motion of every tip relative to the workpiece), but no tool tip relative to
    the workpiece at 2000 commands over the travel moves by 0.5 um (0.1 um on average)
    beyond that rigid motion, and station 1 relative to station 0 not by 0.05 um
    (measured at 1e-3: E_0 moves 95 um, the tips 0.21 um at most, 0.05 um on average,
    station 1 relative to station 0 0.0001 um; the model's bases leave ~1e-3 of a rigid
    motion of the housing unfollowed, and 1e-3 of 95 um is what moves)."""
    m, plan = trunnion_plan
    sim = simulate(m, seed=1, plan=plan.template, station_positions=plan.placement.stations)
    c, truth = sim.campaign, sim.truth
    q = m.lower + qmc.Halton(m.n_axes, seed=5).random(2000) * (m.upper - m.lower)
    tool = float(plan.tools[0])
    points = truth.tool_tip(c.q[c.station == 0], c.tool[c.station == 0])
    fits = {}
    for prior in (1e-2, 1e-3, 1e-1):
        monkeypatch.setattr(tracker_module, "POSE_PRIOR", prior)
        monkeypatch.setattr(likelihood, "E0_PRIORS", np.full(6, prior))
        fits[prior] = _fit(m, c, truth)
    ref = fits[1e-2]
    moved = max(np.abs(f.e0_[:3] - ref.e0_[:3]).max() for f in fits.values())
    assert moved > 1e-6  # the gauge is there: E_0 itself is not determined by the rows
    for f in fits.values():
        d = np.linalg.norm(_rigid_residual(_table_tips(ref, q, tool), _table_tips(f, q, tool)), axis=1)
        assert d.max() < 5e-7 and d.mean() < 1e-7
        assert abs(relative_pose_error_um(f.setup_, truth, points)
                   - relative_pose_error_um(ref.setup_, truth, points)) < 0.05


def test_a_head_machine_read_from_two_stations_keeps_both_poses(flow):
    """flow_xyzcb read from two stations (the simulator's design): no station term removed
    (before: all six, station 1 held at its start and the model's constants carrying its
    error), the model loses the terms a one-station fit loses, station 1 relative to
    station 0 within 10 um of the truth's."""
    sim = simulate(flow, seed=0, design=Design(stations=2))
    c, truth = sim.campaign, sim.truth
    both = _fit(flow, c, truth)
    alone = _fit(flow, c.subset(np.flatnonzero(c.station == 0)), truth)
    assert not [n for n in both.report_.removed + both.report_.weak if n.startswith("station")]
    assert both.report_.removed == alone.report_.removed
    assert not [w for w in both.report_.warnings if "station" in w]
    points = truth.tool_tip(c.q[c.station == 0], c.tool[c.station == 0])
    assert relative_pose_error_um(both.setup_, truth, points) < 10.0


def _with_station_one(c, truth, q, tool, seed=7):
    """Station 0's rows of ``c`` and station 1 reading the tool at commands q (K,n) [m, rad]
    with holders ``tool`` (K,) [m] (the truth's second tracker, its noise)."""
    zero = c.subset(np.flatnonzero(c.station == 0))
    xyz = truth.measure(q, tool, np.random.default_rng(seed), station=1)
    return Campaign(zero.axis_names, np.vstack([zero.q, q]), np.r_[zero.tool, tool], np.vstack([zero.xyz, xyz]), {},
                    "two_stations.csv", station=np.r_[zero.station, np.ones(len(q), int)])


def test_a_station_that_reads_too_little_is_named_with_what_to_read(flow):
    """Station 1 reading the tool at one command with both holders (two points on the tool
    axis: a turn about that line moves neither) is refused naming the file, the station,
    the rows and what to read; with a third point 0.05 mm off that line (X moved) the fit
    runs, names the station, the pose components its rows barely fix and what to read;
    at a dozen commands over the travel it says nothing of the station."""
    sim = simulate(flow, seed=0, design=Design(stations=2))
    c, truth = sim.campaign, sim.truth
    one = np.flatnonzero(c.station == 1)
    qa, tools = c.q[one[0]], np.unique(c.tool)[:2]
    line = _with_station_one(c, truth, np.array([qa, qa]), tools)
    with pytest.raises(IdentifiabilityError, match=r"two_stations.csv: tracker station 1 reads 2 points on a line "
                                                   r"\(rows \d+, \d+\).*at least three points"):
        _fit(flow, line, truth)
    near = qa + np.eye(flow.n_axes)[flow.axis("X").index] * 5e-5
    few = _with_station_one(c, truth, np.array([qa, qa, near]), np.r_[tools, tools[0]])
    msgs = [w for w in _fit(flow, few, truth).report_.warnings if "station" in w]
    assert len(msgs) == 1 and msgs[0].startswith("two_stations.csv: tracker station 1 ")
    assert "do not determine" in msgs[0] and "3 tool and 0 nest readings at 2 commands" in msgs[0]
    assert "at least three points" in msgs[0] and "ez" in msgs[0]
    pick = one[:: len(one) // 12][:12]
    dozen = _with_station_one(c, truth, c.q[pick], c.tool[pick])
    assert not [w for w in _fit(flow, dozen, truth).report_.warnings if "station" in w]
