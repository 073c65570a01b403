"""A large campaign's normal equations, shared out in pieces between forked copies, are the
whole pass's: each piece of rows (every block's, sorted by pose) lands in exactly one share.
Checked on a small campaign cut in small pieces (the sum of the shares against one pass); the
forked run itself is the million-row benchmark's (benchmarks/bench_million.py)."""
import numpy as np

from vecpin.identification.likelihood import Likelihood
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.simulate import Design, simulate


def test_the_shares_sum_to_the_whole_pass(machines):
    m = machines["trunnion_xyzac"]
    c = simulate(m, seed=3, design=Design(n_commands=40, n_validation=4, nests=3)).campaign   # tool and nest rows
    lik = Likelihood(make_model("ap", m, 1), c, NoiseModel.default(m, "spherical"))
    theta = np.random.default_rng(0).normal(size=lik.n_unknowns) * lik.sigma * 0.1
    chi2, G, g, n_eq = lik.normal_equations(theta, chunk=17)
    parts = [lik._normal_sums(theta, True, 17, (k, 3)) for k in range(3)]
    shares = [s for s, _ in parts]
    assert sum(s[3] for s in shares) == n_eq
    np.testing.assert_allclose(sum(s[0] for s in shares), chi2, rtol=1e-12)
    np.testing.assert_allclose(sum(s[1] for s in shares), G, rtol=1e-10, atol=1e-12 * np.abs(G).max())
    np.testing.assert_allclose(sum(s[2] for s in shares), g, rtol=1e-10, atol=1e-12 * np.abs(g).max())


def test_a_pass_keeps_its_points_for_the_same_theta(machines):
    """The points a pass predicted (every share's rows) are those a pass without Jacobians
    computes afresh, to the last digit; two passes at other thetas later, they are computed afresh."""
    m = machines["trunnion_xyzac"]
    c = simulate(m, seed=3, design=Design(n_commands=40, n_validation=4, nests=3)).campaign
    model, noise = make_model("ap", m, 1), NoiseModel.default(m, "spherical")
    lik = Likelihood(model, c, noise)
    theta = np.random.default_rng(1).normal(size=lik.n_unknowns) * lik.sigma * 0.1
    fresh = Likelihood(model, c, noise).predicted_points(theta, chunk=17)
    y = np.full((len(c), 3), np.nan)
    for _, (rows, points) in (lik._normal_sums(theta, True, 17, (k, 3)) for k in range(3)):
        y[rows] = points
    np.testing.assert_array_equal(y, fresh)
    lik.normal_equations(theta, chunk=17)
    np.testing.assert_array_equal(lik.predicted_points(theta, chunk=17), fresh)
    for other in (0.5, 0.25):
        lik.normal_equations(theta * other, chunk=17)
    assert not any(np.array_equal(kept[0], theta) for kept in lik._points)
    np.testing.assert_array_equal(lik.predicted_points(theta, chunk=17), fresh)
