"""The estimator whose fit makes the model choice (``vecpin.ErrorModelCV``) and its
predicted tool-tip error with a standard deviation.

Independent checks of the standard deviation: the empirical scatter of refits on noise
re-drawn over the same simulated true machine and commands (the simulator's noise, not
the fit's covariance), and a Monte-Carlo draw of the parameters from that covariance
through the nonlinear model (not the linearised propagation ``predict`` uses). The
estimator's fit is the command line's: the same campaign gives the same model file, byte
for byte."""
import re

import numpy as np
import pytest

import vecpin
from vecpin.cli import main
from vecpin.cli.main import build_parser
from vecpin.cli.options import as_flags
from vecpin.errors import InputError, VecpinError
from vecpin.simulation.simulate import Design, simulate
from vecpin.fitting.estimator import ErrorModelCV
from vecpin.workflows.fitting import FitRun, fit_campaign

FIXED = {"kind": "6dof", "basis": "chebyshev", "order": 2}


@pytest.fixture(scope="module")
def sim(flow):
    return simulate(flow, seed=1, design=Design(n_commands=60, n_validation=20))


@pytest.fixture(scope="module")
def fixed(flow, sim):
    return ErrorModelCV(flow, **FIXED).fit(sim.campaign)


def test_the_facade_exposes_the_estimator_and_one_fitting_path():
    assert vecpin.ErrorModelCV is ErrorModelCV
    assert vecpin.fit is fit_campaign


def test_fit_returns_self_with_the_fitted_model_and_no_choice_when_all_is_fixed(fixed, flow):
    assert isinstance(fixed.model_, vecpin.ErrorModel)
    assert fixed.choice_ is None and fixed.result_.model is fixed.model_
    assert fixed.model_.spec == vecpin.make_model("6dof", flow, 2, basis="chebyshev").spec
    err = fixed.predict(np.zeros((1, flow.n_axes)), 0.2)
    assert err.shape == (1, 3) and np.all(np.isfinite(err))


def test_predicted_error_is_the_modelled_minus_the_nominal_tip(fixed, flow, sim):
    q, tool = sim.validation.q, 0.25
    model = fixed.model_
    for frame, f in (("workpiece", "workpiece"), ("machine", "base")):
        expected = model.tool_tip(q, tool, model.b_, jacobian=False, frame=f).tip - flow.tool_tip(q, tool, frame=f)
        np.testing.assert_allclose(fixed.predict(q, tool, frame=frame), expected, atol=1e-15)


def test_std_matches_a_monte_carlo_draw_of_the_parameters(fixed, flow, sim):
    """4000 parameter vectors drawn from the fit's covariance, each through the nonlinear
    model: their errors' scatter is the predicted standard deviation within 5 %
    (the draw's own relative error is about 1 %)."""
    model = fixed.model_
    q, tool = sim.validation.q[:10], 0.2
    err, std = fixed.predict(q, tool, return_std=True)
    C = model.cov_[6:, 6:]
    w, V = np.linalg.eigh(C)
    draws = model.b_ + (np.random.default_rng(3).standard_normal((4000, len(w))) * np.sqrt(np.clip(w, 0, None))) @ V.T
    nominal = flow.tool_tip(q, tool, frame="workpiece")
    mc = np.array([model.tool_tip(q, tool, b, jacobian=False, frame="workpiece").tip - nominal for b in draws])
    np.testing.assert_allclose(mc.std(axis=0, ddof=1), std, rtol=0.05)
    np.testing.assert_allclose(mc.mean(axis=0), err, atol=0.1 * std.min())


