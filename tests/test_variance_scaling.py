"""Issue 42: the variance components of many repeated readings without dense per-pose blocks.

The reading noise's REML estimate is computed from per-pose sums; here it is checked
against the dense form it replaced (Helmert contrasts of every pose and axis, their
covariance C D Cᵀ + σ² I built and factored as matrices, written in this test), and a
campaign with one pose read 5,000 times is reduced in O(N) memory (tracemalloc: the
dense form would hold a 5,000 x 5,000 contrast matrix, 200 MB).
"""
import math
import tracemalloc

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from vecpin.identification.variance import reml_repeatability, variance_components
from vecpin.measurement.campaign import Campaign


def _helmert(n: int) -> np.ndarray:
    """(n-1, n) orthonormal contrasts: rows orthogonal to the ones vector and to each other."""
    H = np.zeros((n - 1, n))
    for k in range(1, n):
        H[k - 1, :k] = 1.0
        H[k - 1, k] = -k
        H[k - 1] /= math.sqrt(k * (k + 1))
    return H


def _dense_reml(r, known, block):
    """The dense REML (the former vecpin code): per block z = C r, covariance C D Cᵀ + σ² I,
    log det and solve by matrices; σ² by the same bounded search; Fisher ½ Σ tr(M⁻²)."""
    blocks = []
    for b in np.unique(block):
        sel = block == b
        C = _helmert(int(sel.sum()))
        blocks.append((C @ r[sel], (C * known[sel]) @ C.T))

    def nll(log_s2):
        s2 = math.exp(log_s2)
        return 0.5 * sum(np.linalg.slogdet(K + s2 * np.eye(len(z)))[1] + z @ np.linalg.solve(K + s2 * np.eye(len(z)), z)
                         for z, K in blocks)
    scale = np.mean([float(z @ z) / len(z) for z, _ in blocks])
    res = minimize_scalar(nll, bounds=(math.log(scale * 1e-8 + 1e-16), math.log(scale * 10 + 1e-16)), method="bounded")
    s2 = math.exp(res.x)
    info = 0.5 * sum(np.trace(np.linalg.matrix_power(np.linalg.inv(K + s2 * np.eye(len(z))), 2)) for z, K in blocks)
    return s2, 1.0 / math.sqrt(info), nll


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_per_pose_sums_equal_the_dense_helmert_reml(seed):
    """Blocks of 2 to 9 readings, known variances different at every reading (the
    tracker's std columns), pose means far larger than the scatter: the estimate, its
    standard deviation and the likelihood itself equal the dense form's."""
    rng = np.random.default_rng(seed)
    sizes = rng.integers(2, 10, 40)
    block = np.repeat(np.arange(len(sizes)), sizes)
    known = rng.uniform(0.2, 2.0, block.size) * 1e-4             # mm²
    s2_true = 3e-4
    r = rng.normal(0.0, 1.0, block.size) * np.sqrt(known + s2_true) + rng.normal(0, 0.5, len(sizes))[block]
    s2, sd = reml_repeatability(r, known, block)
    s2_d, sd_d, nll_d = _dense_reml(r, known, block)
    assert s2 == pytest.approx(s2_d, rel=1e-4)
    assert sd == pytest.approx(sd_d, rel=1e-4)
    # the likelihood's shape (differences between two σ², constants aside) is the dense one's
    n = np.bincount(block)
    for a, b in ((1e-4, 5e-4), (2e-4, 1e-3)):
        w_a, w_b = 1 / (known + a), 1 / (known + b)

        def per_sums(w, s):
            S, Sr = np.bincount(block, w), np.bincount(block, w * r)
            return 0.5 * (np.log(known + s).sum() + np.log(S).sum() - np.log(n).sum() + (w * r * r).sum()
                          - (Sr**2 / S).sum())
        assert per_sums(w_a, a) - per_sums(w_b, b) == pytest.approx(nll_d(math.log(a)) - nll_d(math.log(b)), rel=1e-9)


