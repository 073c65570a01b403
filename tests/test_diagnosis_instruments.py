"""The diagnosis of campaigns read by several instruments (issue 12): tracker points from
two stations, ball bar radii with tracker points, every row judged with its own
likelihood."""
import numpy as np
import pytest
from scipy import stats

from vecpin.diagnosis.diagnose import diagnose
from vecpin.diagnosis.localise import _breakdown
from vecpin.simulation.effects import TrueEffect
from vecpin.simulation.simulate import Design, simulate

pytestmark = pytest.mark.slow   # a long matrix: the edit loop (-m 'not slow') leaves it to CI

SKEW = TrueEffect("gantry_skew", ("Y",), 0.05, {"about": "x", "depends": "X"}, seed=1)


def test_skew_on_a_two_station_campaign_is_found_alone(machines):
    m = machines["flow_xyzcb"]
    sim = simulate(m, seed=10, design=Design(n_commands=200, stations=2), effects=[SKEW])
    assert set(np.unique(sim.campaign.station)) == {0, 1}
    d = diagnose(m, sim.campaign)
    assert [e.label for e in d.accepted] == ["gantry_skew[Y/x]"], [e.label for e in d.effects[:4]]
    assert not d.outlier_rows
    assert d.best[0] < 0.8 * d.base["heldout_mean_mm"]


def test_clean_ballbar_and_tracker_campaign_names_nothing(machines):
    m = machines["flow_xyzcb"]
    sim = simulate(m, seed=10, design=Design(n_commands=200, ballbar_points=120))
    ball = sim.campaign.instrument == "ballbar"
    assert ball.sum() == 120 and np.all(np.isnan(sim.campaign.xyz[ball]))
    d = diagnose(m, sim.campaign)
    assert not d.accepted and not d.outlier_rows, [e.label for e in d.accepted]
    assert all(not e.significant for e in d.effects)
    assert np.isfinite(d.best[0]) and np.isfinite(d.base["heldout_mean_mm"])


def test_localisation_counts_one_equation_on_range_rows():
    """The F tests of a breakdown count only a row's real equations: rows carrying one
    equation (a range, a radius) padded with junk in the other two give the same test
    as those rows alone (a one-way analysis of variance by hand, scipy's f_oneway)."""
    rng = np.random.default_rng(3)
    N = 240
    x = rng.uniform(0, 100, N)
    w = rng.normal(size=(N, 3))
    w[:, 0] += 0.4 * (x > 50)  # structured in the first equation
    junk = w.copy()
    junk[:, 1:] = 1e3 * rng.normal(size=(N, 2))  # padding: must not count
    valid = np.zeros((N, 3), bool)
    valid[:, 0] = True
    b = _breakdown(x, w * 1e-5, junk, 4, "x", "mm", valid=valid)
    edges = np.linspace(x.min(), x.max(), 5)
    idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, 3)
    F, p = stats.f_oneway(*[w[idx == k, 0] for k in range(4)])
    assert np.isclose(b["F_bins"], F, rtol=1e-9) and np.isclose(b["p_bins"], p, rtol=1e-6)
    # the trend test: a simple regression of the one equation on x
    lr = stats.linregress(x, w[:, 0])
    assert np.isclose(b["p_trend"], lr.pvalue, rtol=1e-6)


def test_outliers_on_a_two_station_campaign_are_named_by_file_line(machines, tmp_path):
    """Gross errors on a campaign of two stations (both stations' readings spoiled) are
    flagged exactly, before the base model is chosen, named by their line in the campaign
    file (header = line 1), and the accepted lines do not repeat their label."""
    from vecpin.measurement.campaign import read_campaign, write_campaign
    m = machines["flow_xyzcb"]
    spec = TrueEffect("outliers", (), 0.5, {"fraction": 0.01}, seed=6)
    sim = simulate(m, seed=10, design=Design(n_commands=200, stations=2), effects=[spec])
    path = tmp_path / "campaign.csv"
    write_campaign(path, sim.campaign, m)
    c = read_campaign(path, m)
    d = diagnose(m, c)
    flagged = np.asarray(d.outlier_rows)
    # the rows the simulation spoiled, on both stations: the same seed without the gross errors differs there only
    clean = simulate(m, seed=10, design=Design(n_commands=200, stations=2)).campaign
    simulated = np.flatnonzero(np.linalg.norm(sim.campaign.xyz - clean.xyz, axis=1) > 0.1e-3).tolist()
    assert flagged.tolist() == simulated and len(simulated) >= 2
    assert set(sim.campaign.station[simulated]) == {0, 1}
    lines = path.read_text().splitlines()
    assert d.outlier_lines == [int(c.lines[r]) for r in flagged]
    for r, ln in zip(flagged, d.outlier_lines):  # the line holds that row's reading
        assert f"{c.xyz[r, 0] * 1e3:.6f}" in lines[ln - 1]
    assert not [e for e in d.accepted if e.name != "outliers"]
    text = d.summary()
    assert "0-based" not in text and f"file lines {d.outlier_lines[0]}" in text
    for e in d.accepted:
        line = next(s for s in text.splitlines() if s.startswith(f"accepted: {e.headword}"))
        assert line.count(e.label) == 1, line


def test_row_dependent_effects_act_on_every_station_of_a_simulated_campaign(machines):
    """The program runs again for each further station: backlash (set by the approach
    direction, the same in every run) moves station 1's readings exactly as it moves
    station 0's. Same seed with and without the effect: the noise is the same, so the
    difference is the effect alone, and its size per row is frame-free (a rotation
    between the stations' frames keeps lengths)."""
    m = machines["flow_xyzcb"]
    design = Design(n_commands=40, n_validation=5, stations=2)
    plain = simulate(m, seed=21, design=design).campaign
    spec = TrueEffect("backlash", ("X",), 0.04, seed=2)
    lost = simulate(m, seed=21, design=design, effects=[spec]).campaign
    d = np.linalg.norm(lost.xyz - plain.xyz, axis=1)
    s0, s1 = plain.station == 0, plain.station == 1
    assert s0.sum() == s1.sum() and d[s0].max() > 1e-5
    np.testing.assert_allclose(d[s1], d[s0], atol=1e-9)