def test_a_model_file_keeps_the_std(fixed, sim, tmp_path):
    """The file's standard deviations and correlations (6 decimals) give back the same
    predicted standard deviation to 0.1 %."""
    fixed.save(tmp_path / "m.json")
    back = vecpin.ErrorModel.load(tmp_path / "m.json")
    q = sim.validation.q
    e0, s0 = fixed.predict(q, 0.2, return_std=True)
    e1, s1 = back.predict(q, 0.2, return_std=True)
    np.testing.assert_allclose(e1, e0, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(s1, s0, rtol=1e-3)


@pytest.mark.slow
def test_std_matches_the_scatter_of_refits_on_redrawn_noise(flow, sim):
    """40 campaigns of the same true machine and commands, the noise drawn again: the
    predicted errors' scatter over the refits against the standard deviation the fits
    predict. With 39 degrees of freedom a sample standard deviation is within about
    +-11 % (1 sigma) of the true one; the median ratio over 60 coordinates within 15 %,
    nine in ten within 35 %."""
    c, q = sim.campaign, sim.validation.q
    errs, stds = [], []
    for seed in range(2, 42):
        again = simulate(flow, seed=seed, truth=sim.truth, plan=(c.q, c.tool), design=Design(n_validation=5)).campaign
        assert np.array_equal(again.q, c.q) and not np.array_equal(again.xyz, c.xyz)
        e, s = ErrorModelCV(flow, noise_from_data=False, **FIXED).fit(again).predict(q, 0.2, return_std=True)
        errs.append(e)
        stds.append(s)
    ratio = np.array(errs).std(axis=0, ddof=1) / np.array(stds).mean(axis=0)
    assert 0.85 < np.median(ratio) < 1.15
    assert np.mean((ratio > 0.65) & (ratio < 1.35)) >= 0.9


@pytest.mark.parametrize("flags,options", [
    pytest.param(["--model", "6dof", "--basis", "chebyshev", "--order", "2", "--repeatability-mm", "0.006"],
                 dict(FIXED, noise_from_data=False), id="fixed"),
    pytest.param([], {"noise_from_data": True}, id="chosen", marks=pytest.mark.slow)])
def test_the_estimator_is_the_command_lines_fit(flow, sim, tmp_path, capsys, flags, options):
    """``vecpin fit`` and the estimator on the same file write the same model file byte for
    byte and print the same lines; with the default options the choice is made inside
    ``fit`` (``choice_``, recorded in the model)."""
    csv = sim.write(tmp_path / "sim")["campaign"]
    assert main(["fit", "flow_xyzcb", str(csv), "--out", str(tmp_path / "cli.json"), "--quiet", *flags]) == 0
    printed = capsys.readouterr().out
    est = ErrorModelCV(flow, vecpin.NoiseModel.default(flow), **options).fit(vecpin.read_campaign(csv, flow))
    est.save(tmp_path / "est.json")
    assert (tmp_path / "cli.json").read_bytes() == (tmp_path / "est.json").read_bytes()
    flags = build_parser().parse_args(["fit", "flow_xyzcb", str(csv), "--out", "x.json"]).flags
    untimed = lambda text: re.sub(r"in [0-9.]+ s\b", "", text)  # noqa: E731 (the fit's seconds differ)
    assert untimed(as_flags("\n".join(FitRun.of(est.result_).lines()), flags)) in untimed(printed)
    if not flags:
        assert est.choice_ is not None and est.model_.selection_ == est.choice_.to_dict()
        assert est.model_.spec == est.choice_.chosen.model(flow).spec


def test_unfitted_and_bad_frame_are_refused(flow, fixed):
    with pytest.raises(VecpinError, match="not fitted"):
        ErrorModelCV(flow).predict(np.zeros((1, flow.n_axes)))
    with pytest.raises(InputError, match="`frame` 'tracker'"):
        fixed.predict(np.zeros((1, flow.n_axes)), frame="tracker")


def test_the_facade_takes_names_and_paths_and_refuses_the_rest(tmp_path):
    """Issue 42: `vecpin.fit("flow_xyzcb", "c.csv", ...)` raised AttributeError deep inside. The
    facade takes a machine's name or URDF path and a campaign's path as the CLI does, an
    instrument's name for the noise, and refuses anything else naming the argument."""
    import vecpin
    from vecpin.errors import InputError
    from vecpin.measurement.campaign import write_campaign
    m = vecpin.Machine.load("flow_xyzcb")
    sim = vecpin.simulate(m, seed=3, design=__import__("vecpin.simulation.simulate", fromlist=["Design"]).Design(
        n_commands=60, n_validation=5))
    write_campaign(tmp_path / "c.csv", sim.campaign, m)
    by_name = vecpin.fit("flow_xyzcb", tmp_path / "c.csv", "spherical", kind="6dof", basis="chebyshev", order=1)
    by_object = vecpin.fit(m, vecpin.read_campaign(tmp_path / "c.csv", m), vecpin.NoiseModel.default(m, "spherical"),
                           kind="6dof", basis="chebyshev", order=1, noise_from_data=True)   # a name states no level
    np.testing.assert_allclose(by_name.model.b_, by_object.model.b_, atol=1e-9)
    for args, name in (((m, 3.5), "`campaign` float"), ((None, sim.campaign), "`machine` NoneType"),
                       ((m, sim.campaign, 3), "`noise` int")):
        with pytest.raises(InputError, match=name):
            vecpin.fit(*args)


def test_the_facade_and_the_command_line_default_alike(sim, tmp_path, capsys):
    """No noise given: ``vecpin.fit`` takes the noise level from the data as ``vecpin fit``
    without noise options does, so one campaign gives one model file either way (a stated
    NoiseModel keeps its level)."""
    csv = sim.write(tmp_path / "sim")["campaign"]
    assert main(["fit", "flow_xyzcb", str(csv), "--out", str(tmp_path / "cli.json"), "--quiet", "--model", "6dof",
                 "--basis", "chebyshev", "--order", "2"]) == 0
    capsys.readouterr()
    run = vecpin.fit("flow_xyzcb", csv, **FIXED)
    run.model.save(tmp_path / "api.json")
    assert (tmp_path / "cli.json").read_bytes() == (tmp_path / "api.json").read_bytes()
    assert "noise from the data" in "\n".join(run.lines())
    stated = vecpin.fit("flow_xyzcb", csv, vecpin.NoiseModel.default(vecpin.Machine.load("flow_xyzcb")), **FIXED)
    assert stated.noise_scale is None


def test_the_estimator_contract_params_score_and_best_score(fixed, flow, sim):
    """get_params/set_params round-trip the settings; score is minus the mean distance [mm] of
    a run's readings from the model, computed here from the model's own tips; best_score_
    is None when nothing was chosen."""
    params = fixed.get_params()
    assert params["kind"] == "6dof" and params["order"] == 2
    est = ErrorModelCV(flow).set_params(**params)
    assert est.get_params() == params
    with pytest.raises(VecpinError, match="no setting colour"):
        est.set_params(colour="red")
    v = sim.validation
    d = np.linalg.norm(v.xyz - fixed.model_.predict_tip(v.q, v.tool), axis=1) * 1000.0
    assert fixed.score(v) == pytest.approx(-d.mean(), rel=1e-9)
    assert fixed.best_score_ is None
