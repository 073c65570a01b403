"""Per-row features of a campaign: approach directions (vectorised forward fill) and the
station that read each row."""
import numpy as np

from vecpin.measurement.features import Features, approach_directions
from vecpin.simulation.simulate import Design, simulate


def _loop(q):
    """The definition, row by row: the sign of each axis' last nonzero move before the row."""
    out = np.zeros_like(q)
    last = np.zeros(q.shape[1])
    for i in range(1, len(q)):
        step = np.sign(q[i] - q[i - 1])
        last = np.where(step != 0, step, last)
        out[i] = last
    return out


def test_approach_directions_equal_the_row_loop():
    rng = np.random.default_rng(7)
    q = rng.normal(size=(500, 5))
    # axes that stand still for runs of rows (the forward fill must carry the last move)
    for k in range(5):
        still = rng.random(500) < 0.3 + 0.15 * k
        for i in np.flatnonzero(still):
            if i:
                q[i, k] = q[i - 1, k]
    q[:40, 4] = 1.0  # an axis that does not move at first: 0 until its first move
    d = approach_directions(q)
    assert np.array_equal(d, _loop(q))
    assert np.all(d[:40, 4] == 0) and np.all(d[0] == 0)
    assert set(np.unique(d)) == {-1.0, 0.0, 1.0}


def test_features_of_a_campaign_with_stations_and_ball_bar(machines):
    m = machines["flow_xyzcb"]
    sim = simulate(m, seed=3, design=Design(n_commands=30, n_validation=10, stations=2, ballbar_points=20))
    c = sim.campaign
    f = Features.from_campaign(c)
    assert np.array_equal(f.direction, _loop(c.q))
    ball = c.instrument == "ballbar"
    assert np.all(f.station[ball] == -1)
    assert np.array_equal(f.station[~ball], c.station[~ball])
    rows = np.flatnonzero(~ball)[::3]
    s = f.subset(rows)
    assert np.array_equal(s.station, f.station[rows]) and np.array_equal(s.direction, f.direction[rows])
