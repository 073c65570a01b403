"""The smooth-prior fit (vecpin.fitting.smoothprior, vecpin.models.prior): its evidence against the
Gaussian density written out, its maximum against a grid, its fit against the ridge solution of the
linearised problem, and its model file read back."""
import math

import numpy as np
import pytest
from scipy import linalg

from vecpin.fitting.smoothprior import EvidenceProblem, maximise, smooth_bases
from vecpin.identification.likelihood import Likelihood
from vecpin.measurement.noise import NoiseModel
from vecpin.models import ErrorModel, make_model
from vecpin.models.prior import SmoothPrior, frequencies, roughness
from vecpin.simulation.simulate import Design, simulate


def small_problem(kernel: str, seed: int = 3) -> tuple[EvidenceProblem, np.ndarray, np.ndarray, np.ndarray]:
    """A linear problem y = J psi + e: two unknowns of their own prior (1), two groups of four
    columns of one axis (roughness 0, 1, 5, 16; frequencies 0, 0.5, 1, 2)."""
    rng = np.random.default_rng(seed)
    J = rng.normal(size=(40, 10))
    y = J @ np.r_[rng.normal(size=2), 0.3 * rng.normal(size=8)] + rng.normal(size=40)
    e, w = np.tile([0.0, 1.0, 5.0, 16.0], 2), np.tile([0.0, 0.5, 1.0, 2.0], 2)
    sigma = np.r_[1.0, 1.0, np.full(8, 1e-3)]     # the default priors psi is scaled by (a model's 1 mm)
    prob = EvidenceProblem(J.T @ J, J.T @ y, float(y @ y), 40, sigma, np.r_[-1, -1, [0] * 4, [1] * 4],
                           np.r_[-1, -1, [0] * 8], np.r_[0, 0, e], np.r_[0, 0, w], kernel)
    return prob, J, y, e


@pytest.mark.parametrize("kernel", ["roughness", "squared-exponential"])
def test_the_evidence_is_the_gaussian_density_of_the_readings(kernel):
    """-evaluate = log N(y; 0, v I + J S J') + n/2 log 2 pi, S the prior's covariance, v the noise;
    its gradient is the difference quotient's."""
    prob, J, y, _ = small_problem(kernel)
    x = np.array([math.log(7e-4), math.log(2e-4), math.log(0.8), math.log(1.3)])
    value, grad = prob.evaluate(x, 2, 1, True)
    amp, lam, beta = prob.unpack(x, 2, 1, True)
    S = np.diag(np.exp(-prob.log_alpha(amp, lam)))            # the prior's covariance of psi
    C = J @ S @ J.T + np.eye(40) / beta
    direct = -0.5 * y @ linalg.solve(C, y) - 0.5 * np.linalg.slogdet(C)[1] - 20 * math.log(2 * math.pi)
    assert -value - 20 * math.log(2 * math.pi) == pytest.approx(direct, rel=1e-10)
    step = 1e-6
    numeric = [(prob.evaluate(x + step * np.eye(4)[k], 2, 1, True)[0]
                - prob.evaluate(x - step * np.eye(4)[k], 2, 1, True)[0]) / (2 * step) for k in range(4)]
    assert grad == pytest.approx(numeric, rel=1e-5, abs=1e-6)


def test_the_evidence_maximum_is_the_grids():
    """One amplitude free (the other and the scale held by tight bounds through a one-group problem):
    maximise lands on the best of a fine grid of amplitudes."""
    prob, *_ = small_problem("roughness")
    one = EvidenceProblem(prob.G, prob.g, prob.yty, prob.n, prob.sigma, np.where(prob.group >= 0, 0, -1),
                          prob.axis, prob.e, prob.w, "roughness")
    value, amp, lam, _ = maximise(one, 1, 1, False)
    grid = np.exp(np.linspace(math.log(1e-6), math.log(1e-2), 601))
    lam_fixed = math.log(lam[0])
    best = max(grid, key=lambda a: -one.evaluate(np.array([math.log(a), lam_fixed]), 1, 1, False)[0])
    assert amp[0] == pytest.approx(best, rel=2e-2)
    assert value >= -one.evaluate(np.array([math.log(best), lam_fixed]), 1, 1, False)[0] - 1e-9


@pytest.fixture(scope="module")
def sim(flow):
    return simulate(flow, seed=11, design=Design(n_commands=40, n_validation=2))


