"""Maximum-likelihood identification on simulated machines with known errors."""
import json

import numpy as np
import pytest

from vecpin.errors import VecpinError
from vecpin.identification.likelihood import predict_tracker
from vecpin.measurement.instruments.tracker import E0_NAMES
from vecpin.measurement.setup import Setup
from vecpin.models import ErrorModel, make_model
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.registration import rigid_registration
from vecpin.identification.folds import command_folds
from vecpin.selection.orders import order_sweep
from vecpin.simulation.simulate import Design, simulate
from vecpin.kinematics.so3 import exp3
from vecpin.measurement.tracker import TrackerNoise, cartesian_to_spherical
from vecpin.simulation.truth import uniform_commands

pytestmark = pytest.mark.slow   # a long matrix: the edit loop (-m 'not slow') leaves it to CI

TOOLS = np.array([0.21488, 0.31286])


def _validation(sim, n=400, seed=99):
    rng = np.random.default_rng(seed)
    m = sim.truth.machine
    q = uniform_commands(m, n, rng)
    tool = TOOLS[rng.integers(0, 2, n)]
    return q, tool, sim.truth.measure(q, tool, None)


@pytest.fixture(scope="module")
def sims(machines):
    flow = machines["flow_xyzcb"]
    return {fam: simulate(flow, seed=12, mean_error_mm=0.65, family=fam) for fam in ("6dof", "ap")}


@pytest.mark.parametrize("kind", ["6dof", "ap"])
def test_fit_reaches_the_noise_limited_floor(flow, sims, kind):
    """Order chosen on held-out data (5-fold CV); noise-free validation error within
    1.2x of the floor, the fit of the true error family itself with the same data."""
    sim = sims[kind]
    q, tool, exact = _validation(sim)
    noise = NoiseModel.default(flow, "spherical")
    mean = lambda model: np.linalg.norm(model.predict_tip(q, tool) - exact, axis=1).mean()
    floor = mean(make_model(kind, flow, 4, bases=sim.truth.family_bases()).fit(sim.campaign, noise))
    sweep = order_sweep(flow, sim.campaign, kind, range(3, 9), noise=noise)
    got = mean(make_model(kind, flow, sweep.best.order).fit(sim.campaign, noise))
    assert floor < 0.012e-3  # noise-limited: about 8 µm from 18 µm-class measurements
    assert got <= 1.2 * floor, (sweep.best.order, got, floor)
    uncompensated = np.linalg.norm(sim.truth.tool_tip(q, tool) - flow.tool_tip(q, tool), axis=1).mean()
    assert got < 0.03 * uncompensated


@pytest.mark.parametrize("kind", ["6dof", "ap"])
def test_chi2_in_band_only_when_the_noise_model_is_right(flow, sims, kind):
    sim = sims[kind]
    results = {}
    for scale in (1 / 3, 1.0, 3.0):
        noise = NoiseModel.default(flow, "spherical")
        t = noise.tracker
        noise.tracker = TrackerNoise(t.range_const * scale, t.range_ppm * scale, t.transverse_const * scale, t.transverse_ppm * scale)
        noise.axis_sigma = noise.axis_sigma * scale
        rep = make_model(kind, flow, 4, bases=sim.truth.family_bases()).fit(sim.campaign, noise).report_
        results[scale] = rep
    assert results[1.0].chi2_in_band
    assert results[1 / 3].chi2 > results[1 / 3].chi2_band[1]   # noise model too optimistic
    assert results[3.0].chi2 < results[3.0].chi2_band[0]       # too pessimistic
    # a model that cannot describe the machine leaves the band too
    misfit = make_model(kind, flow, 1).fit(sim.campaign, NoiseModel.default(flow, "spherical")).report_
    assert misfit.chi2 > misfit.chi2_band[1]


