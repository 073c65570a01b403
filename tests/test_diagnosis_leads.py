"""Issue 26, diagnosis without false leads: gross errors at a stated family-wise
false-alarm rate, repeated readings that agree and rows crowded into one region told
apart from gross errors (model misfit, kept and reported as a region)."""
import numpy as np
import pytest

from vecpin.diagnosis import grosserrors
from vecpin.diagnosis.diagnose import diagnose
from vecpin.models.effects import Effect
from vecpin.simulation.effects import TrueEffect
from vecpin.simulation.simulate import Design, simulate

pytestmark = pytest.mark.slow   # a long matrix: the edit loop (-m 'not slow') leaves it to CI


def test_sidak_limit_holds_the_family_wise_rate(rng):
    """Clean chi2(3) statistics of 1,200 rows pass together about 99 % of the time,
    whatever the number of rows (the per-row limit grows with it)."""
    valid = np.ones((1200, 3), bool)
    trials = 2000
    s = rng.chisquare(3, size=(trials, 1200))
    lim = grosserrors.row_limit(valid, 1200)
    rate = np.mean((s > lim).any(axis=1))
    assert 0.003 < rate < 0.02, rate
    assert grosserrors.row_limit(valid[:1], 10_000)[0] > lim[0] > grosserrors.row_limit(valid[:1], 100)[0]


