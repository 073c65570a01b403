"""One residual per row through the likelihood (review 7): residuals of mixed campaigns
carry tracker-frame effects, a knocked tracker moves its own station's rows only (in the
fit, in residuals and in the diagnosis' columns alike), rows that are not numbers are
never judged explained."""
import copy

import numpy as np
import pytest

from vecpin.diagnosis.grosserrors import beyond, robust_level
from vecpin.diagnosis.scoring import Kinematics, effect_columns
from vecpin.identification.linearised import Linearised
from vecpin.measurement.features import Features
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.models.effects.instrument_shift import InstrumentShift
from vecpin.simulation.simulate import Design, simulate


def _with_shift(base, shift, values):
    em = base.with_effects([shift])
    em.e0_, em.setup_, em.noise_, em.report_ = base.e0_, copy.deepcopy(base.setup_), base.noise_, base.report_
    em.b_ = np.r_[base.b_, values]
    return em


@pytest.mark.parametrize("machine, design, station", [
    ("flow_xyzcb", Design(n_commands=40, n_validation=10, stations=2), 1),
    ("trunnion_xyzac", Design(n_commands=40, n_validation=10, nests=3), 0)])
def test_a_tracker_step_moves_its_stations_rows_by_exactly_its_size(machines, machine, design, station):
    """Closed form: a pure translation delta of station s's tracker from t0 on changes
    the residuals (measured minus modelled, station frame) of exactly those rows by
    -delta, on a campaign of two stations and on one of tool tips and nests (mixed)."""
    m = machines[machine]
    c = simulate(m, seed=5, design=design).campaign
    assert c.mixed
    base = make_model("6dof", m, 3).fit(c, NoiseModel.default(m, "spherical"))
    t0 = float(np.median(c.time))
    delta = np.array([3e-5, -2e-5, 1e-5])
    em = _with_shift(base, InstrumentShift(m, t0=t0, station=station), np.r_[delta, 0.0, 0.0, 0.0])
    d = em.residuals(c) - base.residuals(c)
    on = (c.time >= t0) & (c.station == station) & (c.instrument != "ballbar")
    assert on.sum() > 10 and (~on).sum() > 10
    assert np.allclose(d[on], -delta, atol=1e-12) and np.allclose(d[~on], 0.0, atol=1e-12)


def test_instrument_shift_columns_equal_finite_differences_per_station(machines):
    """The diagnosis' columns of a station-1 tracker step are the finite differences of
    the model with that step (the model then fitted): station 0's rows do not move."""
    m = machines["flow_xyzcb"]
    c = simulate(m, seed=7, design=Design(n_commands=40, n_validation=10, stations=2)).campaign
    noise = NoiseModel.default(m, "spherical")
    base = make_model("6dof", m, 3).fit(c, noise)
    f = Features.from_campaign(c)
    lin = Linearised(base, c, noise, f)
    kin = Kinematics(base, lin, f)
    cands = InstrumentShift.candidates(m, f)
    assert {e.station for e in cands} == {0, 1}
    eff = [e for e in cands if e.station == 1][len(cands) // 4]
    A, _ = effect_columns(kin, lin, eff, f)
    prior = np.array([p.prior for p in eff.parameters()])
    fd = np.zeros_like(A)
    for j, s in enumerate(prior):
        r = [_with_shift(base, eff, v * 1e-3 * s * np.eye(6)[j]).row_residuals(c, f).metric for v in (1, -1)]
        fd[..., j] = -(r[0] - r[1]) / 2e-3
    assert np.abs(A - fd).max() <= 1e-6 * np.abs(fd).max()
    assert np.abs(A[c.station == 0]).max() == 0 and np.abs(A[c.station == 1]).max() > 0


def test_rows_without_a_number_are_never_explained():
    w = np.array([[0.5, 0.1, -0.2], [np.nan, 0.0, 0.0], [4.0, 0.0, 0.0], [0.3, 0.0, 0.0]])
    valid = np.array([[1, 1, 1], [1, 0, 0], [1, 0, 0], [1, 0, 0]], bool)
    s = robust_level(np.sum(w[[0, 2, 3]] ** 2, axis=1), valid[[0, 2, 3]])
    out = beyond(np.sum(w**2, axis=1), valid, 1.0, 4, alpha=1e-3)
    # limits chi2.isf(1 - 0.999^(1/4) ~ 2.5e-4): 19.19 with 3 equations, 13.41 with 1; 4^2 = 16 is beyond, NaN always
    assert out.tolist() == [False, True, True, False]
    assert np.isfinite(s) and s > 0


def test_a_fit_keeps_its_own_residuals_to_the_last_digit(machines):
    """The residuals a fit leaves (the fit's own last pass) are those the likelihood computes
    again from the fitted model, to the last digit; parameters changed afterwards are not
    served from the fit's points."""
    m = machines["flow_xyzcb"]
    c = simulate(m, seed=6, design=Design(n_commands=40, n_validation=5)).campaign
    em = make_model("ap", m, 1).fit(c, NoiseModel.default(m, "spherical"))
    assert em._fitted_points is not None
    np.testing.assert_array_equal(em.residuals(c), c.xyz - em.row_residuals(c).y)
    em.b_ = em.b_ + 1e-6
    np.testing.assert_array_equal(em.residuals(c), c.xyz - em.row_residuals(c).y)
    assert not np.array_equal(em.residuals(c), c.xyz - em._fitted_points[3])
