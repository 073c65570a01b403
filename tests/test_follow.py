"""What no table can follow (issue 41): the leftover of the full tables is named by the pair
of inputs it couples, found from synthetic leftovers whose shape is known in closed form,
and the remedy fits the machine's class."""
import numpy as np

from vecpin.compensation.follow import Unfollowed, coupled_pairs, remedy, unfollowed


def _inputs(rng, n=3000):
    return {"X": rng.uniform(0, 1.2, n), "Y": rng.uniform(-0.4, 0.4, n), "A": rng.uniform(-1.5, 1.5, n),
            "C": rng.uniform(-3.1, 3.1, n)}


def test_a_product_of_two_axes_is_named_as_their_coupling(rng):
    v = _inputs(rng)
    left = np.zeros((len(v["X"]), 3))
    left[:, 1] = 20e-6 * (v["X"] - 0.6) * np.sin(v["A"])     # a squareness that turns with the tilt
    left += rng.normal(0, 1e-6, left.shape)
    pairs = coupled_pairs(v, left)
    assert pairs and pairs[0][0] == "X with A" and pairs[0][1] > 0.5
    assert all("C" not in p for p, _ in pairs[:1])


def test_a_sum_of_one_axis_functions_is_no_coupling(rng):
    v = _inputs(rng)
    left = np.zeros((len(v["X"]), 3))
    left[:, 0] = 10e-6 * np.cos(v["C"]) + 5e-6 * v["Y"] ** 2   # what tables of one input can carry
    left += rng.normal(0, 1e-6, left.shape)
    assert coupled_pairs(v, left) == []


def test_the_line_says_what_is_left_and_what_removes_it(machines, rng):
    m = machines["trunnion_xyzac"]
    q = np.column_stack([rng.uniform(a.lower, a.upper, 500) for a in m.axes])
    before = np.tile([[0.2e-3, 0.0, 0.0]], (500, 1))
    after = np.zeros((500, 3))
    mid = (m.axes[0].lower + m.axes[0].upper) / 2
    after[:, 2] = 200e-6 * np.sin(q[:, 3]) * (q[:, 0] - mid) / m.axes[0].travel
    u = unfollowed(m, q, np.full(500, 0.2), before, after, fit_mm=0.005)
    line = u.line()
    assert "X with A" in line and "5-axis transformation" in line and f"{u.after_mm:.4f} of 0.2000 mm" in line
    assert "robot controller" in remedy(machines["ur5"]) and "volumetric" in remedy(machines["flow_xyzcb"])
    assert "follow the model" in Unfollowed(0.2, 0.006, 0.005, [], "").line()   # within the fit: nothing to say
    with_products = Unfollowed(0.2, 0.05, 0.005, [], "", "zc*x", 0.08).line()   # quoted after the terms written
    assert "0.0500 of 0.2000 mm mean, after the full tables with the product terms zc*x" in with_products
    assert "the one-axis tables alone, before the product terms, leave 0.0800 mm" in with_products