def test_a_prediction_far_from_the_data_has_a_wider_spread():
    """The statistic scales each row's held-out residual by its own predicted spread:
    the same residual at a row where the fold model extrapolates (large J M J^T) counts
    less than in the middle of the data."""
    w = np.array([[3.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    J = np.zeros((2, 3, 1))
    J[1, 0, 0] = 2.0
    s = grosserrors.prediction_statistic(w, J, np.eye(1), np.ones((2, 3), bool))
    np.testing.assert_allclose(s, [9.0, 9.0 / 5.0])
    # a range row (one equation): the padding does not count
    valid = np.array([[True, False, False]])
    s1 = grosserrors.prediction_statistic(np.array([[2.0, 7.0, 7.0]]), np.zeros((1, 3, 1)), np.eye(1), valid)
    np.testing.assert_allclose(s1, [4.0])


@pytest.mark.parametrize("seed", [1, 2])
def test_a_clean_campaign_of_1200_rows_flags_no_row(flow, seed):
    sim = simulate(flow, seed=seed, design=Design(n_commands=600, n_validation=10))
    assert len(sim.campaign) == 1200
    d = diagnose(flow, sim.campaign)
    assert d.outlier_rows == [] and d.misfit_regions == [], (d.outlier_rows, d.misfit_regions)
    assert not d.accepted


def test_repeated_readings_that_agree_are_misfit_not_gross_errors(flow):
    """A pose read three times, every reading 0.4 mm off the same way (a place the model
    cannot follow: re-measuring reads the same), and one single reading 0.4 mm off (a
    gross error): only the single reading is left out; the repeated pose is reported as
    misfit, with its file lines."""
    sim = simulate(flow, seed=3, design=Design(n_validation=10, repeat_points=6, repeat_times=2))
    c = sim.campaign
    key = np.unique(np.c_[np.round(c.q, 9), c.tool], axis=0, return_inverse=True)[1].ravel()
    count = np.bincount(key)
    pose = np.flatnonzero(key == key[np.flatnonzero(count[key] >= 3)[0]])
    single = int(np.flatnonzero(count[key] == 1)[7])
    off = np.array([3e-4, -2e-4, 2e-4])
    c.xyz[pose] += off
    c.xyz[single] += off
    d = diagnose(flow, c)
    assert d.outlier_rows == [single]
    assert [sorted(g["rows"]) for g in d.misfit_regions] == [sorted(int(r) for r in pose)]
    assert d.misfit_regions[0]["lines"] == [int(v) for v in c.lines[sorted(pose)]]
    assert "misfit, not gross errors" in d.headline()[1]
    # the single reading's advice: re-measure it where the tracker stands; agreeing readings are systematic
    advice = next(e for e in d.effects if e.name == "outliers").advice[0]
    assert f"file lines {c.lines[single]} " in advice and "systematic at those poses" in advice


def test_flagged_rows_crowded_at_one_end_of_an_axis_are_a_region(flow):
    """A systematic error growing over the last few percent of Y's travel: the rows it
    pushes beyond the noise all lie there; they are reported as a region the model does
    not fit (on Y, at the top of its travel), not as gross errors to re-measure."""
    sim = simulate(flow, seed=4, design=Design(n_validation=10))
    c = sim.campaign
    y = c.q[:, flow.axis_names.index("Y")]
    top = y > y.min() + 0.93 * np.ptp(y)
    c.xyz[top] += np.array([0.0, 0.0, 3e-3]) * ((y[top] - y[top].min()) / np.ptp(y[top]))[:, None]
    d = diagnose(flow, c)
    assert d.outlier_rows == []
    assert d.misfit_regions and d.misfit_regions[0]["axis"] == "Y"
    g = d.misfit_regions[0]
    assert len(g["rows"]) >= 3 and top[g["rows"]].mean() > 0.5  # the model's smear reaches a little below
    assert np.all((y[g["rows"]] * 1e3 >= g["from"] - 1e-6) & (y[g["rows"]] * 1e3 <= g["to"] + 1e-6))
    assert g["from"] > y.min() * 1e3 + 0.8 * np.ptp(y) * 1e3


def test_a_skew_is_named_once(flow, tmp_path):
    """A gantry skew (Y rotating about x with X) is one finding: never named again as a
    second skew or a coupled pair; where the campaign cannot tell it from another
    candidate, the two are one group, named once with the best member's shrink."""
    spec = TrueEffect("gantry_skew", ("Y",), 0.05, {"about": "x", "depends": "X"}, seed=1)
    sim = simulate(flow, seed=11, design=Design(n_validation=10), effects=[spec])
    d = diagnose(flow, sim.campaign)
    acc = [e for e in d.accepted if e.name != "outliers"]
    assert len(acc) == 1 and acc[0].label == "gantry_skew[Y/x]", [e.finding for e in acc]
    named = [acc[0].label] + acc[0].alternatives
    assert len(set(named)) == len(named)
    assert d.headline()[1].count("explains it") == 1 and acc[0].finding in d.headline()[1]
    for alt in acc[0].alternatives:  # a group member is not scored as a finding of its own
        assert alt not in [e.label for e in d.accepted]
    # the report opens with the diagnosis in three sentences, the group named in the second
    text = d.write(tmp_path)["report"].read_text().splitlines()
    assert text[2].startswith("Where:") and text[3].startswith("Which:") and text[4].startswith("What to do:")
    assert acc[0].finding in text[3] and text[5] == ""


def test_a_thermal_drift_is_named_as_thermal_alone(flow):
    spec = TrueEffect("thermal", (), 0.04, seed=3)
    sim = simulate(flow, seed=11, design=Design(n_validation=10), effects=[spec])
    d = diagnose(flow, sim.campaign)
    assert [e.label for e in d.accepted] == ["thermal[X,Y,Z]"]


def test_no_series_has_more_terms_than_its_axis_has_positions(flow):
    """An axis visited at 5 positions: the model choice offers it no basis of more than 5
    functions (constant included); harmonics are offered only on a rotary axis whose travel and positions can
    tell them from a polynomial; at 3 positions the effects' series on it are of order 2."""
    from vecpin.diagnosis.scoring import candidate_effects
    from vecpin.measurement.features import Features
    from vecpin.models.effects import Visited
    from vecpin.selection.choice import choose_model
    first = simulate(flow, seed=5, design=Design(n_validation=10))
    q, tool = first.campaign.q.copy(), first.campaign.tool.copy()
    iy = flow.axis_names.index("Y")
    lo, hi = q[:, iy].min(), q[:, iy].max()
    q[:, iy] = lo + np.round((q[:, iy] - lo) / (hi - lo) * 4) * (hi - lo) / 4
    c = simulate(flow, seed=5, design=Design(n_validation=10), plan=(q, tool)).campaign
    assert len(np.unique(np.round(c.q[:, iy], 9))) == 5
    choice = choose_model(flow, c)
    assert all(cand.axes[iy].size <= 5 for cand in choice.candidates)
    assert any(cand.axes[iy].size == 5 for cand in choice.candidates)  # the cap is offered, not more
    feats = Features.from_campaign(c)
    q3 = c.q.copy()  # Y at 3 positions: series on Y of order 2 at most
    q3[:, iy] = lo + np.round((q3[:, iy] - lo) / (hi - lo) * 2) * (hi - lo) / 2
    cands = candidate_effects(flow, feats, ["coupled_axes", "gantry_skew"], q3)
    assert {e.order for e in cands if e.name == "coupled_axes" and "Y" in e.axes} == {2}
    assert {e.order for e in cands if e.name == "coupled_axes" and "Y" not in e.axes} == {3}
    assert {e.orders["Y"] for e in cands if e.name == "gantry_skew" and e.axes[0] != "Y"} == {2}
    assert all(e.n_parameters == 12 for e in cands if e.name == "gantry_skew" and e.axes[0] == "Y")
    # harmonics 4..8 per turn: a C axis over two turns at 8 positions cannot resolve them
    ic = flow.axis_names.index("C")
    q8 = c.q.copy()
    q8[:, ic] = np.round(np.linspace(0, 7, len(q8))) * (4 * np.pi / 7) - 2 * np.pi
    assert Visited.of(flow, q8).positions["C"] == 8
    labels = [e.label for e in candidate_effects(flow, feats, ["rotary_periodic"], q8)]
    assert "rotary_periodic[C]" not in labels
    assert "rotary_periodic[C]" in [e.label for e in candidate_effects(flow, feats, ["rotary_periodic"], c.q)]


def test_an_effect_whose_fit_fails_is_not_a_finding_and_no_abort(flow, monkeypatch):
    """The nonlinear fit with an accepted effect that cannot converge (the solver's
    honest refusal) leaves that effect out with the reason; the diagnosis still returns
    (and writes) what it found, rather than dying."""
    from vecpin.errors import ConvergenceError
    from vecpin.models import ErrorModel
    real = ErrorModel.fit

    def fit(self, *a, **kw):
        if self.effects:
            raise ConvergenceError("the fit cannot lower chi2 = 7.8e5 any further (a step promised 13.2)")
        return real(self, *a, **kw)

    monkeypatch.setattr(ErrorModel, "fit", fit)
    spec = TrueEffect("backlash", ("X",), 0.03, seed=2)
    sim = simulate(flow, seed=12, design=Design(n_commands=200, n_validation=10), effects=[spec])
    d = diagnose(flow, sim.campaign, effects=["backlash"])
    assert not d.accepted
    top = d.effects[0]
    assert top.label == "backlash[X]" and top.significant and "cannot be fitted" in top.evidence


def test_readings_of_one_pose_agree_when_most_of_their_residual_is_shared(flow):
    """Two readings of a pose 2 mm off the same way that differ by 0.28 mm (far beyond the
    noise of two readings, far below their shared residual) agree: the machine there, not
    the reading. A reading whose repeat is near the model, and two readings off in
    different directions, do not."""
    sim = simulate(flow, seed=3, design=Design(n_validation=10, repeat_points=6, repeat_times=2))
    c = sim.campaign
    key = np.unique(np.c_[np.round(c.q, 9), c.tool], axis=0, return_inverse=True)[1].ravel()
    pairs = [np.flatnonzero(key == k)[:2] for k in np.unique(key) if np.sum(key == k) >= 2][:3]  # the rest read 0
    w = np.zeros((len(c), 3))
    sigma = 0.01  # mm per whitened unit
    (a1, a2), (b1, b2), (c1, c2) = pairs
    w[a1], w[a2] = np.array([2.0, 0, 0]) / sigma, np.array([2.0, 0.28, 0]) / sigma    # shared, 0.28 mm apart
    w[b1], w[b2] = np.array([0, 1.0, 0]) / sigma, np.array([0.01, 0, 0]) / sigma      # one reading off
    w[c1], w[c2] = np.array([1.0, 0, 0]) / sigma, np.array([0, 0, -1.0]) / sigma     # both off, differently
    flagged = np.array(sorted([a1, a2, b1, c1, c2]))
    agree = grosserrors.agreeing_repeats(c, flagged, w, np.ones((len(c), 3), bool), 1.0)
    assert sorted(agree) == sorted([a1, a2])


def test_backward_elimination_drops_what_the_others_explain(flow):
    """Given a real backlash on X, a backlash on Y (not there) buys nothing on held-out
    rows beyond its spread over the folds: it is the one dropped; the linearised removal
    agrees with a real refit without it; the real one survives alone."""
    from vecpin.diagnosis import diagnose as D
    from vecpin.diagnosis import scoring as S
    from vecpin.identification.folds import command_folds
    from vecpin.identification.linearised import Linearised
    from vecpin.measurement.features import Features
    from vecpin.measurement.noise import NoiseModel
    from vecpin.models.effects import parse_effect
    from vecpin.selection.choice import fixed_model
    sim = simulate(flow, seed=11, design=Design(n_validation=10), effects=[TrueEffect("backlash", ("X",), 0.03, seed=2)])
    c, noise = sim.campaign, NoiseModel.default(flow, "spherical")
    feats = Features.from_campaign(c)
    fold = command_folds(c, 5, np.random.default_rng(0))
    proto = fixed_model(flow, "6dof", "chebyshev", 6)
    bx, by = parse_effect("backlash:axes=X", flow), parse_effect("backlash:axes=Y", flow)
    lin = Linearised(proto.with_effects([bx, by]).fit(c, noise), c, noise, feats)
    ev = lin.folded(fold).evaluate()
    dropped, why = S.weakest([bx, by], lin, ev, fold)
    assert dropped is by and "spread over the folds" in why
    lo = S.without(lin, by)
    real = Linearised(proto.with_effects([bx]).fit(c, noise), c, noise, feats)
    np.testing.assert_allclose(D.distances_mm(lo, lo.folded(fold).evaluate()["heldout"]),
                               D.distances_mm(real, real.folded(fold).evaluate()["heldout"]),
                               atol=1e-4)
    lin_x = real
    assert S.weakest([bx], lin_x, lin_x.folded(fold).evaluate(), fold) is None


def test_an_instrument_shift_is_named_alone(flow):
    """The tracker knocked part-way through: one time effect, the shift, not a shift and a
    thermal drift."""
    spec = TrueEffect("instrument_shift", (), 0.05, {"at": 0.6}, seed=5)
    sim = simulate(flow, seed=11, design=Design(n_validation=10), effects=[spec])
    d = diagnose(flow, sim.campaign)
    labels = [e.label for e in d.accepted]
    assert len(labels) == 1 and labels[0].startswith("instrument_shift"), labels


class _LaggedWarmUp(Effect):
    """A truth outside vecpin's thermal form: the structure's temperature follows the air's
    through a first-order lag of ``tau_h`` hours, integrated here with fine Euler substeps
    from 0.3 K below the first reading; linear axes expand 12 ppm/K, the spindle grows
    25 µm/K plus 8 µm/K^2 (nonlinear)."""
    name = "lagged_warm_up_truth"  # not registered: never a candidate

    def __init__(self, machine, tau_h: float, **kw):
        super().__init__(machine, (), **kw)
        self.tau_s = tau_h * 3600.0

    def _warm(self, feats):
        t, air = feats.time, feats.temperature
        x, out = air[0] - 0.3, np.empty(len(t))
        for k in range(len(t)):
            for j in range(20 if k else 0):
                h = (t[k] - t[k - 1]) / 20
                x += h * (air[k - 1] + (air[k] - air[k - 1]) * (j + 0.5) / 20 - x) / self.tau_s
            out[k] = x - 20.0
        return out

    def simulate_command(self, q, feats):
        dq = np.zeros_like(q)
        for a in self.machine.axes:
            if a.kind == "linear":
                dq[:, a.index] = 12e-6 * q[:, a.index] * self._warm(feats)
        return dq * self.scale

    def simulate_tip(self, q, tip, tool_dir, feats):
        d = self._warm(feats)
        return tip + tool_dir * ((25e-6 * d + 8e-6 * d ** 2) * self.scale)[:, None]


def test_a_thermal_drift_with_lag_is_named_as_thermal_alone(flow):
    """The structure warming 3 h behind the air (and not linearly): one thermal effect, with
    the lag the data fit best, not a thermal drift plus a tracker step (without the lag
    scan this campaign was named instrument_shift alone)."""
    sim = simulate(flow, seed=12, design=Design(n_validation=10), effects=[_LaggedWarmUp(flow, 3.0, strength_mm=0.05)])
    d = diagnose(flow, sim.campaign)
    acc = [e for e in d.accepted if e.name != "outliers"]
    assert [e.label for e in acc] == ["thermal[X,Y,Z]"], [e.finding for e in acc]
    assert acc[0].effect.lag_h >= 1.0 and any("lag of about" in a for a in acc[0].advice)
