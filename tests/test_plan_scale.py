"""Large plans: the lazy D-optimal choice picks what the plain greedy picks (whatever the
batch of recomputed gains), the windowed 2-opt keeps a tour whole and its ends where
they are, and the default candidate count keeps 10,000 commands affordable."""
import numpy as np
import pytest

from vecpin.planning import route
from vecpin.planning.doptimal import greedy_d_optimal
from vecpin.planning.candidates import candidate_commands, default_candidates


def _plain_greedy(W, n):
    N = np.eye(W.shape[2])
    out = []
    for _ in range(n):
        g = [np.linalg.slogdet(N + W[c].T @ W[c])[1] if c not in out else -np.inf for c in range(len(W))]
        out.append(int(np.argmax(g)))
        N = N + W[out[-1]].T @ W[out[-1]]
    return out


def test_lazy_choice_is_the_plain_greedy_for_any_batch():
    rng = np.random.default_rng(4)
    W = rng.normal(size=(120, 3, 9)) * rng.uniform(0.2, 1.5, (120, 1, 1))
    want = _plain_greedy(W, 25)
    for batch in (1, 3, 64, 500):
        assert list(greedy_d_optimal(W, 25, batch=batch)[0]) == want
    # float32 rows (the plan stores its candidates so) choose the same here
    assert list(greedy_d_optimal(W.astype(np.float32), 25)[0]) == want


def test_windowed_tour_is_whole_and_close_to_the_full_two_opt(flow):
    speed = route.axis_speeds(flow)
    q = candidate_commands(flow, 700, flow.lower, flow.upper, 5)
    full = route.order_points(q, speed, window=1000)
    win = route.order_points(q, speed, window=150)
    assert sorted(win) == list(range(len(q)))
    t_full, t_win = route.travel_time(q[full], speed), route.travel_time(q[win], speed)
    nn = route.order_points(q, speed, max_passes=1, window=1000)  # nearest neighbour and one 2-opt move
    assert t_win < route.travel_time(q[nn], speed) and t_win < 1.1 * t_full


def test_two_opt_with_a_fixed_end_keeps_both_ends():
    rng = np.random.default_rng(2)
    q = rng.uniform(0, 1, (30, 2))
    D = route.move_times(q[:, None, :], q[None, :, :], np.ones(2))
    p = route.two_opt(np.arange(30), D, fixed_end=True)
    assert p[0] == 0 and p[-1] == 29 and sorted(p) == list(range(30))
    cost = (lambda t: D[t[:-1], t[1:]].sum())
    assert cost(p) < cost(np.arange(30))


def test_default_candidates():
    assert default_candidates(100) == 2000 and default_candidates(1000) == 10_000
    assert default_candidates(2000) == 10_000 and default_candidates(10_000) == 30_000


def test_compact_rows_carry_the_same_normal_matrix(machines):
    """A plan is scored from (P, P) rows with the readings' W^T W, summed in chunks."""
    from vecpin.measurement.noise import NoiseModel
    from vecpin.models import make_model
    from vecpin.planning.information import Information
    m = machines["trunnion_xyzac"]
    info = Information(make_model("6dof", m, 2), NoiseModel.default(m, "spherical"), np.array([0.0, 2.5, 0.7]),
                       [0.2, 0.3], nests={"1": np.array([0.1, 0.05, 0.03])})
    q = candidate_commands(m, 50, m.lower, m.upper, 1)
    tool = np.r_[np.full(50, 0.2), np.full(50, 0.3), np.full(50, 0.2)]
    inst = np.array(["tracker"] * 100 + ["nest"] * 50, dtype=object)
    target = np.array([""] * 100 + ["1"] * 50, dtype=object)
    qq = np.vstack([q, q, q])
    W = info.measurement_rows(qq, tool, inst, target).reshape(-1, info.P)
    C = info.compact_rows(qq, tool, inst, target, chunk=40)
    assert C.shape == (info.P, info.P)
    np.testing.assert_allclose(C.T @ C, W.T @ W, rtol=1e-9, atol=1e-9 * np.abs(W.T @ W).max())
    assert info.log_det(C) == pytest.approx(info.log_det(W), rel=1e-9)


def test_candidate_rows_in_chunks_keep_every_row_and_choose_as_the_dense_rows():
    """Rows stored by groups over their nonzero columns, in chunks whose later ones reach
    columns the first did not (the store widens), and with rows that are all zero (a nest
    out of sight): the same rows back, the same X = W F^T, the same picks as the plain greedy."""
    from vecpin.planning.doptimal import CandidateRows, _whitening
    rng = np.random.default_rng(7)
    C, P = 90, 100
    W = np.zeros((C, 8, P))
    W[:, :3, :55] = rng.normal(size=(C, 3, 55))           # "tool" rows: the first 55 terms
    W[:, 3:, 45:] = rng.normal(size=(C, 5, 55))           # "nest" rows: the last 55 terms
    W[rng.random(C) < 0.3, 3:, :] = 0.0                    # a nest out of sight: zero rows
    W[60:, 0, 80] = rng.normal(size=30)                    # a column only later chunks reach
    rows = CandidateRows(iter([W[:25], W[25:60], W[60:]]), C)
    assert len(rows.groups) == 2 and rows.nbytes < 0.6 * W.nbytes
    np.testing.assert_array_equal(rows.dense(np.arange(C)), W)
    F, _ = _whitening(np.eye(P) + np.einsum("cri,crj->ij", W[:10], W[:10]))
    idx = rng.permutation(C)[:40]
    np.testing.assert_allclose(rows.whitened(idx, rows.factor_parts(F)), W[idx] @ F.T, atol=1e-12)
    assert list(greedy_d_optimal(rows, 20)[0]) == _plain_greedy(W, 20)


def test_the_choice_on_an_ill_conditioned_design_keeps_the_float64_picks():
    """float32 rows with gains taken in float32 through the whitening pick what float64
    picks on rows whose scales span six decades (the criterion differs by round-off)."""
    rng = np.random.default_rng(11)
    W = rng.normal(size=(300, 6, 20)) * np.logspace(-3, 3, 20)[None, None, :] * rng.uniform(0.3, 1.0, (300, 1, 1))
    p64, ld64 = greedy_d_optimal(W, 60)
    p32, ld32 = greedy_d_optimal(W.astype(np.float32), 60)
    assert list(p32) == list(p64)
    np.testing.assert_allclose(ld32, ld64, rtol=1e-6)


def test_a_table_plan_beyond_a_minute_warns_with_the_measured_figure(machines, flow):
    """Above the points a plan with table nests computes within a minute, the plan warns
    at once, naming `n_commands` and what the largest plan took; a head machine does not."""
    import warnings
    from vecpin.errors import VecpinWarning
    from vecpin.planning.problem import TABLE_LARGEST, TABLE_MINUTE_POINTS, PlanSettings, plan_problem
    with pytest.warns(VecpinWarning, match=rf"`n_commands` {TABLE_MINUTE_POINTS + 1}: .*{TABLE_LARGEST}"):
        plan_problem(machines["trunnion_xyzac"], PlanSettings(n_commands=TABLE_MINUTE_POINTS + 1, sight=False))
    with warnings.catch_warnings():
        warnings.simplefilter("error", VecpinWarning)
        plan_problem(machines["trunnion_xyzac"], PlanSettings(n_commands=TABLE_MINUTE_POINTS, sight=False))
        plan_problem(flow, PlanSettings(n_commands=10_000, sight=False))
