"""A joint that stood still in every row of the campaign (issue 40: a sweep held out, the
others fitted without it): fit says so, and evaluate names it among the axes commanded
beyond what the fit measured."""
import json
import warnings

import numpy as np
import pytest

import vecpin
from vecpin.errors import VecpinWarning
from vecpin.simulation.simulate import Design, simulate
from vecpin.selection.design import partly_measured
from vecpin.simulation.truth import uniform_commands
from vecpin.workflows.evaluation import evaluate


def test_fit_and_evaluate_name_the_axis_that_never_moved(flow, tmp_path):
    rng = np.random.default_rng(4)
    q = uniform_commands(flow, 60, rng)
    z = flow.axis("Z")
    # Z stands still in the campaign (its readings within 0.3 um: an encoder's jitter, not a move)
    q[:, z.index] = 0.4 * z.lower + 0.6 * z.upper + rng.uniform(-0.3e-6, 0.3e-6, len(q)) * z.travel
    sim = simulate(flow, seed=4, plan=(np.repeat(q, 2, axis=0), np.tile([0.21488, 0.31286], 60)),
                   design=Design(n_validation=20))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        run = vecpin.fit(flow, sim.campaign, vecpin.NoiseModel.default(flow), kind="6dof", basis="chebyshev", order=2)
    said = [str(w.message) for w in seen if issubclass(w.category, VecpinWarning)]
    assert any("did not move in any row (Z at" in s and "holds its errors" in s for s in said), said
    printed = "\n".join(said + run.lines())   # said once; no ends of a span it does not have held out
    assert printed.count("did not move") == 1 and "measured over less than" not in printed, printed
    x = flow.axis("X")   # an axis measured over part of its travel keeps its ends held out
    half = sim.campaign.subset(np.flatnonzero(sim.campaign.q[:, x.index] < 0.5 * (x.lower + x.upper)))
    assert z.index not in partly_measured(flow, sim.campaign) and x.index in partly_measured(flow, half)
    assert z.index not in partly_measured(flow, half)
    moving = simulate(flow, seed=5, truth=sim.truth, design=Design(n_commands=20, n_validation=5)).campaign
    ev = evaluate(run.model, moving)                               # the same tracker, Z over its travel
    assert any("Z" in w and "did not move in the fit's campaign" in w for w in ev.warnings), ev.warnings
    out = ev.to_dict()
    assert out["still_axes"]["Z"]["unit"] == "mm" and out["rows_outside_measured_range"] == int(ev.outside.sum()) > 0
    assert any("did not move in the fit's campaign: Z at" in line for line in ev.lines())
    # no series along Z beyond where it stood: whatever the fit gives Z's series (here 0.1 mm and 0.1 mrad per
    # order, what a fit of readings that barely move could give), the errors of Z are held where Z stood, so along
    # Z (a linear axis, the rotaries after it standing) the tip error is the nominal chain's lever on constant
    # errors: a straight line in Z, a second difference of ~0 (the 0.6 um Z moved in the campaign leaves < 1 nm);
    # the series would bend it (shown with the hold taken off)
    series = [i for i, n in enumerate(run.model.parameter_names) if n.startswith("Z.") and not n.endswith(".0")]
    run.model.b_[series] = 1e-4
    run.model.save(tmp_path / "m.json")
    back = vecpin.ErrorModel.load(tmp_path / "m.json")
    assert json.loads((tmp_path / "m.json").read_text())["still_axes"]["Z"]["position"] == pytest.approx(
        z.to_user(q[:, z.index].min()))
    along = np.repeat(q[:3], 5, axis=0)
    along[:, z.index] = np.tile(np.linspace(z.lower, z.upper, 5), 3)

    def bend(model):
        return np.abs(np.diff(model.predict(along, 0.21488).reshape(3, 5, 3), 2, axis=1)).max()
    assert bend(run.model) < 1e-9 and bend(back) < 1e-9
    back.range_ = None
    assert bend(back) > 1e-5


