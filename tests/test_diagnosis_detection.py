"""Issue 40: a diagnosis says what it could have seen, judges every effect given the
accepted ones, and plans its next measurement inside the measured range.

* The F-test's detection size on a small linear problem against a Monte Carlo of the
  F-test written here with numpy (least squares, no vecpin): at the stated size the test
  passes about 90 % of the time.
* The whole statement on simulated machines: a per-turn harmonic of a rotary axis
  simulated at twice the stated size is named, at half of it not.
* One meaning of significant: given the accepted effects.
* The discriminating plan stays inside the campaign's measured box, or says it does not.
"""
import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from vecpin.diagnosis.detection import Sight, mean_distance
from vecpin.diagnosis.diagnose import diagnose
from vecpin.diagnosis.report import _sight_section
from vecpin.identification.crossval import FoldedProblem
from vecpin.simulation.effects import TrueEffect
from vecpin.simulation.simulate import Design, simulate


def test_the_f_tests_detection_size_is_detected_90_percent_of_the_time():
    """k = 1 effect column beside P model columns (large, so the unit priors hardly count):
    an effect of the stated size, drawn into the data 4000 times with unit noise, passes
    the F-test at the threshold in 90 % of the draws (binomial spread 0.5 %)."""
    rng = np.random.default_rng(3)
    N, P, thr = 60, 4, 1e-3
    J = rng.normal(size=(N, 3, P)) * 30
    J1 = (rng.normal(size=(N, 3, 1)) + 0.5 * J[..., :1] / 30) * 2     # partly in the model's span
    base = FoldedProblem(J, J.copy(), np.zeros((N, 3)), np.zeros((N, 3)), np.arange(N) % 5)
    lin = SimpleNamespace(point_rows=np.ones(N, bool), r=np.zeros((N, 3)))
    dof = 3 * N - P - 1
    sight = Sight(base, lin, np.ones(N), 1.0, dof, 0.0)
    sight.add(SimpleNamespace(name="one", label="one[1]"), (J1 * 1e-3, J1))     # metric columns: 1 mm per unit
    sight.settle(thr)
    rms_mm = sight.found[0].by["the F-test"]
    s = rms_mm / math.sqrt(np.mean(np.sum(J1[..., 0] ** 2, axis=1)))               # the unit shape's size
    # the judge: least squares with and without the column, F against its critical value
    X0, X1 = J.reshape(-1, P), np.c_[J.reshape(-1, P), J1.reshape(-1, 1)]
    Q0, Q1 = np.linalg.qr(X0)[0], np.linalg.qr(X1)[0]
    w = s * J1.reshape(-1)[:, None] + rng.normal(size=(3 * N, 4000))
    rss0 = np.sum((w - Q0 @ (Q0.T @ w)) ** 2, axis=0)
    rss1 = np.sum((w - Q1 @ (Q1.T @ w)) ** 2, axis=0)
    F = (rss0 - rss1) / (rss1 / dof)
    power = float(np.mean(F > stats.f.isf(thr, 1, dof)))
    assert abs(power - 0.9) < 0.025, power


def test_the_out_of_fold_spread_is_the_folds_own_estimate(rng):
    """Per row the variance of a 3-term effect's fitted move as its fold estimates it,
    E_i S_f^-1 E_i^T, against numpy: E the effect's metric columns less what the model's
    terms give back (full data), S_f the effect's Gram beside the model's terms with unit
    priors over the rows out of fold f. The same figures whether the scoring's blocks
    (:meth:`FoldedProblem.evaluate_extended`) are handed over or formed from the columns."""
    N, P, Q = 40, 4, 3
    J, A = rng.normal(size=(N, 3, P)), rng.normal(size=(N, 3, P))
    J1, A1 = rng.normal(size=(N, 3, Q)), rng.normal(size=(N, 3, Q))
    fold = np.arange(N) % 5
    base = FoldedProblem(J, A, rng.normal(size=(N, 3)), np.zeros((N, 3)), fold)
    lin = SimpleNamespace(point_rows=np.ones(N, bool), r=np.zeros((N, 3)))
    Jf, J1f = J.reshape(-1, P), J1.reshape(-1, Q)
    E = A1 - A @ (np.linalg.inv(Jf.T @ Jf + np.eye(P)) @ (Jf.T @ J1f))
    want = np.empty(N)
    for f in range(5):
        out = np.repeat(fold != f, 3)
        a, b = Jf[out], J1f[out]
        S = b.T @ b + np.eye(Q) - (a.T @ b).T @ np.linalg.inv(a.T @ a + np.eye(P)) @ (a.T @ b)
        want[fold == f] = np.einsum("niq,qr,nir->n", E[fold == f], np.linalg.inv(S), E[fold == f])
    sight = Sight(base, lin, np.ones(N), 1.0, 3 * N - P - Q, 0.0)
    formed = sight._shape((A1, J1))
    handed = sight._shape((A1, J1), base.evaluate_extended(J1, A1))
    np.testing.assert_allclose(formed[3], want, rtol=1e-9)
    for x, y in zip(formed[1:], handed[1:]):
        np.testing.assert_allclose(x, y, rtol=1e-9)