@pytest.mark.parametrize("seed", [1, 2])
def test_spherical_beats_cartesian_on_a_long_machine(machines, seed):
    """Section 3.5.1, Table 3.1 shape: on the 12 m Ingersoll gantry, range-dependent
    spherical noise gives a smaller validation error and range residual."""
    m = machines["ingersoll_xyzca"]
    sim = simulate(m, seed=seed, design=Design(n_commands=212, n_validation=50), mean_error_mm=0.4,
                   tracker_noise=TrackerNoise(3e-6, 0.5e-6, 5e-6, 5e-6))
    q, tool, exact = _validation(sim, 500, seed=5)
    out = {}
    for inst in ("cartesian", "spherical"):
        noise = NoiseModel.default(m, inst, tracker=sim.truth.tracker.noise)
        model = make_model("6dof", m, 4, bases=sim.truth.family_bases()).fit(sim.campaign, noise)
        y = model.predict_tip(q, tool)
        out[inst] = (np.linalg.norm(y - exact, axis=1).mean(),
                     np.abs(cartesian_to_spherical(exact)[:, 0] - cartesian_to_spherical(y)[:, 0]).mean(),
                     model.report_)
    assert out["spherical"][0] < 0.9 * out["cartesian"][0]
    assert out["spherical"][1] < out["cartesian"][1]
    assert out["spherical"][2].chi2_in_band and not out["cartesian"][2].chi2_in_band


@pytest.mark.parametrize("kind", ["6dof", "ap"])
def test_estimator_prediction_jacobian_matches_finite_differences(flow, rng, kind):
    sim = simulate(flow, seed=3, design=Design(n_commands=8, n_validation=2))
    model = make_model(kind, flow, 2)
    R, t = rigid_registration(flow.tool_tip(sim.campaign.q, sim.campaign.tool), sim.campaign.xyz)
    c = sim.campaign

    def predict(th):
        return predict_tracker(model, c.q, c.tool, th, Setup(R, t))

    theta = rng.normal(size=model.n_parameters + 6) * 1e-4
    theta[3:6] = [0.01, -0.02, 0.005]
    y, dy, dq = predict(theta)
    h = 1e-7
    for k in range(theta.size):
        e = np.zeros_like(theta)
        e[k] = h
        fd = (predict(theta + e)[0] - predict(theta - e)[0]) / (2 * h)
        np.testing.assert_allclose(dy[:, :, k], fd, atol=5e-8)


def test_redundant_terms_found_numerically(flow, sims):
    """Paper I §2.2: for the XYZCB machine the first-order translations orthogonal to
    a linear axis' travel are redundant; rotations about the tool axis move nothing."""
    rep = make_model("6dof", flow, 3).fit(sims["6dof"].campaign).report_
    for name in ("X.dy.1", "X.dz.1", "Y.dx.1", "Y.dz.1", "Z.dx.1", "Z.dy.1", "B.ez.0", "B.ez.1", "B.ez.3", "X.dx.0", "B.dz.0"):
        assert name in rep.removed
    for name in ("X.dx.1", "C.dx.0", "X.ey.0", "E0.ex"):  # pitch, C offset, squareness-type terms stay
        assert name not in rep.removed
    assert rep.condition_number < 1e9
    ap = make_model("ap", flow, 3).fit(sims["ap"].campaign).report_
    assert {"X.offset", "Y.offset", "Z.offset"} <= set(ap.removed)  # taken by E_0 translations


def test_tracker_registration_needs_no_guess(flow):
    """An arbitrary tracker pose (any heading, 2 deg tilt) is found automatically; E_0 stays small."""
    sim = simulate(flow, seed=21, design=Design(n_commands=150))
    model = make_model("6dof", flow, 3).fit(sim.campaign, NoiseModel.default(flow, "spherical"))
    true = sim.truth.tracker
    R_fit = model.setup_.R @ exp3(model.e0_[3:])
    angle = np.degrees(np.arccos(np.clip((np.trace(R_fit.T @ true.rotation) - 1) / 2, -1, 1)))
    assert angle < 0.05
    assert np.all(np.abs(model.e0_[3:]) < 1e-3)


def test_parameter_uncertainty_covers_the_true_gauge_error(flow):
    hits = 0
    for seed in range(4):
        sim = simulate(flow, seed=40 + seed, design=Design(n_commands=150), family="ap")
        model = make_model("ap", flow, 4, bases=sim.truth.family_bases()).fit(sim.campaign, NoiseModel.default(flow, "spherical"))
        est, std = model.b_[0], model.std_[0]
        assert 0 < std < 20e-6
        hits += abs(est - sim.truth.gauge_error) < 3 * std
    assert hits >= 3


def test_fit_report_and_residuals(flow, sims):
    c = sims["6dof"].campaign
    model = make_model("ap", flow, 4).fit(c)
    rep = model.report_
    assert rep.n_rows == len(c) and rep.n_equations == 3 * len(c)
    assert set(rep.residuals_mm) == {"all", "tool 214.880 mm", "tool 312.860 mm"}
    d = np.linalg.norm(model.residuals(c), axis=1) * 1e3
    assert rep.residuals_mm["all"]["mean"] == pytest.approx(d.mean())
    assert "chi2" in rep.summary()