@pytest.fixture(scope="module")
def fitted(flow, sim):
    """A 6-DoF model with penalised splines of 4 knots (a Fourier series of order 4 on C) under a
    smoothness prior, fitted to a small simulated campaign (stated noise)."""
    bases = smooth_bases(flow, sim.campaign, knots=4, fourier=4)
    groups = [f"{a}.{c}" for a in flow.axis_names for c in ("dx", "dy", "dz", "ex", "ey", "ez")]
    prior = SmoothPrior(tuple((g, "length" if ".d" in g else "angle", 2e-5 * (1 + k % 5))
                              for k, g in enumerate(groups)),
                        tuple((a, 3.0) for a in flow.axis_names), "squared-exponential")
    model = make_model("6dof", flow, 0, bases=bases, prior=prior)
    noise = NoiseModel.default(flow)
    return model.fit(sim.campaign, noise, underdetermined=True), sim.campaign, noise


def test_the_fit_is_the_ridge_solution_of_the_linearised_problem(fitted):
    """The parameters a fit under the prior gives are the posterior mean of the problem linearised at
    the nominal machine, (G + S^-1)^-1 J'w in the prior-scaled unknowns (to the model's nonlinearity),
    and each column's prior is its amplitude x exp(-(w scale)^2 / 4)."""
    model, campaign, noise = fitted
    removed = set(model.report_.removed)
    proto = make_model("6dof", model.machine, 0, bases=model.bases, prior=model.spec.prior)
    lik = Likelihood(proto, campaign, noise, setup=None)
    _, G, g, _ = lik.normal_equations(np.zeros(lik.n_unknowns))
    keep = np.array([n not in removed for n in lik.names])
    psi = np.zeros(lik.n_unknowns)
    psi[keep] = -linalg.solve(G[np.ix_(keep, keep)] + np.eye(keep.sum()), g[keep], assume_a="pos")
    theta = psi * lik.sigma
    b = theta[6:6 + model.n_parameters]
    assert np.abs(b - model.b_).max() <= 2e-3 * np.abs(model.b_).max()
    p = next(p for p in model.parameters if p.group == "X.dy" and p.order == 3)
    w = frequencies(model.bases[0])[3]
    assert p.prior == pytest.approx(model.spec.prior.amplitude("X.dy") * math.exp(-(w * 3.0) ** 2 / 4))
    assert roughness(model.bases[0])[:2] == pytest.approx([0.0, 0.0], abs=1e-12)   # a line costs nothing


def test_the_model_file_keeps_the_prior(fitted, tmp_path):
    """Saved and read back: the same prior (mm and degrees in the file), priors and predictions."""
    model = fitted[0]
    model.save(tmp_path / "m.json")
    back = ErrorModel.load(tmp_path / "m.json")
    assert back.spec.prior.kernel == "squared-exponential" and back.spec.prior.roughness == model.spec.prior.roughness
    assert back.bases == model.bases and back.parameter_names == model.parameter_names
    assert back.priors == pytest.approx(model.priors, rel=1e-12)
    q = model.machine.lower + np.random.default_rng(0).random((20, 5)) * (model.machine.upper - model.machine.lower)
    assert back.predict(q, 0.1) == pytest.approx(model.predict(q, 0.1), rel=1e-9, abs=1e-15)
    assert "smoothness prior" in back.label()


def test_the_fit_problem_takes_the_smooth_basis(flow, sim, tmp_path):
    """``basis="smooth"``: the evidence's prior in the fitted model (amplitudes moved from their common
    start, inside their range), the stated noise kept, the file read back; the model choice refuses it."""
    from vecpin.errors import InputError
    from vecpin.fitting.problem import FitProblem
    from vecpin.fitting.smoothprior import BOUNDS
    from vecpin.selection.choice import choose_or_fix
    noise = NoiseModel.default(flow)
    result = FitProblem.build(flow, sim.campaign, noise, basis="smooth", order=2).solve()
    prior = result.model.spec.prior
    assert prior is not None and result.choice is None and result.noise_used == 1.0
    amps = np.array([v for _, _, v in prior.amplitudes])
    assert np.all((amps > 0.99 * BOUNDS[0]) & (amps < 1.01 * BOUNDS[1])) and np.ptp(np.log(amps)) > 1   # moved
    assert {a for a, _ in prior.roughness} == set(flow.axis_names)
    result.model.save(tmp_path / "m.json")    # read back: every parameter within its prior's reach (models.recorded)
    assert ErrorModel.load(tmp_path / "m.json").spec.prior.kernel == prior.kernel
    with pytest.raises(InputError, match="`basis` smooth"):
        choose_or_fix(flow, sim.campaign, noise, basis="smooth")
