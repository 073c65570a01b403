"""The campaign simulator: reproducible, realistic magnitudes, noise as specified."""
import filecmp

import numpy as np
import pytest

from vecpin.measurement.campaign import read_campaign
from vecpin.measurement.registration import rigid_registration, registered_errors
from vecpin.planning.zones import parse_zone
from vecpin.simulation.simulate import Design, design_commands, simulate
from vecpin.measurement.tracker import Tracker, TrackerNoise, cartesian_to_spherical, spherical_jacobian, spherical_to_cartesian
from vecpin.simulation.truth import TrueMachine


def test_same_seed_same_files(flow, tmp_path):
    d = Design(n_commands=20, n_validation=5)
    a = simulate(flow, seed=3, design=d).write(tmp_path / "a")
    b = simulate(flow, seed=3, design=d).write(tmp_path / "b")
    c = simulate(flow, seed=4, design=d).write(tmp_path / "c")
    for key in a:
        assert filecmp.cmp(a[key], b[key], shallow=False), key
    assert not filecmp.cmp(a["campaign"], c["campaign"], shallow=False)


def test_paper_one_design_and_written_files_read_back(flow, tmp_path):
    sim = simulate(flow, seed=1)
    c = sim.campaign
    assert len(c) == 590 and len(sim.validation) == 35
    np.testing.assert_allclose(np.unique(c.tool), [0.21488, 0.31286])
    # short tool first, then the same commands with the long tool
    np.testing.assert_array_equal(c.q[:295], c.q[295:])
    assert np.all(np.diff(c.time) > 0)
    paths = sim.write(tmp_path)
    back = read_campaign(paths["campaign"], flow)
    np.testing.assert_allclose(back.xyz, c.xyz, atol=1e-9)
    truth = TrueMachine.load(paths["truth"], flow)
    np.testing.assert_allclose(truth.tool_tip(c.q, c.tool), sim.truth.tool_tip(c.q, c.tool), atol=1e-12)
    exact = read_campaign(paths["validation_truth"], flow)
    np.testing.assert_allclose(exact.xyz, sim.truth.measure(exact.q, exact.tool, None), atol=1e-9)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_uncompensated_error_is_of_the_seeds_order(flow, seed):
    """Paper I: mean 0.602 mm, max 1.417 mm before compensation."""
    sim = simulate(flow, seed=seed, mean_error_mm=0.65)
    c = sim.campaign
    err = np.linalg.norm(registered_errors(flow.tool_tip(c.q, c.tool), c.xyz), axis=1)
    assert 0.3e-3 < err.mean() < 0.8e-3
    assert err.max() < 3e-3


def test_noise_free_truth_has_no_noise_and_noisy_has_the_right_size(flow):
    sim = simulate(flow, seed=5, design=Design(n_commands=400, n_validation=5))
    c = sim.campaign
    exact = sim.truth.measure(c.q, c.tool, None)
    d = np.linalg.norm(c.xyz - exact, axis=1)
    # axis repeatability 6 µm and tracker noise of a few tens of µm at 2-6 m
    assert 5e-6 < d.mean() < 60e-6


def test_tracker_noise_is_spherical_and_range_dependent(rng):
    noise = TrackerNoise(range_const=2e-6, range_ppm=1e-6, transverse_const=4e-6, transverse_ppm=5e-6)
    tr = Tracker(np.eye(3), np.zeros(3), noise)
    p = np.tile([[3.0, 4.0, 1.0]], (20000, 1))
    s0 = cartesian_to_spherical(p[:1])[0]
    s = cartesian_to_spherical(tr.measure(p, rng))
    R = np.linalg.norm(p[0])
    assert np.std(s[:, 0]) == pytest.approx(2e-6 + 1e-6 * R, rel=0.05)
    assert np.std(s[:, 1]) == pytest.approx((4e-6 + 5e-6 * R) / R, rel=0.05)
    assert np.std(s[:, 2]) == pytest.approx((4e-6 + 5e-6 * R) / R, rel=0.05)
    assert np.mean(s[:, 0]) == pytest.approx(s0[0], abs=1e-7)


