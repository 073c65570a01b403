"""Issue 40: a flagged row whose neighbours in joint space share its misfit is a region the
model does not fit, not a gross error. The residuals are the test's own (noise of 10 µm):
every command read at two visits (the second block of the file reads them again); a misfit
at four poses that both visits carry is a region ("near"); a cluster of four gross errors
read one after another (a tracker that moved) and an isolated one stay gross errors: their
other visits do not carry them, and the cluster's rows do not vouch for each other."""
import numpy as np

from vecpin.diagnosis import grosserrors
from vecpin.simulation.simulate import Design, simulate


def _unit(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1)[:, None]


def test_misfit_both_visits_share_is_a_region_and_gross_errors_stay(flow):
    one = simulate(flow, seed=5, design=Design(n_commands=80, n_validation=10)).campaign
    n = len(one)
    c = one.subset(np.r_[np.arange(n), np.arange(n)])          # every command read again, later
    rng = np.random.default_rng(3)
    sigma = 1e-5
    r = rng.normal(0.0, sigma, (2 * n, 3))
    poses = np.array([11, 40, 57, 73])
    offset = 9 * sigma * _unit(rng, poses.size)                # beyond the noise, both visits
    r[poses] += offset
    r[poses + n] += offset
    cluster = np.arange(20, 24)                                 # read one after another in the first block
    isolated = np.array([n + 5])
    gross_rows = np.r_[cluster, isolated]
    r[gross_rows] += rng.uniform(3e-4, 1.2e-3, (gross_rows.size, 1)) * _unit(rng, gross_rows.size)
    valid = np.ones((2 * n, 3), bool)
    s = np.sum((r / sigma) ** 2, axis=1)
    gross, misfit, regions = grosserrors.judge(flow, c, s, r / sigma, valid, r=r)
    assert sorted(gross) == sorted(gross_rows), (sorted(gross), sorted(gross_rows))
    flagged_poses = np.intersect1d(np.r_[poses, poses + n], np.r_[misfit, gross])
    assert flagged_poses.size >= 6 and np.isin(flagged_poses, misfit).all()
    near = [g for g in regions if g.get("near")]
    assert near and set(flagged_poses) <= {v for g in regions for v in g["rows"]}
    where, text = grosserrors.describe_region(near[0], c)
    assert where.startswith("near X") and "neighbours in joint space share" in text
    # the same misfit on one visit only (a reading that does not come back): gross errors
    r1 = r.copy()
    r1[poses + n] -= offset
    s1 = np.sum((r1 / sigma) ** 2, axis=1)
    gross1 = grosserrors.judge(flow, c, s1, r1 / sigma, valid, r=r1)[0]
    assert set(poses) <= set(gross1) and set(gross_rows) <= set(gross1)
