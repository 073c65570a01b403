"""The model file's check commands: vecpin's scrambled Halton points equal scipy's, bit for bit.

A model file records its uncompensated figure on these commands and every reader recomputes it
(vecpin.models.recorded); vecpin draws them without importing scipy.stats (a second of start-up),
so they are held here to scipy's ``qmc.Halton(d, scramble=True, seed=0)``, the judge.
"""
import numpy as np
import pytest
from scipy.stats import qmc

from vecpin.models.recorded import CHECK_COMMANDS, scrambled_halton


@pytest.mark.parametrize("d", range(1, 10))
def test_equal_to_scipy(d):
    want = qmc.Halton(d=d, scramble=True, seed=0).random(CHECK_COMMANDS)
    assert np.array_equal(scrambled_halton(d, CHECK_COMMANDS, seed=0), want)


def test_other_seed_and_length():
    want = qmc.Halton(d=3, scramble=True, seed=5).random(1000)
    assert np.array_equal(scrambled_halton(3, 1000, seed=5), want)
