"""Table machines end to end (issue 24): ``evaluate`` and ``verify`` judge the tool tip
relative to the table from the validation run's tool and nest rows; ``simulate`` writes
those rows on every table machine, the all-table ``xyzac_trt`` included; a campaign that
cannot identify the table axes is warned about, nest rows without a table refused.

The yardsticks are not vecpin's evaluation: the simulated true machine's own tip
relative to its table (its error functions through its error frames), the nominal tip
from the hand-derived closed forms (tests/closed_forms.py), and the truth commanded
through the tables."""
import json
import warnings

import numpy as np
import pytest

from closed_forms import MACHINES as CLOSED_FORMS
from vecpin.cli.main import main
from vecpin.errors import CampaignFileError, InputError, VecpinWarning
from vecpin.measurement.campaign import read_campaign, write_campaign
from vecpin.measurement.features import Features
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.registration import registered_errors
from vecpin.measurement.tableframe import table_campaign_notes
from vecpin.models import ErrorModel, make_model
from vecpin.models.effects.backlash import Backlash
from vecpin.planning.nests import VALIDATION_READS
from vecpin.simulation.effects import TrueEffect
from vecpin.simulation.floor import true_compensated_error
from vecpin.simulation.simulate import Design, simulate
from vecpin.simulation.truth import TrueMachine
from vecpin.workflows.evaluation import TABLE_FRAME, TRACKER_FRAME, evaluate
from vecpin.workflows.fitting import fit_campaign
from vecpin.workflows.verifying import verify

TABLE_MACHINES = ["trunnion_xyzac", "trunnion_xyzbc", "head_table_bc", "xyzac_trt"]


def _mean(d):
    return float(np.linalg.norm(d, axis=1).mean())


def _truth_errors(truth, model, run):
    """(uncompensated, model) mean [mm] from the truth alone: the nominal tip from the
    closed form, the true tip relative to the true table (with the run's approach
    directions), the model's relative to its table; each registered rigidly."""
    c = run.primary()
    feats = Features.from_campaign(run).subset(run.tracker_rows)
    true = truth.tool_tip(c.q, c.tool, feats, frame="workpiece")
    nominal = CLOSED_FORMS[truth.machine.name][0][0](c.q, c.tool)
    mod = model.tool_tip(c.q, c.tool, model.b_, jacobian=False, features=feats if model.effects else None,
                         frame="workpiece").tip
    return _mean(registered_errors(nominal, true)) * 1e3, _mean(registered_errors(mod, true)) * 1e3


@pytest.mark.parametrize("name", TABLE_MACHINES)
def test_simulated_validation_reads_the_nests_and_evaluate_judges_the_tip_relative_to_the_table(machines, name):
    """Every table machine's validation run reads the tool and the table nests at each
    command; evaluate's figures on the noise-free run are the truth's own tip-relative-
    to-table errors (uncompensated and the model's) within 1 %, and on the same run
    without its nest rows it judges at the tool with a first warning."""
    m = machines[name]
    sim = simulate(m, seed=3, design=Design(n_commands=120, n_validation=30))
    v = sim.validation_truth
    reads = VALIDATION_READS  # each point read this many times in a row at its standstill, judged as their mean
    assert len(v.nest_rows) == 3 * 30 * reads and len(v.tracker_rows) == 30 * reads
    assert set(v.target[v.nest_rows]) == set(sim.nests)
    model = make_model("6dof", m, 4, bases=sim.truth.family_bases()).fit(
        sim.campaign, NoiseModel.default(m, "spherical", tracker=sim.truth.tracker.noise))
    ev = evaluate(model, v)
    unc, mod = _truth_errors(sim.truth, model, v)
    assert ev.frame == TABLE_FRAME and ev.rows == 30 and not ev.warnings
    assert ev.uncompensated.mean() == pytest.approx(unc, rel=0.01)
    assert ev.residual.mean() == pytest.approx(mod, rel=0.01)
    if name == "xyzac_trt":  # the tool stands still: nothing to judge without the nests
        with pytest.raises(CampaignFileError, match="stands still"):
            evaluate(model, v.subset(v.tracker_rows))
        return
    tool_only = evaluate(model, v.subset(v.tracker_rows))
    assert tool_only.frame == TRACKER_FRAME and tool_only.warnings[0].startswith("WARNING: ")
    assert "no nest rows" in tool_only.warnings[0] and ", ".join(m.table_axes) in tool_only.warnings[0]