def test_the_mean_distance_of_a_displaced_gaussian(rng):
    """E|n + a| for n ~ N(0, I_3): the closed form against 200 000 draws, and sqrt(8/pi) at 0."""
    n = rng.normal(size=(200_000, 3))
    for a in (0.0, 0.3, 1.0, 2.5):
        draws = np.linalg.norm(n + [a, 0, 0], axis=1)
        assert mean_distance(np.array([a]), 1.0)[0] == pytest.approx(draws.mean(), abs=4 * draws.std() / 447)
    assert mean_distance(np.zeros(1), 2.0)[0] == pytest.approx(2 * math.sqrt(8 / math.pi))


@pytest.mark.slow   # five small diagnoses (~4 s)
def test_a_harmonic_at_twice_the_stated_size_is_named_at_half_not(flow):
    """A per-turn harmonic of C on flow_xyzcb (60 commands): the clean campaign's
    diagnosis states the size it would detect; the same commands with the harmonic at
    twice that size name it (two seeds), at half of it not both (two seeds). The stated size is
    named with 90 % probability over the effect's shapes, so at half of it (a quarter of the
    noncentrality) the tests pass about one time in five: both seeds naming it would say the
    stated size is twice too large (p ~ 0.04). The base model is the clean one's, so the
    harmonic is judged against the model that stated the size."""
    fams = ["rotary_periodic"]
    design = Design(n_commands=60, n_validation=3)
    clean = simulate(flow, seed=0, design=design)
    d = diagnose(flow, clean.campaign, effects=fams, model="6dof", basis="chebyshev", order=4)
    fam = {f["effect"]: f for f in d.detection}["rotary_periodic"]
    size_mm = fam["per_candidate_um"]["rotary_periodic[C]"] * 1e-3
    assert 0.005 < size_mm < 0.5 and fam["rows"] == len(clean.campaign)
    plan = (clean.campaign.q, clean.campaign.tool)
    named = {}
    for k, seed in ((2.0, 1), (2.0, 2), (0.5, 1), (0.5, 2)):
        spec = TrueEffect("rotary_periodic", ("C",), k * size_mm, seed=seed + 7)
        sim = simulate(flow, seed=seed, design=design, effects=[spec], plan=plan)
        got = diagnose(flow, sim.campaign, effects=fams, base=d.base_model)
        named[(k, seed)] = "rotary_periodic[C]" in [e.label for e in got.accepted]
    assert named[(2.0, 1)] and named[(2.0, 2)], named
    assert not (named[(0.5, 1)] and named[(0.5, 2)]), named