def test_terms_collinear_only_because_a_joint_stood_still_are_held_by_their_priors(monkeypatch):
    """A one-joint-at-a-time design with joint 3's sweep left out: joint 3 stands still, so
    constant errors on either side of it are collinear in this campaign though any design
    moving it tells them apart. They are kept and held by their priors (the posterior mean,
    as the model choice's folds fit them): only what no design could identify is removed,
    where the campaign's own redundancy removal drops the later of each collinear pair."""
    import vecpin.identification.fit as fitmod
    ur10 = vecpin.Machine.load("ur10")
    mid = np.array([0.3, -1.2, 1.4, -1.5, -1.4, 0.2])
    q = np.array([mid + np.eye(6)[k] * v for k in (0, 1, 2, 4, 5) for v in np.linspace(-1.5, 1.5, 8)])
    c = simulate(ur10, seed=2, plan=(q, np.full(len(q), 0.1)), design=Design(n_validation=5)).campaign
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        now = vecpin.fit(ur10, c, None, kind="6dof", order=0).model
        monkeypatch.setattr(fitmod, "STILL_BY_PRIORS", False)
        before = vecpin.fit(ur10, c, None, kind="6dof", order=0).model
    struct, _ = fitmod.structural_redundancy(now, c.tool_lengths(), now.noise_)
    names = ["E0"] * 6 + list(now.parameter_names)
    assert set(now.report_.removed) == {n for n, r in zip(names, struct) if r and n != "E0"}
    extra = set(before.report_.removed) - set(now.report_.removed)
    assert extra and set(now.report_.removed) < set(before.report_.removed)
    held = [now.parameter_names.index(n) for n in extra]
    assert np.all(np.abs(now.b_[held]) > 0)          # fitted under their priors, not fixed at zero


def test_a_gauge_line_held_by_its_prior_is_said():
    """T_offset whose standard deviation is most of its prior's (one tool length): the
    printout says the campaign barely determines it, not only a number."""
    from types import SimpleNamespace

    from vecpin.workflows.fitting import offset_lines
    report = SimpleNamespace(removed=[], weak=[])
    model = SimpleNamespace(report_=report, cov_=np.diag([1.0] * 6 + [4.47e-3**2, 1e-10]), b_=np.array([1.8e-5, 0.0]),
                            parameter_names=["T_offset", "X.dx.1"], priors=np.array([5e-3, 1e-3]))
    line, = offset_lines(model)
    assert line.startswith("  gauge line T_offset: +0.0180 ± 4.4700 mm") and "held by its prior" in line
    model.cov_ = np.diag([1.0] * 6 + [0.02e-3**2, 1e-10])
    assert "held by its prior" not in offset_lines(model)[0]


def test_a_model_with_thermal_terms_fits_a_campaign_where_an_axis_stood_still():
    """An axis that stood still and terms that follow the rows' temperatures: the reference design that holds
    the still axis' terms by their priors has no rows' history, so the campaign's own redundancy judges them
    (it raised before); the lag the fit finds is the truth's (thermal_truth, 1 h)."""
    from thermal_truth import Truth, commands
    from vecpin.compensation.thermal import fit_thermal
    from vecpin.measurement.campaign import Campaign
    from vecpin.models import make_model
    m = vecpin.Machine.load("trunnion_xyzac")
    rng = np.random.default_rng(3)
    n, zi = 60, m.axis_names.index("Z")
    q, t = commands(m, n, rng), np.linspace(0, 10 * 3600, n)
    q[:, zi] = q[0, zi]                                                    # Z never moves
    air, tool = 21 + 3 * np.sin(2 * np.pi * t / (7 * 3600)), np.full(n, 0.12)
    truth = Truth(lag_s=3600.0)
    xyz = truth.tip(m, q, tool, truth.structure(t, air)) + rng.normal(0, 1e-6, (n, 3))
    camp = Campaign(m.axis_names, q, tool, xyz, extra={"time": t, "temperature": air})
    geo = make_model("6dof", m, 2).fit(camp, vecpin.NoiseModel.default(m, "spherical"))
    terms, fitted = fit_thermal(geo, camp, lags=(0.5, 1.0, 2.0))
    assert abs(terms.lag_h - 1.0) < 0.15 and np.isfinite(fitted.report_.chi2)