def test_backlash_of_the_table_axis_shows_in_evaluate(machines):
    """Backlash on the trunnion's A moves the part, not the tool: at the tool the model
    without backlash and the one with it read alike, relative to the table evaluate sees
    the difference, and its figures are the truth's (approach directions of the run)."""
    m = machines["trunnion_xyzac"]
    sim = simulate(m, seed=10, design=Design(n_commands=200, n_validation=60),
                   effects=[TrueEffect("backlash", ("A",), 0.03, seed=2)])
    noise = NoiseModel.default(m, "spherical", tracker=sim.truth.tracker.noise)
    plain = make_model("6dof", m, 4, bases=sim.truth.family_bases()).fit(sim.campaign, noise)
    with_b = make_model("6dof", m, 4, bases=sim.truth.family_bases(), effects=[Backlash(m, ("A",))]).fit(
        sim.campaign, noise)
    v = sim.validation_truth
    table = {k: evaluate(mod, v) for k, mod in (("plain", plain), ("backlash", with_b))}
    tool = {k: evaluate(mod, v.subset(v.tracker_rows)) for k, mod in (("plain", plain), ("backlash", with_b))}
    for k, mod in (("plain", plain), ("backlash", with_b)):
        assert table[k].residual.mean() == pytest.approx(_truth_errors(sim.truth, mod, v)[1], rel=0.02)
    assert table["plain"].residual.mean() > 1.5 * table["backlash"].residual.mean()
    assert tool["plain"].residual.mean() < 1.1 * tool["backlash"].residual.mean()


def _scipy_rigid(p, q):
    """q - (R p + t) after the best rigid fit, by scipy (not vecpin's registration)."""
    from scipy.spatial.transform import Rotation
    cp, cq = p.mean(axis=0), q.mean(axis=0)
    R = Rotation.align_vectors(q - cq, p - cp)[0].as_matrix()
    return q - ((p - cp) @ R.T + cq)


def test_evaluate_takes_the_tracker_noise_out_like_with_like(machines):
    """On a noisy validation run the measured tip relative to the table carries the tracker
    noise through the nest registration; the truth's figure does not. Judged by code that
    is not vecpin's: the same noisy readings registered on the *true* nests (scipy, command
    by command) give evaluate's mean within 10 %; evaluate's model error net of the noise
    lies within three of its standard uncertainties of the truth's noise-free RMS, which the
    noisy figure itself misses by far."""
    from scipy.spatial.transform import Rotation
    m = machines["trunnion_xyzac"]
    sim = simulate(m, seed=5, design=Design(n_commands=150, n_validation=150))
    model = make_model("6dof", m, 4, bases=sim.truth.family_bases()).fit(
        sim.campaign, NoiseModel.default(m, "spherical", tracker=sim.truth.tracker.noise))
    v = sim.validation
    ev = evaluate(model, v)
    tips, rows = [], []
    k = VALIDATION_READS  # the simulated run: each command's tool read k times, then each of its 3 nests k times
    for start in range(0, len(v), 4 * k):
        tool, nest = np.arange(start, start + k), np.arange(start + k, start + 4 * k).reshape(3, k)
        assert np.all(v.instrument[tool] == "tracker") and np.all(v.instrument[nest] == "nest")
        P = np.array([sim.nests[str(v.target[n[0]])] for n in nest])
        Q = v.xyz[nest].mean(axis=1)  # each nest's readings averaged, as the tool's
        R = Rotation.align_vectors(Q - Q.mean(axis=0), P - P.mean(axis=0))[0].as_matrix()
        tips.append((v.xyz[tool].mean(axis=0) - Q.mean(axis=0)) @ R + P.mean(axis=0))
        rows.append(start)
    c = v.subset(np.array(rows))
    mod = model.tool_tip(c.q, c.tool, model.b_, jacobian=False, frame="workpiece").tip
    same_way = np.linalg.norm(_scipy_rigid(mod, np.array(tips)), axis=1).mean() * 1e3
    assert ev.residual.mean() == pytest.approx(same_way, rel=0.10)
    e = sim.validation_truth.primary()
    true = sim.truth.tool_tip(e.q, e.tool, None, frame="workpiece")
    mod = model.tool_tip(e.q, e.tool, model.b_, jacobian=False, frame="workpiece").tip
    truth_rms = np.sqrt(np.mean(np.sum(_scipy_rigid(mod, true) ** 2, axis=1))) * 1e3
    net = ev.net
    assert net is not None and net.rows == 150 and net.sd > 0
    assert abs(net.rms - truth_rms) < 3 * net.sd
    assert net.measured_rms > truth_rms + 3 * net.sd  # the noise the raw figure holds
    assert any(n.startswith("model error net of the measurement noise") for n in ev.notes)


