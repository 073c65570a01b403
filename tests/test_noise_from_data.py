"""The noise level from the data (issue 25): when the user states no noise, a fit whose
chi2 leaves its band is chosen and fitted again with every noise sigma scaled by what the
residuals say; a campaign whose noise is as stated keeps it."""
import pytest

from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.tracker import TrackerNoise
from vecpin.simulation.simulate import Design, simulate
from vecpin.workflows.fitting import fit_campaign


def _sim(machines, k: float):
    """flow_xyzcb measured with k times the default repeatability and tracker noise."""
    m = machines["flow_xyzcb"]
    t = TrackerNoise()
    noisy = TrackerNoise(t.range_const * k, t.range_ppm * k, t.transverse_const * k, t.transverse_ppm * k)
    return m, simulate(m, seed=8, design=Design(n_commands=150, n_validation=5), repeatability_mm=0.006 * k,
                       repeatability_deg=0.0015 * k, tracker_noise=noisy)


def test_noise_as_stated_is_kept(machines):
    m, sim = _sim(machines, 1.0)
    run = fit_campaign(m, sim.campaign, NoiseModel.default(m), noise_from_data=True)
    assert not run.noise_rescaled and run.noise_used == 1.0
    assert run.noise_scale == pytest.approx(1.0, abs=3 * run.noise_scale_sd)
    assert "the stated noise kept" in run.noise_line()


@pytest.mark.slow
def test_noise_four_times_the_stated_is_found_and_used(machines):
    m, sim = _sim(machines, 4.0)
    stated = fit_campaign(m, sim.campaign, NoiseModel.default(m))
    assert not stated.model.report_.chi2_in_band and stated.noise_scale is None
    run = fit_campaign(m, sim.campaign, NoiseModel.default(m), noise_from_data=True)
    assert run.noise_rescaled and run.model.report_.chi2_in_band
    assert run.noise_scale == pytest.approx(4.0, rel=0.1)
    assert run.noise_scale_sd < 0.1 * run.noise_scale
    assert run.model.noise_.axis_sigma[0] == pytest.approx(run.noise_used * NoiseModel.default(m).axis_sigma[0])
    assert "scaled by" in run.noise_line()
