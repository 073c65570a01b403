"""The thermal lag and its uncertainty (vecpin.compensation.thermal.refine_lag), judged
against closed forms: fits whose chi-square is an exact parabola in the lag, with the
noise the residuals show (chi-square per degree of freedom) and coefficients straight in
the lag. The lag is where the fit with the curvature free is best (not where the straight
fit is: the curvature a wide temperature cycle shows moves that one), its standard
deviation is where the chi-square has risen by the noise (Δχ² = 1 times χ²/dof), and the
coefficients' change per hour of lag is their slope; a minimum near the far end of the
scanned lags, beyond a coarse neighbour, is still found (not the scanned lag next to it)."""
from types import SimpleNamespace

import numpy as np
import pytest

from vecpin.compensation.thermal import refine_lag

DOF = 400.0
SCALE = 0.2                                  # chi-square per degree of freedom at the minimum
SLOPE = np.array([3.0, -1.5, 0.25])          # coefficients' change per hour of lag [um/K/h ...]


def report(lag: float, at: float, sd: float) -> SimpleNamespace:
    """A fit's report whose chi-square is SCALE (DOF + ((lag - at) / sd)^2): Δχ² = SCALE at one sd."""
    return SimpleNamespace(chi2=SCALE * (DOF + ((lag - at) / sd) ** 2), chi2_expected=DOF)


class Fit:
    """A fitted model with one effect: the coefficients straight in the lag, the chi-square a parabola."""

    def __init__(self, lag: float, at: float, sd: float):
        self.effect = object()
        self.b_ = np.r_[np.zeros(6), 1.0 + SLOPE * lag] * 1e-6
        self.report_ = report(lag, at, sd)

    def effect_slices(self):
        return [(self.effect, slice(6, 9))]


def fitter(at: float, sd: float):
    """lag -> (effect, fit): fits whose chi-square is least at ``at`` [h], one standard deviation ``sd`` [h]."""
    def fit_at(lag: float):
        f = Fit(lag, at, sd)
        return f.effect, f
    return fit_at


class Problem:
    """The fit with the curvature free as a function of the lag (as LagProblem.solve answers): the parabola's."""

    def __init__(self, at: float, sd: float):
        self.fit_at = fitter(at, sd)

    def solve(self, lag: float):
        f = self.fit_at(lag)[1]
        return f.report_.chi2, f.report_.chi2_expected, f.b_[6:9]


@pytest.mark.parametrize("straight, bent, sd", [(2.0, 1.86, 0.03), (0.9, 0.95, 0.01), (3.1, 3.3, 0.2)])
def test_the_lag_its_deviation_and_the_coefficients_change_are_the_bent_fits(straight, bent, sd):
    fit_at = fitter(straight, 5 * sd)                    # the straight fit: a biased, narrower-looking minimum
    fits = {lag: fit_at(lag) for lag in (0.0, 0.5, 1.0, 2.0, 4.0)}
    lag, std, gradient = refine_lag(fits, fit_at, Problem(bent, sd))
    assert lag == pytest.approx(bent, abs=0.011)         # kept to 0.01 h
    assert std == pytest.approx(sd, rel=1e-3)            # Δχ² = χ²/dof at one standard deviation
    assert gradient == pytest.approx(SLOPE, rel=1e-6)
    assert lag in fits                                   # the terms written are the straight fit's at that lag


def test_at_an_end_of_the_scan_the_lag_is_not_refined():
    fit_at = fitter(6.0, 0.5)
    fits = {lag: fit_at(lag) for lag in (0.0, 0.5, 1.0, 2.0, 4.0)}
    lag, std, gradient = refine_lag(fits, fit_at, Problem(6.0, 0.5))
    assert lag == pytest.approx(4.0, abs=0.011) and std == 0.0 and gradient is None



def test_a_lag_not_refined_is_said_so_not_given_as_certain():
    """The lag kept at an end of the scan has no standard deviation (0): the prediction's words say its
    uncertainty is not counted, not "± 0.00 h"; a refined lag's deviation is printed."""
    from vecpin.compensation.thermal import ThermalTerms
    from vecpin.workflows.thermal import how_predicted
    t = ThermalTerms("m", ["X"], 20.0, 4.0, {"X": 0.0}, {"X": 1.0}, {"X": 0.0}, None, t_range_c=(19.0, 21.0))
    t.held_out = {"names": ["X.offset_per_K", "X.slope_per_K"], "cov": [[1.0, 0.0], [0.0, 1.0]], "floor_um": 2.0,
                  "blocks": 5, "lag_std_h": 0.0}
    said = how_predicted(t)
    assert "± 0.00 h" not in said and "not the lag's uncertainty" in said
    t.held_out["lag_std_h"] = 0.12
    assert "the lag's uncertainty ± 0.12 h" in how_predicted(t)