@pytest.mark.slow   # an end-to-end run: kept out of the fast tier (its 180 s budget)
def test_the_all_table_machine_end_to_end(tmp_path, capsys):
    """xyzac_trt (spindle on the frame, every axis under the workpiece): simulate -> fit ->
    evaluate -> tables -> simulate through the tables -> verify on the command line.
    evaluate's figures are the truth's within 10 %, verify's compensated run is the truth
    commanded through the tables, both runs judged relative to the table."""
    s = tmp_path / "s"
    assert main(["simulate", "xyzac_trt", "--out", str(s), "--points", "150", "--seed", "2"]) == 0
    assert "the tool tips stand still" in capsys.readouterr().out
    assert main(["fit", "xyzac_trt", str(s / "campaign.csv"), "--model", "6dof", "--order", "4",
                 "--out", str(s / "model.json"), "--quiet"]) == 0
    capsys.readouterr()
    model = ErrorModel.load(s / "model.json")
    run = read_campaign(s / "validation_truth.csv", model.machine)
    truth = TrueMachine.load(s / "truth.json", model.machine)
    assert main(["evaluate", str(s / "model.json"), str(s / "validation_truth.csv"), "--json", str(s / "e.json")]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[1] == f"  frame: {TABLE_FRAME}"
    js = json.loads((s / "e.json").read_text())
    unc, mod = _truth_errors(truth, model, run)
    assert js["uncompensated"]["all"]["mean"] == pytest.approx(unc, rel=0.1)
    assert js["model_residual"]["all"]["mean"] == pytest.approx(mod, rel=0.1)
    assert mod < 0.1 * unc
    assert main(["tables", str(s / "model.json"), "--out", str(tmp_path / "t")]) == 0
    assert main(["simulate", "xyzac_trt", "--out", str(tmp_path / "c"), "--points", "150", "--seed", "2",
                 "--truth", str(s / "truth.json"), "--tables", str(tmp_path / "t")]) == 0
    capsys.readouterr()
    c = tmp_path / "c"
    assert main(["verify", str(c / "validation_truth.csv"), str(c / "validation_compensated_truth.csv"),
                 "--model", str(s / "model.json"), "--tables", str(tmp_path / "t"), "--out", str(tmp_path / "v"),
                 "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "frame of every figure: the part's frame" in out and "the tool tip relative to the table" in out
    vj = json.loads((tmp_path / "v" / "verify.json").read_text())
    from vecpin.workflows.verifying import load_tables
    tables = load_tables(tmp_path / "t", model.machine)[0]
    before = read_campaign(c / "validation_truth.csv", model.machine).primary()
    # verify judges in the machine's reference frame (the model's, from the nests it fitted): the truth there
    true_after = true_compensated_error(truth, tables, before.q, before.tool, "reference")[0]
    true_before = true_compensated_error(truth, None, before.q, before.tool, "reference")[0]
    # (within the model's own uncertainty of its reference lines: a few µrad over a metre)
    assert vj["compensated"]["measured"]["all"]["mean"] == pytest.approx(true_after, rel=0.06)
    assert vj["uncompensated"]["measured"]["all"]["mean"] == pytest.approx(true_before, rel=0.02)
    assert vj["shape_mm"]["compensated"]["mean"] == pytest.approx(
        true_compensated_error(truth, tables, before.q, before.tool, "shape")[0], rel=0.02)
    assert vj["compensated"]["predicted"]["all"]["mean"] == pytest.approx(true_after, rel=0.1)


def test_verify_compares_like_with_like(machines):
    """Both runs with nests: relative to the table; neither: at the tool with a warning
    (with a model: refused, its figures are relative to the table); one of each: refused."""
    m = machines["trunnion_xyzac"]
    sim = simulate(m, seed=4, design=Design(n_commands=100, n_validation=30))
    model = make_model("6dof", m, 3, bases=sim.truth.family_bases()).fit(
        sim.campaign, NoiseModel.default(m, "spherical", tracker=sim.truth.tracker.noise))
    v, t = sim.validation, sim.validation_truth
    both = verify(m, v, t, model=model)
    assert "relative to the table" in both.frame and both.before.predicted is not None and not both.warnings
    assert [n for n in both.notes if n.startswith("the table's face was not read")]   # no nest heights in the fit
    with pytest.raises(InputError, match="no nest rows: on trunnion_xyzac the model's figures are the tip relative"):
        verify(m, v.primary(), t.primary(), model=model)   # the model's frame is the table's: not seen at the tool
    tool = verify(m, v.primary(), t.primary())
    assert tool.warnings and "no nest rows" in tool.warnings[0] and tool.before.predicted is None
    assert tool.lines()[0] == tool.warnings[0]
    with pytest.raises(InputError, match="has nest rows and .* has none"):
        verify(m, v, t.primary(), model=model)


def _fit_warnings(m, campaign):
    with pytest.warns(VecpinWarning) as rec:
        fit_campaign(m, campaign, NoiseModel.default(m, "spherical"), kind="6dof", basis="chebyshev", order=2)
    return [str(r.message) for r in rec if issubclass(r.category, VecpinWarning)]


def test_table_campaigns_that_cannot_identify_the_table_axes_are_warned(machines):
    """No nest rows, one nest, nests on a line, a nest that moved 0.4 mm half-way: each
    named with the file and rows; a clean campaign gets no note."""
    m = machines["trunnion_xyzac"]
    sim = simulate(m, seed=2, design=Design(n_commands=100, n_validation=5))
    c = sim.campaign
    assert table_campaign_notes(m, c) == []
    assert any("no nest rows" in w and "(A, C)" in w for w in _fit_warnings(m, c.subset(c.tracker_rows)))
    one = c.subset((c.instrument == "tracker") | (c.target == "1"))
    assert any("only 1 nest(s)" in w and f"rows {one.lines[one.nest_rows[0]]}" in w for w in _fit_warnings(m, one))
    rng = np.random.default_rng(0)
    line = c.subset(np.arange(len(c)))
    for k, nid in enumerate(sorted(sim.nests)):  # three nests on one line across the table
        rows = line.nest_rows[line.target[line.nest_rows] == nid]
        line.xyz[rows] = sim.truth.measure(line.q[rows], line.tool[rows], rng, None, 0,
                                           nest=np.array([-0.1 + 0.1 * k, 0.05, 0.04]))
    assert any("lie on a line" in w for w in _fit_warnings(m, line))
    moved = c.subset(np.arange(len(c)))
    rows = moved.nest_rows[moved.target[moved.nest_rows] == "2"]
    late = rows[len(rows) // 2:]
    moved.xyz[late] = sim.truth.measure(moved.q[late], moved.tool[late], rng, None, 0,
                                        nest=sim.nests["2"] + np.array([0.4e-3, 0.0, 0.0]))
    notes = table_campaign_notes(m, moved)
    assert len(notes) == 1 and notes[0].startswith(f"{c.source}: nest 2 moved at row {moved.lines[late[0]]}")


def test_a_tilt_range_where_the_nests_were_never_read_is_warned(machines):
    """The nests hidden below 30 % of the commanded A travel (their rows dropped): the
    campaign is warned once, naming A and the three tenths of its commanded travel, whose
    edges are recounted here from the commands."""
    m = machines["trunnion_xyzac"]
    c = simulate(m, seed=2, design=Design(n_commands=100, n_validation=5)).campaign
    a = m.axis("A")
    A = c.q[:, a.index]
    lo, hi = A.min(), A.max()
    hidden = (c.instrument == "nest") & (A < lo + 0.3 * (hi - lo))
    notes = table_campaign_notes(m, c.subset(np.flatnonzero(~hidden)))
    assert len(notes) == 1 and "30 % of the commanded travel of A" in notes[0]
    e = [np.degrees(lo + k * (hi - lo) / 10) for k in range(4)]
    assert f"({e[0]:.1f}..{e[1]:.1f}, {e[1]:.1f}..{e[2]:.1f}, {e[2]:.1f}..{e[3]:.1f} deg)" in notes[0]
    assert notes[0].startswith(c.source) and "extrapolated" in notes[0]


def test_a_nest_that_moved_without_changing_its_distances_is_found_after_the_fit(machines):
    """On the head-table machine (nests far apart) nest 1 rising 0.4 mm half-way hardly
    changes its distances to the others; its residuals after the fit step."""
    m = machines["head_table_bc"]
    sim = simulate(m, seed=2, design=Design(n_commands=150, n_validation=5))
    c = sim.campaign.subset(np.arange(len(sim.campaign)))
    rows = c.nest_rows[c.target[c.nest_rows] == "1"]
    late = rows[len(rows) // 2:]
    c.xyz[late] = sim.truth.measure(c.q[late], c.tool[late], np.random.default_rng(0), None, 0,
                                    nest=sim.nests["1"] + np.array([0.0, 0.0, 0.4e-3]))
    assert table_campaign_notes(m, c) == []
    assert [w for w in _fit_warnings(m, c) if f"nest 1 moved at row {c.lines[late[0]]}: from there its residuals" in w]
    with warnings.catch_warnings(record=True) as rec:  # the same campaign before the move: no word
        warnings.simplefilter("always")
        fit_campaign(m, sim.campaign, NoiseModel.default(m, "spherical"), kind="6dof", basis="chebyshev", order=2)
    assert not [r for r in rec if "moved" in str(r.message)]


def test_nest_rows_on_a_machine_without_a_table_are_refused(flow, tmp_path, capsys):
    c = simulate(flow, seed=1, design=Design(n_commands=60, n_validation=5)).campaign
    c.instrument[4], c.target[4] = "nest", "1"  # file row 6
    write_campaign(tmp_path / "n.csv", c, flow)
    with pytest.raises(CampaignFileError, match="has no table"):
        table_campaign_notes(flow, read_campaign(tmp_path / "n.csv", flow))
    assert main(["fit", "flow_xyzcb", str(tmp_path / "n.csv"), "--out", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert "row 6" in err and "instrument" in err and "has no table" in err


def test_batched_kabsch_is_the_rigid_registration(rng):
    """Many registrations at once (the nests of every command), weighted or not, give
    what scipy's Rotation.align_vectors (an independent Kabsch) gives each, one at a time
    through register, and recover a known rotation and shift."""
    from scipy.spatial.transform import Rotation

    from vecpin.measurement.registration import kabsch, rigid_registration
    P = rng.normal(size=(4, 3)) * 0.1
    R_true = Rotation.random(6, random_state=1).as_matrix()
    t_true = rng.normal(size=(6, 3))
    Q = np.einsum("gij,kj->gki", R_true, P) + t_true[:, None] + rng.normal(size=(6, 4, 3)) * 1e-6
    for w in (None, np.array([1.0, 2.0, 0.5, 3.0])):
        R, t = kabsch(P, Q, w)
        ww = np.ones(4) / 4 if w is None else w / w.sum()
        for g in range(6):
            cp, cq = ww @ P, ww @ Q[g]
            rot, _ = Rotation.align_vectors(Q[g] - cq, P - cp, weights=ww)
            np.testing.assert_allclose(R[g], rot.as_matrix(), atol=1e-12)
            np.testing.assert_allclose(t[g], cq - rot.as_matrix() @ cp, atol=1e-12)
            R1, t1 = rigid_registration(P, Q[g], w)
            np.testing.assert_allclose(R1, R[g], atol=1e-14)
            np.testing.assert_allclose(t1, t[g], atol=1e-14)
            np.testing.assert_allclose(R[g], R_true[g], atol=1e-4)
    mirrored = Q * np.array([1.0, 1.0, -1.0])       # a reflection of the points: still a rotation
    assert np.allclose(np.linalg.det(kabsch(P, mirrored)[0]), 1.0)
