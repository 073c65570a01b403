"""Issue 26, what to measure next: an ambiguity group of the diagnosis comes with a short
discriminating measurement (commands, NC program, expected readings under each
candidate) that, measured on the simulated truth and appended to the campaign, settles
it: the true member is then named alone."""
import numpy as np
import pytest

from vecpin.diagnosis.diagnose import diagnose
from vecpin.measurement.campaign import Campaign
from vecpin.planning import discriminate
from vecpin.simulation.effects import TrueEffect
from vecpin.simulation.simulate import Design, simulate


def test_the_chosen_points_add_what_the_joint_gaussian_says(rng):
    """The greedy choice's gains (incremental Cholesky over the pool, row by row) add up
    to the closed form d_S^T (s I + H_S H_S^T)^-1 d_S over the points taken."""
    N, P, s = 30, 5, 1.7
    d = rng.normal(size=(N, 3)) * 2.0
    Ha, Hb = rng.normal(size=(N, 3, P)) * 0.5, rng.normal(size=(N, 3, P - 2)) * 0.3
    pair = discriminate._Pair(d, Ha, Hb, s)
    taken, gains = discriminate._choose([pair], n_min=6, n_max=6)
    assert len(set(taken.tolist())) == 6
    rows = np.concatenate([np.arange(3 * k, 3 * k + 3) for k in taken])
    H = np.concatenate([Ha, Hb], axis=-1).reshape(3 * N, -1)[rows]
    dS = d.ravel()[rows]
    closed = dS @ np.linalg.solve(s * np.eye(len(rows)) + H @ H.T, dS)
    np.testing.assert_allclose(gains.sum(), closed, rtol=1e-9)
    # the first point is the one whose own reading says most: |d|^2 / (s + |H|^2) summed over its rows
    own = (d ** 2 / (s + np.einsum("nip,nip->ni", Ha, Ha) + np.einsum("nip,nip->ni", Hb, Hb))).sum(axis=1)
    assert taken[0] == int(np.argmax(own))


def test_the_rank_3_updates_condition_as_a_direct_solve(rng):
    """Point by point (more rows than the factor first holds), the pair's conditional mean and
    variance after the rank-3 updates are those of the joint Gaussian conditioned directly:
    mu - S[:, T] S_TT^-1 mu_T and diag(S - S[:, T] S_TT^-1 S[T, :]), S = s I + H H^T."""
    N, P, s = 40, 6, 0.8
    d = rng.normal(size=(N, 3))
    Ha, Hb = rng.normal(size=(N, 3, P)) * 0.7, rng.normal(size=(N, 3, P)) * 0.4
    pair = discriminate._Pair(d, Ha, Hb, s)
    H = np.concatenate([Ha, Hb], axis=-1).reshape(3 * N, -1)
    S, mu = s * np.eye(3 * N) + H @ H.T, d.ravel()
    taken = rng.permutation(N)[:20]
    for k in taken:
        pair.take(int(k))
    T = np.concatenate([np.arange(3 * k, 3 * k + 3) for k in taken])
    K = np.linalg.solve(S[np.ix_(T, T)], S[T])
    np.testing.assert_allclose(pair.mu, mu - K.T @ mu[T], atol=1e-9)
    np.testing.assert_allclose(pair.var, np.clip(np.diag(S - S[:, T] @ K), 0, None), atol=1e-9)


@pytest.mark.slow   # two diagnoses of a 590-row campaign: the edit loop (-m 'not slow') leaves it to CI
# run=False while it is known to fail (18 s of CI for a known answer); remove it with the fix
@pytest.mark.xfail(strict=True, run=False, reason="issue 40 regression, open: after the 15-point plan the truth gantry_skew[Y/x] "
                   "is named first and out-predicts the skew of Z by 600 nats and coupled_axes[X,Y] by 113, but the "
                   "paired test over the commands where they differ gives p = 0.008 and 0.007 against the round's "
                   "threshold 6.6e-5 (about 45 such commands would reach it; the plan stops at 40), so the group holds")