def test_spherical_conversions_and_jacobian(rng):
    p = rng.normal(size=(50, 3)) * 3
    np.testing.assert_allclose(spherical_to_cartesian(cartesian_to_spherical(p)), p, atol=1e-12)
    J = spherical_jacobian(p)
    h = 1e-6
    for k in range(3):
        dp = np.zeros(3)
        dp[k] = h
        fd = (cartesian_to_spherical(p + dp) - cartesian_to_spherical(p - dp)) / (2 * h)
        np.testing.assert_allclose(J[:, :, k], fd, atol=1e-7)


def test_exclusion_zone_is_respected(flow, rng):
    zone = parse_zone("X=0:3000,B=-111:0")
    q = design_commands(flow, 300, rng, "sobol", [zone])
    x_mm, b_deg = q[:, 0] * 1e3, np.degrees(q[:, 4])
    assert len(q) == 300
    assert not np.any((x_mm >= 0) & (x_mm <= 3000) & (b_deg <= 0))
    assert np.any(x_mm <= 3000) and np.any(b_deg <= 0)


def test_registration_recovers_a_rigid_pose(rng):
    P = rng.normal(size=(30, 3))
    from vecpin.kinematics.so3 import exp3
    R = exp3(np.array([0.3, -1.2, 2.0]))
    t = np.array([1.0, -2.0, 0.5])
    R2, t2 = rigid_registration(P, P @ R.T + t)
    np.testing.assert_allclose(R2, R, atol=1e-12)
    np.testing.assert_allclose(t2, t, atol=1e-12)


@pytest.mark.parametrize("name", ["cincinnati_20v", "snk_120v", "ingersoll_xyzca"])
def test_other_machines_simulate(machines, name):
    m = machines[name]
    sim = simulate(m, seed=0, design=Design(n_commands=50, n_validation=5))
    c = sim.campaign
    err = np.linalg.norm(registered_errors(m.tool_tip(c.q, c.tool), c.xyz), axis=1)
    assert 0.1e-3 < err.mean() < 1.5e-3


@pytest.mark.parametrize("read_dwell_s", [None, 1.5])
def test_a_validation_runs_further_readings_are_the_read_dwell_apart(machines, tmp_path, read_dwell_s):
    """A table machine's validation run reads every point VALIDATION_READS times at its
    standstill: each further reading is stamped `read_dwell_s` (default the NC program's
    2 s) after the reading before it, as the plan's program dwells; the first readings
    come as the design times a run of them alone (10 min after the campaign, then 15 s per
    point plus the linear axes' path at 0.1 m/s, computed here), each later by the dwells
    of the further readings before it; the run through the tables too; the written files
    read back (time never goes backwards)."""
    from vecpin.compensation.tables import TableSet
    from vecpin.planning.nests import VALIDATION_READS as k
    m = machines["trunnion_xyzac"]
    d = Design(n_commands=30, n_validation=6)
    kw = {} if read_dwell_s is None else {"read_dwell_s": read_dwell_s}
    sim = simulate(m, seed=2, design=d, tables=TableSet(m.axis_names, []), **kw)
    dwell = 2.0 if read_dwell_s is None else read_dwell_s
    lin = [a.index for a in m.axes if a.kind == "linear"]
    start = sim.campaign.time[-1] + 600.0
    for run in (sim.validation, sim.compensated):
        q, t = run.q, run.time
        assert len(run) == 6 * 4 * k  # every command: the tool and 3 nests, each read k times in a row
        first = np.arange(len(run)) % k == 0
        path = np.r_[0.0, np.linalg.norm(np.diff(q[first][:, lin], axis=0), axis=1)]
        alone = start + np.cumsum(15.0 + path / 0.1)   # the design's time stamps of the first readings alone
        np.testing.assert_allclose(t[first], alone + dwell * (k - 1) * np.arange(first.sum()), rtol=0, atol=1e-9)
        np.testing.assert_allclose(np.diff(t)[~first[1:]], dwell, rtol=0, atol=1e-9)
        again = ~first[1:]
        assert np.all(q[1:][again] == q[:-1][again]) and np.all(run.target[1:][again] == run.target[:-1][again])
        assert np.all(np.diff(t) > 0)
        start = t[-1] + 600.0
    paths = sim.write(tmp_path)
    np.testing.assert_allclose(read_campaign(paths["validation"], m).time, sim.validation.time, atol=1e-3)