def test_reml_of_pairs_with_a_known_part_is_the_closed_form():
    """Every reading's known variance c, pairs of readings: the REML variance beyond it is
    mean(z²) - c over the pairs' contrasts z = (r1 - r2) / √2, its Fisher information
    n / (2 (c + σ²)²) (closed forms)."""
    rng = np.random.default_rng(3)
    c, s2 = 0.4, 1.1
    z = rng.normal(0.0, np.sqrt(c + s2), 600)
    r = np.column_stack([z, -z]).ravel() / math.sqrt(2)          # (r1 - r2) / √2 = z
    est, sd = reml_repeatability(r, np.full(r.size, c), np.repeat(np.arange(600), 2))
    assert est == pytest.approx(np.mean(z**2) - c, rel=1e-4)
    assert sd == pytest.approx(np.sqrt(2 * (c + est) ** 2 / 600), rel=1e-3)


def test_one_pose_read_5000_times_in_linear_memory():
    """20,000 rows of a 5-axis machine: 15,000 poses read once, one pose read 5,000 times
    with the tracker's σ in its std columns. The reading part is the pooled within-pose
    variance less the tracker's (a closed form: every known variance equal), the
    repeatability lands on the simulated one, and the reduction's peak memory stays far
    below what one dense 5,000 x 5,000 contrast matrix takes (200 MB)."""
    rng = np.random.default_rng(7)
    q = np.vstack([rng.uniform(-1, 1, (15_000, 5)), np.tile([0.1, 0.2, 0.3, 0.4, 0.5], (5_000, 1))])
    tracker, repeat = 0.010, 0.006                               # mm, per axis
    res_mm = rng.normal(0.0, 0.03, (20_000, 3))                  # poses read once: the pose part and noise
    res_mm[15_000:] = 0.02 + rng.normal(0.0, math.hypot(tracker, repeat), (5_000, 3))
    std = {k: np.full(20_000, tracker) for k in ("std_x", "std_y", "std_z")}
    c = Campaign(list("XYZAC"), q, np.full(20_000, 0.2), np.zeros((20_000, 3)), std)
    tracemalloc.start()
    vc = variance_components(res_mm / 1000.0, c, dof=59_900.0, stated_mm=0.01)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    rep = res_mm[15_000:]
    pooled = ((rep - rep.mean(axis=0)) ** 2).sum() / (3 * (5_000 - 1))
    assert vc.repeated_poses == 1 and vc.contrasts == 3 * 4_999
    assert vc.repeatability**2 == pytest.approx(pooled - tracker**2, rel=1e-4)
    assert abs(vc.repeatability - repeat) < 3 * vc.repeatability_sd
    assert vc.instrument == pytest.approx(tracker)
    assert peak < 20e6, f"{peak / 1e6:.0f} MB"


def test_the_choice_on_a_subsample_says_so(monkeypatch):
    """A campaign larger than the choice's subsample (here made small: 200 rows of 590) is
    judged on whole commands drawn with a fixed seed, the same rows on every run, and the
    choice table says so; a campaign within it does not."""
    import vecpin
    import vecpin.selection.choice as choice
    from vecpin.measurement.noise import NoiseModel
    from vecpin.simulation.simulate import Design, simulate
    m = vecpin.Machine.load("flow_xyzcb")
    c = simulate(m, seed=4, design=Design(n_validation=5)).campaign
    noise = NoiseModel.default(m)
    monkeypatch.setattr(choice, "MAX_SELECTION_ROWS", 200)
    one = choice.choose_model(m, c, noise, kinds=("ap",), families=("chebyshev",), orders=(0, 1), per_axis=False)
    assert one.subsample[1:] == (len(c), 0) and one.subsample[0] <= 200
    assert f"chosen on a subsample: {one.subsample[0]} of the campaign's {len(c)} rows" in one.table()
    a, b = choice._subsample(c, 0), choice._subsample(c, 0)
    assert len(a) == one.subsample[0] and np.array_equal(a.lines, b.lines)
    monkeypatch.setattr(choice, "MAX_SELECTION_ROWS", 3000)
    whole = choice.choose_model(m, c, noise, kinds=("ap",), families=("chebyshev",), orders=(0, 1), per_axis=False)
    assert whole.subsample == () and "subsample" not in whole.table()