def test_a_discriminating_plan_settles_an_ambiguity_group(flow, tmp_path):
    """A gantry skew of Y (about x, growing with X) measured with the ram Z at one height:
    a skew of Y and a skew of Z turn the tip alike, so the diagnosis names a group. Its
    plan measures 15-40 points over the whole travel (Z varied); their readings on the
    simulated truth, appended to the campaign, name the skew of Y alone."""
    spec = TrueEffect("gantry_skew", ("Y",), 0.05, {"about": "x", "depends": "X"}, seed=1)
    first = simulate(flow, seed=11, design=Design(n_validation=10))
    q, tool = first.campaign.q.copy(), first.campaign.tool.copy()
    q[:, flow.axis_names.index("Z")] = flow.axis("Z").lower  # the whole campaign at one ram height
    sim = simulate(flow, seed=11, design=Design(n_validation=10), effects=[spec], plan=(q, tool))
    c = sim.campaign
    d = diagnose(flow, c)
    acc = [e for e in d.accepted if e.name != "outliers"]
    assert len(acc) == 1 and {acc[0].label, *acc[0].alternatives} >= {"gantry_skew[Y/x]", "gantry_skew[Z/x]"}
    assert d.to_settle() == acc
    plan = acc[0].next_plan
    assert 15 <= len(plan.tool) <= 40 and set(plan.labels) == {acc[0].label, *acc[0].alternatives}
    assert np.ptp(plan.q[:, flow.axis_names.index("Z")]) > 0.1 * flow.axis("Z").travel  # the campaign held it
    # written next to the report and named there: template, expected readings, NC programs
    paths = d.write(tmp_path)
    report = paths["report"].read_text()
    assert "## What to measure next" in report and "next_1/plan.ngc" in report and "next_1/expected.csv" in report
    assert "next_1/" in d.headline()[2]
    program = (tmp_path / "next_1" / "plan.ngc").read_text()
    assert program.count("read the tool target") == len(plan.tool)
    expected = (tmp_path / "next_1" / "expected.csv").read_text().splitlines()
    assert len(expected) == len(plan.tool) + 1 and all(f"{lab} x [mm]" in expected[0] for lab in plan.labels)
    # measured on the simulated truth right after the campaign, appended, diagnosed again
    new, feats = discriminate._after(c, plan.q, plan.tool)
    xyz = sim.truth.measure(plan.q, plan.tool, np.random.default_rng(99), feats)
    both = Campaign(c.axis_names, np.vstack([c.q, plan.q]), np.r_[c.tool, plan.tool], np.vstack([c.xyz, xyz]),
                    {k: np.r_[c.extra[k], new.extra[k]] for k in ("time", "temperature")}, "campaign + plan")
    d2 = diagnose(flow, both)
    acc2 = [e for e in d2.accepted if e.name != "outliers"]
    assert [e.label for e in acc2] == ["gantry_skew[Y/x]"] and not acc2[0].alternatives, [e.finding for e in acc2]


def test_a_scanned_candidate_gain_is_the_full_solve(rng):
    """The round's Schur-complement gain of a scanned candidate's columns
    (FoldedProblem.chi2_gain) equals the full normal-equation solve over [J0, J1] less that
    over J0 (closed form, numpy)."""
    from vecpin.identification.crossval import FoldedProblem
    N, P0, k = 120, 9, 3
    J0, J1, w, psi0 = rng.normal(size=(N, 3, P0)), rng.normal(size=(N, 3, k)), rng.normal(size=(N, 3)), rng.normal(size=P0)
    a, b = J0.reshape(-1, P0), J1.reshape(-1, k)
    base = FoldedProblem(J0, np.zeros_like(J0), w, np.zeros_like(w), np.arange(N) % 5, x0=psi0)
    gain = base.chi2_gain(J1)
    ab = np.c_[a, b]
    g_full = np.r_[a.T @ w.ravel() - psi0, b.T @ w.ravel()]
    g0 = a.T @ w.ravel() - psi0
    full = g_full @ np.linalg.solve(ab.T @ ab + np.eye(P0 + k), g_full) - g0 @ np.linalg.solve(a.T @ a + np.eye(P0), g0)
    np.testing.assert_allclose(gain, full, rtol=1e-10)


def test_scanned_gains_formed_together_are_each_full_solve(rng):
    """A scanned family's gains formed together (FoldedProblem.chi2_gains, groups of at most 4 columns here)
    equal each candidate's full normal-equation solve over [J0, J1] less that over J0 (closed form, numpy)."""
    from vecpin.identification.crossval import FoldedProblem
    N, P0 = 100, 7
    J0, w, psi0 = rng.normal(size=(N, 3, P0)), rng.normal(size=(N, 3)), rng.normal(size=P0)
    a, g0 = J0.reshape(-1, P0), J0.reshape(-1, P0).T @ w.ravel() - psi0
    base = FoldedProblem(J0, np.zeros_like(J0), w, np.zeros_like(w), np.arange(N) % 5, x0=psi0)
    J1s = [rng.normal(size=(N, 3, k)) for k in (2, 1, 3, 6, 2)]
    gains = base.chi2_gains(J1s, width=4)
    for J1, gain in zip(J1s, gains):
        ab, b = np.c_[a, J1.reshape(len(a), -1)], J1.reshape(len(a), -1)
        g_full = np.r_[g0, b.T @ w.ravel()]
        full = (g_full @ np.linalg.solve(ab.T @ ab + np.eye(ab.shape[1]), g_full)
                - g0 @ np.linalg.solve(a.T @ a + np.eye(P0), g0))
        np.testing.assert_allclose(gain, full, rtol=1e-10)
