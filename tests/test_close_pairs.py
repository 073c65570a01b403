"""Poses read twice: vecpin's pairs of readings within the tolerance equal scipy's k-d tree's.

``vecpin.measurement.repeatability.close_pairs`` finds them by a sweep along one coordinate (no
scipy.spatial import in a fit of distinct commands); scipy's ``cKDTree.query_pairs`` (maximum
norm) is the judge, on random rows with repeats, near repeats and a still axis.
"""
import numpy as np
from scipy.spatial import cKDTree

from vecpin.measurement.repeatability import close_pairs


def _pairs(x):
    return {tuple(p) for p in cKDTree(x).query_pairs(1.0, p=np.inf, output_type="ndarray").tolist()}


def test_equal_to_kdtree():
    rng = np.random.default_rng(0)
    for _ in range(20):
        n, d = int(rng.integers(2, 150)), int(rng.integers(1, 6))
        x = rng.uniform(0, rng.choice([3.0, 30.0, 1e4]), (n, d))
        k = int(rng.integers(1, n + 1))
        x[:k] = x[rng.integers(0, n, k)] + rng.uniform(-1.2, 1.2, (k, d)) * (rng.random() < 0.5)
        if rng.random() < 0.3:
            x[:, 0] = 5.0          # an axis that stood still
        assert {tuple(p) for p in close_pairs(x).tolist()} == _pairs(x)


def test_crowded_falls_back_to_the_tree():
    x = np.random.default_rng(1).uniform(0, 2, (150, 2))     # every row near every other along each axis
    assert {tuple(p) for p in close_pairs(x).tolist()} == _pairs(x)
