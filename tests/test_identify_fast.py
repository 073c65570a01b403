"""The fit's most direct truth test, one cheap case for the fast tier: on a simulated machine
with known errors, the fit of the true error family reaches the noise-limited floor, and chi2
lands in its band only when the stated noise is the noise the data carry (the full matrix of
kinds and orders is in test_identify.py, slow tier)."""
import numpy as np
import pytest

from vecpin.measurement.noise import NoiseModel, scaled_noise
from vecpin.models import make_model
from vecpin.simulation.simulate import simulate
from vecpin.simulation.truth import uniform_commands

TOOLS = np.array([0.21488, 0.31286])  # m


@pytest.fixture(scope="module")
def sim(flow):
    return simulate(flow, seed=12, mean_error_mm=0.65, family="6dof")


def test_true_family_fit_is_noise_limited_and_chi2_tells_the_noise(flow, sim):
    rng = np.random.default_rng(99)
    q = uniform_commands(flow, 300, rng)
    tool = TOOLS[rng.integers(0, 2, len(q))]
    exact = sim.truth.measure(q, tool, None)                 # noise-free tips, tracker frame [m]
    noise = NoiseModel.default(flow, "spherical")
    model = make_model("6dof", flow, 4, bases=sim.truth.family_bases()).fit(sim.campaign, noise)
    got = np.linalg.norm(model.predict_tip(q, tool) - exact, axis=1).mean()
    uncompensated = np.linalg.norm(sim.truth.tool_tip(q, tool) - flow.tool_tip(q, tool), axis=1).mean()
    assert got < 0.012e-3                                    # about 8 µm from 18 µm-class readings
    assert got < 0.03 * uncompensated
    assert model.report_.chi2_in_band
    pessimistic = make_model("6dof", flow, 4, bases=sim.truth.family_bases()).fit(sim.campaign,
                                                                                  scaled_noise(noise, 3.0))
    assert pessimistic.report_.chi2 < pessimistic.report_.chi2_band[0]   # noise stated 3x too large
