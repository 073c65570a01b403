"""Issue 40, clean campaigns silent: the gross-error limit holds its stated family-wise
false-alarm rate when the noise level is estimated from the same residuals (the median
level, its own scatter allowed for by F with the level's degrees of freedom), judged by a
Monte Carlo of Gaussian residuals; a gross row is still found."""
import numpy as np

from vecpin.diagnosis import grosserrors

ALPHA = 0.01


def _clean(rng, trials: int, rows: int, sigma: float = 0.7) -> np.ndarray:
    """(trials, rows) squared norms of 3-D Gaussian residuals of an unknown scale ``sigma``."""
    return np.sum((sigma * rng.standard_normal((trials, rows, 3))) ** 2, axis=2)


def test_the_limit_holds_its_rate_with_the_level_estimated(rng):
    """40 rows: with the level treated as known (chi2) a clean campaign flags a row about twice
    as often as stated; with F at the level's degrees of freedom at most the stated rate, and
    not far below it. The degrees of freedom match the median level's own scatter (2 / nu)."""
    trials, rows = 20_000, 40
    s = _clean(rng, trials, rows)
    valid = np.ones((rows, 3), bool)
    per_median = grosserrors.robust_level(np.ones(rows), valid)   # the level is the median over this (one call:
    level = np.median(s, axis=1) * per_median                        # the median is homogeneous)
    dof = grosserrors.level_dof(valid)
    ratio = (s / level[:, None]).max(axis=1)
    known = np.mean(ratio > grosserrors.row_limit(valid, rows, ALPHA)[0])
    honest = np.mean(ratio > grosserrors.limit(valid, rows, ALPHA, dof)[0])
    margin = 3 * np.sqrt(ALPHA * (1 - ALPHA) / trials)
    assert known > ALPHA + margin, known
    assert 0.4 * ALPHA < honest <= ALPHA + margin, honest
    rel_var = np.var(level / 0.49) / np.mean(level / 0.49) ** 2      # sigma^2 = 0.49
    assert abs(rel_var * dof / 2 - 1) < 0.15, (rel_var, dof)


def test_a_gross_row_is_still_found(rng):
    """One row 0.3 mm off among 300 rows of 10 um noise (a typical gross error) is flagged, alone."""
    rows = 300
    w = 10e-3 * rng.standard_normal((rows, 3))
    w[123] += [0.3, 0.0, 0.0]
    s = np.sum(w**2, axis=1)
    valid = np.ones((rows, 3), bool)
    level = grosserrors.robust_level(s, valid)
    hit = grosserrors.beyond(s, valid, level, rows, ALPHA, grosserrors.level_dof(valid))
    np.testing.assert_array_equal(np.flatnonzero(hit), [123])