def test_significant_means_given_the_accepted_effects(flow):
    """A skew of Y growing with X: round one finds other skews significant too; once the
    skew is accepted they are judged again with it in the model, and only effects that
    still pass are printed significant. Their figures are the final model's (before = its
    held-out mean), their first-round verdict kept in diagnosis.json."""
    spec = TrueEffect("gantry_skew", ("Y",), 0.05, {"about": "x", "depends": "X"}, seed=1)
    sim = simulate(flow, seed=1, design=Design(n_commands=80, n_validation=3), effects=[spec])
    d = diagnose(flow, sim.campaign, effects=["gantry_skew", "coupled_axes", "backlash"], model="6dof",
                 basis="chebyshev", order=4)
    acc = [e.label for e in d.accepted]
    assert "gantry_skew[Y/x]" in acc
    rest = [e for e in d.effects if not e.accepted]
    assert rest and all(e.given == acc for e in rest)
    assert all(e.heldout_mean_mm_before == pytest.approx(d.best[0]) for e in rest)
    changed = [e for e in rest if e.before_accepted["significant"] and not e.significant]
    assert changed, "the case needs an effect significant only before the accepted one"
    for e in rest:   # significant given the accepted: both tests below the threshold on these figures
        if e.significant:
            assert e.p_value < e.threshold and e.p_heldout < e.threshold
    js = d.to_dict()
    mine = {e["label"]: e for e in js["effects"]}
    for e in changed:
        assert mine[e.label]["significant"] is False and mine[e.label]["before_the_accepted_ones"]["significant"]
    table = [ln for ln in d.summary().splitlines() if ln.strip()[:1].isdigit()]
    yes = {ln.split()[1] for ln in table if ln.split()[2] == "yes"}
    assert yes <= {e.label for e in d.effects if e.accepted or e.significant}
    assert not yes & {e.label for e in changed}
    assert js["detection"] and "below detection here" in d.headline()[1]
    assert "## What this campaign could have seen" in _sight_section(d)


def test_the_next_measurement_stays_inside_the_measured_box(flow):
    """Two rival models fitted to a campaign that measured Y and Z over part of their
    travel: the discriminating plan's commands lie inside the box the campaign measured on
    every axis (no extrapolation said); asked for the whole travel, the plan names the axes
    it leaves the box on, with their measured range in mm, and says it extrapolates."""
    from vecpin.models import make_model
    from vecpin.measurement.noise import NoiseModel
    from vecpin.planning.discriminate import discriminating_plan
    first = simulate(flow, seed=4, design=Design(n_commands=40, n_validation=3))
    q = first.campaign.q.copy()
    lo, hi = flow.lower, flow.upper
    for name in ("Y", "Z"):   # measured over the middle half of their travel
        k = flow.axis_names.index(name)
        q[:, k] = lo[k] + (hi[k] - lo[k]) * (0.25 + 0.5 * (q[:, k] - lo[k]) / (hi[k] - lo[k]))
    camp = simulate(flow, seed=4, design=Design(n_commands=40, n_validation=3), plan=(q, first.campaign.tool)).campaign
    noise = NoiseModel.default(flow, "spherical")
    proto = make_model("6dof", flow, order=2)
    models = {"base": proto.fit(camp, noise),
              "coupled": proto.with_effects([TrueEffect("coupled_axes", ("X", "Y")).build(flow)]).fit(camp, noise)}
    box = camp.q.min(axis=0), camp.q.max(axis=0)
    inside = discriminating_plan(models, camp, n_min=5, n_max=8, n_pool=200)
    assert np.all(inside.q >= box[0] - 1e-12) and np.all(inside.q <= box[1] + 1e-12)
    assert not inside.beyond and "Extrapolation" not in inside.outcome()
    travel = discriminating_plan(models, camp, n_min=5, n_max=8, n_pool=200, inside=False)
    left = [flow.axis_names[k] for k in range(flow.n_axes)
            if np.any(travel.q[:, k] < box[0][k] - 1e-9) or np.any(travel.q[:, k] > box[1][k] + 1e-9)]
    assert left and list(travel.beyond) == left
    k = flow.axis_names.index(left[0])
    assert travel.beyond[left[0]][:2] == pytest.approx(tuple(flow.axes[k].to_user(box[0][k:k + 1]).tolist()
                                                             + flow.axes[k].to_user(box[1][k:k + 1]).tolist()))
    assert "Extrapolation" in travel.outcome() and f"{left[0]} beyond its measured" in travel.outcome()


def test_differences_print_in_mm_from_one_mm():
    from vecpin.planning.discriminate import length_text
    assert length_text(40.3312) == "40.3 mm" and length_text(0.0123) == "12.3 µm" and length_text(1.0) == "1.0 mm"