def test_model_file_round_trip_and_bad_files(flow, sims, tmp_path):
    c = sims["6dof"].campaign
    for kind in ("6dof", "ap"):
        model = make_model(kind, flow, 3, tool_lengths=list(TOOLS)).fit(c)
        model.save(tmp_path / "m.json")
        back = ErrorModel.load(tmp_path / "m.json")
        np.testing.assert_allclose(back.predict_tip(c.q, c.tool), model.predict_tip(c.q, c.tool), atol=1e-12)
        np.testing.assert_allclose(back.std_, model.std_, rtol=1e-9, atol=1e-15)
        d = json.loads((tmp_path / "m.json").read_text())
        assert d["format"] == "vecpin-model" and d["version"] == 1 and d["machine"]["name"] == "flow_xyzcb"
        assert [p["name"] for p in d["parameters"][:6]] == list(E0_NAMES)
    d["version"] = 99
    (tmp_path / "v.json").write_text(json.dumps(d))
    with pytest.raises(VecpinError, match="version 99"):
        ErrorModel.load(tmp_path / "v.json")
    (tmp_path / "x.json").write_text("{not json")
    with pytest.raises(VecpinError, match="not a JSON model file"):
        ErrorModel.load(tmp_path / "x.json")
    d["version"] = 1
    d["machine"]["urdf"] += " "
    (tmp_path / "h.json").write_text(json.dumps(d))
    with pytest.raises(VecpinError, match="checksum"):
        ErrorModel.load(tmp_path / "h.json")


def test_too_few_rows_for_the_order(flow):
    sim = simulate(flow, seed=1, design=Design(n_commands=10, n_validation=2))
    with pytest.raises(VecpinError, match="equations for"):
        make_model("6dof", flow, 6).fit(sim.campaign)


def test_cross_validation_keeps_both_tools_of_a_command_together(flow, sims, rng):
    c = sims["ap"].campaign
    folds = command_folds(c, 5, rng)
    np.testing.assert_array_equal(folds[:295], folds[295:])
    assert set(folds) == set(range(5))


def test_order_sweep_with_validation_file_has_table_two_shape(flow, sims):
    sim = sims["6dof"]
    sweep = order_sweep(flow, sim.campaign, "6dof", [0, 2, 4, 6], validation=sim.validation)
    means = [r.heldout_mean for r in sweep.rows]
    assert means[0] > means[1] > means[2]            # error falls with order ...
    assert sweep.best.order in (4, 6)
    assert sweep.rows[0].ident_mean < sweep.uncompensated_ident[0]
    # Paper I: at order 0 the 6-DoF model explains more than the AP model (80% vs 60%)
    ap0 = order_sweep(flow, sim.campaign, "ap", [0], validation=sim.validation).rows[0]
    assert sweep.rows[0].ident_mean < ap0.ident_mean
    assert "Uncompensated" in sweep.table() and "<- best" in sweep.table()


@pytest.mark.parametrize("mistake, message", [
    ("inches", "25.4 times"), ("swapped", "mirror image"), ("mirrored", "mirror image"),
    ("tool_in_metres", r"row\(s\) lie"), ("another_machine", "not this machine's campaign")])
def test_unit_and_frame_mistakes_are_refused_after_registration(flow, mistake, message):
    """Mistakes that pass the file checks (plausible numbers in every column) cannot
    give a 'fitted' model: the registration of the nominal tips finds them."""
    sim = simulate(flow, seed=2, design=Design(n_commands=40))
    c = sim.campaign
    if mistake == "inches":
        c.xyz = c.xyz * 25.4
    elif mistake == "swapped":
        c.xyz = c.xyz[:, [1, 0, 2]]
    elif mistake == "mirrored":
        c.xyz = c.xyz * [1.0, 1.0, -1.0]
    elif mistake == "tool_in_metres":  # one row typed 0.21488 (metres) where mm were meant: 0.21 mm tool
        c.tool = c.tool.copy()
        c.tool[7] = c.tool[7] * 1e-3
    elif mistake == "another_machine":
        rng = np.random.default_rng(1)
        c.q = c.q[rng.permutation(len(c.q))]
    with pytest.raises(VecpinError, match=message) as e:
        make_model("ap", flow, 2).fit(c)
    if mistake == "tool_in_metres":
        assert e.value.row == c.lines[7]