def test_the_blocks_spread_leaves_the_curvature_to_its_own_draws():
    """A machine whose thermal error is exactly straight terms bent by one curvature per axis
    (2 %/K, lag 1 h, no noise; the growth bent with Z, whose offset carries it): refitted
    without each time block, the straight terms alone move by the curvature's projection
    on the blocks left (a spread the curvature's draws count again), the terms beside their
    curvature held at the campaign's estimate stay put (a fifth of that at most)."""
    from thermal_truth import Truth, hall_day

    import vecpin
    from vecpin.compensation.thermal import fit_thermal
    from vecpin.compensation.thermalheld import held_out
    from vecpin.measurement.campaign import Campaign
    from vecpin.measurement.features import Features
    from vecpin.measurement.noise import NoiseModel
    from vecpin.models import make_model
    m = vecpin.Machine.load("trunnion_xyzac")
    rng = np.random.default_rng(4)
    truth = Truth(lag_s=3600.0, nonlinear={"X": 0.02, "Y": 0.02, "Z": 0.02}, growth_nonlinear=0.02)
    q, tool, tip, t, air = hall_day(m, truth, rng, 3)
    camp = Campaign(m.axis_names, q, tool, tip, extra={"time": t, "temperature": air})
    geo = make_model("6dof", m, 2).fit(camp, NoiseModel.default(m, "spherical"))
    terms, fitted = fit_thermal(geo, camp, lags=(1.0,))
    eff = next(e for e in fitted.effects if e.name == "thermal_terms")
    straight = np.sqrt(np.diag(held_out(fitted, camp, Features.from_campaign(camp), eff)["cov"]))
    kept = np.sqrt(np.diag(terms.held_out["cov"]))
    assert straight.max() > 0.05                                  # um/K, um/m/K: the projection moves them
    assert np.all(kept < 0.2 * straight + 1e-3)


def test_the_lag_problem_is_the_bent_fit_at_that_lag():
    """The lag's refinement solves the fit with the curvature free at each lag from one
    linearisation of the straight fit at a scanned lag (the geometry factorised once):
    at another lag its objective and thermal coefficients are those of the full fit
    there (vecpin's own Gauss-Newton fit of geometry, terms and curvature), to a small
    fraction of the coefficients' standard deviations."""
    from thermal_truth import Truth, hall_day

    import vecpin
    from vecpin.compensation.thermaleffect import ThermalTermsEffect
    from vecpin.compensation.thermalheld import LagProblem, bent_fit
    from vecpin.measurement.campaign import Campaign
    from vecpin.measurement.features import Features
    from vecpin.measurement.noise import NoiseModel
    from vecpin.models import make_model
    from vecpin.models.effects.thermal import lagged
    m = vecpin.Machine.load("trunnion_xyzac")
    rng = np.random.default_rng(7)
    truth = Truth(lag_s=1.3 * 3600.0, nonlinear={"X": 0.01, "Y": -0.005, "Z": 0.015}, growth_nonlinear=0.01)
    q, tool, tip, t, air = hall_day(m, truth, rng, 6)
    n = len(q)
    xyz = tip + rng.normal(0, 3e-6, (n, 3))
    camp = Campaign(m.axis_names, q, tool, xyz, extra={"time": t, "temperature": air})
    feats = Features.from_campaign(camp)
    noise = NoiseModel.default(m, "spherical")
    geo = make_model("6dof", m, 2).fit(camp, noise)
    p0 = {a: 0.5 * (m.axis(a).lower + m.axis(a).upper) for a in "XYZ"}

    def effect(lag):
        return ThermalTermsEffect(m, ("X", "Y", "Z"), float(np.mean(lagged(t, air, lag))), lag, p0, growth=False)

    eff = effect(1.0)
    straight = geo.with_effects(list(geo.effects) + [eff]).fit(camp, noise)
    values = straight.b_[next(s for e, s in straight.effect_slices() if e is eff)]
    obj, _, coef = LagProblem(straight, camp, feats, eff, effect, values).solve(1.5)
    other = effect(1.5)
    full, _ = bent_fit(geo, camp, noise, other, values, feats)
    sl = next(s for e, s in full.effect_slices() if e is other)
    assert obj == pytest.approx(full.report_.chi2, rel=1e-3)
    assert np.all(np.abs(coef - full.b_[sl]) < 0.02 * full.std_[sl])
