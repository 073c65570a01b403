"""Machine kinds through the whole pipeline (issue 14): table nests, tool targets, two tool
points, the tool tip relative to the workpiece for tables, and every new bundled machine
from a simulated campaign to tables at the floor.

Truths the tests compare against are not vecpin's fit: the simulated true machine (its
own error functions, the table floor fitted straight to it), finite differences of the
likelihood, closed forms of a target's offset, the true nest geometry."""
from itertools import combinations

import numpy as np
import pytest

import vecpin
from vecpin.compensation.plan import plan_tables
from vecpin.identification.likelihood import Likelihood
from vecpin.kinematics.axes import _bundled_path
from vecpin.measurement.campaign import Campaign, read_campaign, read_targets, write_campaign, write_targets
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.selection.choice import choose_model
from vecpin.simulation.floor import table_floor, true_compensated_error
from vecpin.simulation.judge import uncompensated_error, validation_commands, validation_error
from vecpin.simulation.simulate import Design, simulate
from vecpin.simulation.truth import TrueMachine
from vecpin.workflows.fitting import fit_campaign

pytestmark = pytest.mark.slow   # a long matrix: the edit loop (-m 'not slow') leaves it to CI

NEW_MACHINES = ["master_mill", "spar_mill_23", "production_xyzbaw", "trunnion_xyzac", "trunnion_xyzbc", "head_table_bc"]
# the whole pipeline to the floor on a gantry and a head-table here; every bundled kind, over seeds, is
# benchmarks/bench_kinds.py (the trunnions' files are judged end to end in test_controller_files_e2e.py)
TO_THE_FLOOR = ["master_mill", "head_table_bc"]
TARGETS_MM = ((0.0, 0.0, 120.0), (180.0, 40.0, 60.0), (-90.0, 170.0, 30.0))


def _noise(machine, sim):
    return NoiseModel.default(machine, "spherical", tracker=sim.truth.tracker.noise)


# tracker stations as the seed recommends for the machine: the long XYZBAW gantry's single tracker
# limited its model (seed Section 2.6: "should consider two laser tracker locations"); with one
# station its tables land at 1.13-1.23x the floor, the true error family's fit's at the same
# 1.12-1.24x (benchmarks/bench_kinds.py), so that gap is the tracker's noise, not vecpin's bases
SEED_STATIONS = {"production_xyzbaw": 2}


@pytest.mark.parametrize("name", TO_THE_FLOOR)
def test_default_fit_and_tables_reach_the_floor(machines, name):
    """simulate -> default fit (the model choice) -> tables: the noise-free validation of
    the fit (tool tip relative to the workpiece on table machines, both spindles on Spar
    Mill) is within 1.15x of a fit with the true error family's bases, the true
    compensated error of vecpin's tables within 1.15x of the best tables fitted straight
    to the true machine (the floor, issue 11's target) and within 1.05x of the tables of
    the true error family's fit (what perfect bases would give from the same data)."""
    m = machines[name]
    sim = simulate(m, seed=1, design=Design(n_validation=5, stations=SEED_STATIONS.get(name, 1)))
    noise = _noise(m, sim)
    model = fit_campaign(m, sim.campaign, noise).model
    q, tool = validation_commands(m, 200, seed=7)
    fitted = validation_error(model, sim.truth, q, tool)[0]
    oracle = make_model("6dof", m, 4, bases=sim.truth.family_bases()).fit(sim.campaign, noise)
    assert fitted <= 1.15 * validation_error(oracle, sim.truth, q, tool)[0]
    assert fitted < 0.1 * uncompensated_error(sim.truth, q, tool)
    vec = true_compensated_error(sim.truth, plan_tables(model, uncertainty=False).tables, q, tool, "reference")[0]
    floor = table_floor(sim.truth, q, tool, judged="reference").mean_mm
    assert vec <= 1.15 * floor
    oracle_tables = plan_tables(oracle, uncertainty=False).tables
    assert vec <= 1.05 * true_compensated_error(sim.truth, oracle_tables, q, tool, "reference")[0]
    assert vec < 0.5 * true_compensated_error(sim.truth, None, q, tool, "reference")[0]


def test_nests_let_a_floor_tracker_see_the_table_axes(machines):
    """A floor tracker reading only the tool cannot see a trunnion's table axes: the fit
    relative to the workpiece is barely better than the nominal machine. With three table
    nests it is at the noise level, and the fitted nests keep the true distances between
    them (distances do not depend on where the table's frame is)."""
    m = machines["trunnion_xyzac"]
    q, tool = validation_commands(m, 200, seed=7)
    out = {}
    for nests in (0, 3):
        sim = simulate(m, seed=5, design=Design(n_commands=150, nests=nests, n_validation=5))
        model = make_model("6dof", m, 4, bases=sim.truth.family_bases()).fit(sim.campaign, _noise(m, sim))
        out[nests] = validation_error(model, sim.truth, q, tool)[0]
    unc = uncompensated_error(sim.truth, q, tool)
    assert out[0] > 0.5 * unc
    assert out[3] < 0.05 * unc
    assert len(sim.campaign.nest_rows) == 3 * 150 and set(model.setup_.nests) == {"1", "2", "3"}
    for a, b in combinations(sim.nests, 2):
        d_fit = np.linalg.norm(model.setup_.nests[a] - model.setup_.nests[b])
        d_true = np.linalg.norm(sim.nests[a] - sim.nests[b])
        assert abs(d_fit - d_true) < 10e-6


def test_unknown_tool_targets_are_recovered_within_their_uncertainty(machines):
    """Three reflectors on a robot's flange, offsets unknown: the fit finds them within 3
    standard deviations of the truth. The truth in closed form: the offset plus the true
    gauge-line error along the tool axis (one tool length is the same as a shift of every
    target along the axis), with the true machine's constant errors after the last two
    wrist joints zero (a constant error transform after the last joint moves every
    target alike: the fit gives it to the targets)."""
    m = machines["ur5"]
    truth = TrueMachine.random(m, np.random.default_rng(5))
    for k in (4, 5):
        for f in truth.errors[k]:
            if f.chebyshev:
                f.chebyshev[0] = 0.0
    sim = simulate(m, seed=3, design=Design(n_commands=150, targets_mm=TARGETS_MM, n_validation=5), truth=truth)
    assert set(sim.campaign.target) == {"T1", "T2", "T3"} and not sim.campaign.targets
    model = make_model("6dof", m, 4, bases=truth.family_bases()).fit(sim.campaign, _noise(m, sim))
    assert model.report_.chi2_in_band
    for tid, offset in sim.targets.items():
        expected = offset + truth.gauge_error * m.tool_axis
        sd = np.array([model.setup_.std[f"target{tid}.{c}"] for c in "xyz"])
        assert np.all(sd > 0) and np.all(sd < 10e-6)
        assert np.all(np.abs(model.setup_.targets[tid] - expected) <= 3 * sd)


def test_off_axis_target_is_not_absorbed_into_joint_errors(machines, rng):
    """The issue's robot dataset: reflectors off the tool axis fitted as a tool length
    are refused when they are centimetres off (no machine is that far from its
    kinematics), and leave chi2 far above its band when two of them are a few
    millimetres off the axis at every pose (one alone is the 6-DoF model's constant error
    after the last joint); the same rows with the targets declared (offsets unknown)
    fit in band."""
    m = machines["ur5"]
    for offsets, refused in ((((180.0, 40.0, 60.0),), True), (((4.0, -3.0, 100.0), (-5.0, 6.0, 100.0)), False)):
        sim = simulate(m, seed=4, design=Design(n_commands=120, targets_mm=offsets, n_validation=5))
        offset = offsets[0]
        noise = _noise(m, sim)
        bases = sim.truth.family_bases()
        good = make_model("6dof", m, 4, bases=bases).fit(sim.campaign, noise)
        assert good.report_.chi2_in_band
        plain = sim.campaign.subset(np.arange(len(sim.campaign)))
        plain.target = np.full(len(plain), "", dtype=object)
        plain.tool = np.full(len(plain), offset[2] * 1e-3)  # the reflector's length along the tool, as a tool
        if refused:
            with pytest.raises(vecpin.errors.CampaignFileError, match="from the nominal tool tips"):
                make_model("6dof", m, 4, bases=bases).fit(plain, noise)
        else:
            assert make_model("6dof", m, 4, bases=bases).fit(plain, noise).report_.chi2 > 10 * good.report_.chi2


def test_likelihood_jacobian_of_nests_targets_and_stations_by_finite_differences(machines, rng):
    """The chained Jacobian (model point -> instrument, through nest positions, target
    offsets and a second station's pose) equals central differences of the residuals
    (the metric: tracker point differences in mm; the whitening is held fixed by the
    Gauss-Newton Jacobian, so the metric is the clean comparison)."""
    m = machines["trunnion_xyzac"]
    design = Design(n_commands=30, nests=2, targets_mm=TARGETS_MM[:2], stations=2, n_validation=5)
    sim = simulate(m, seed=6, design=design)
    c = sim.campaign
    model = make_model("6dof", m, 2)
    lik = Likelihood(model, c, _noise(m, sim))
    names = lik.names
    theta = rng.normal(size=lik.n_unknowns) * lik.sigma * 0.1
    ev = lik.evaluate(theta)
    assert np.all(ev.valid)  # spherical readings: three equations on every row
    pick = [names.index("E0.ex"), 6 + 3, 6 + 50, names.index("nest1.y"), names.index("nest2.z"),
            names.index("targetT1.x"), names.index("targetT2.z"), names.index("station1.dy"), names.index("station1.ez")]
    for k in pick:
        h = lik.sigma[k] * 1e-4
        tp, tm = theta.copy(), theta.copy()
        tp[k] += h
        tm[k] -= h
        fd = (lik.evaluate(tp, False).metric - lik.evaluate(tm, False).metric) / (2 * h) * lik.sigma[k]
        scale = np.abs(ev.A[:, :, k]).max()
        assert scale > 0, names[k]
        assert np.abs(fd - ev.A[:, :, k]).max() < 1e-5 * scale, names[k]


def test_spar_mill_mirrored_head_has_its_own_errors(machines, rng):
    """Spar Mill 23's second spindle hangs from the mimic joints Y_2, Z_2, A_2: the 6-DoF
    model gives each of them an error transform of its own; their terms move spindle 2
    only, by the same amount as the equal terms of head 1 move spindle 1 in the mirror."""
    m = machines["spar_mill_23"]
    model = make_model("6dof", m, 2)
    assert any(n.startswith("Y_2.") for n in model.parameter_names)
    q = m.lower + rng.random((20, m.n_axes)) * (m.upper - m.lower)
    b = np.zeros(model.n_parameters)
    J0 = model.tool_tip(q, 0.2, b, point=0).J_b
    J1 = model.tool_tip(q, 0.2, b, point=1).J_b
    head2 = [k for k, n in enumerate(model.parameter_names) if n.split(".")[0] in ("Y_2", "Z_2", "A_2")]
    head1 = [model.parameter_names.index(model.parameter_names[k].replace("_2", "", 1)) for k in head2]
    assert np.abs(J0[:, :, head2]).max() == 0 and np.abs(J1[:, :, head1]).max() == 0
    assert np.abs(J1[:, :, head2]).max() > 0.5
    # a translation along z after Z_2 lifts spindle 2 by exactly that much (frames parallel to the base)
    np.testing.assert_allclose(J1[:, :, model.parameter_names.index("Z_2.dz.0")], np.tile([0.0, 0.0, 1.0], (20, 1)),
                               atol=1e-12)


def test_ur5_as_published_gets_the_6dof_model(machines):
    """The arm's URDF as published (no 'spindle', tool link tool0 named by option) loads;
    the model choice picks 6-DoF: joint perturbations alone (AP) cannot express link
    errors of an arm, and their held-out error shows it."""
    m = vecpin.Machine.from_urdf_file(_bundled_path("ur5"), tool_link="tool0")
    assert m.tool_axis_name == "+z" and "spindle" not in m.tree.links
    sim = simulate(m, seed=2, design=Design(n_commands=200, n_validation=5))
    choice = choose_model(m, sim.campaign, _noise(m, sim))
    assert choice.chosen.kind == "6dof"
    best_ap = min(c.mean for c in choice.candidates if c.kind == "ap")
    assert best_ap > 3 * choice.chosen.mean


def test_campaign_files_with_nests_targets_and_points(machines, tmp_path):
    """Nest rows, target ids and tool points survive the CSV; a targets file gives known
    offsets; bad cells are refused with row and column."""
    m = machines["spar_mill_23"]
    sim = simulate(m, seed=1, design=Design(n_commands=20, targets_mm=TARGETS_MM[:2], n_validation=5))
    path = tmp_path / "c.csv"
    write_campaign(path, sim.campaign, m)
    back = read_campaign(path, m)
    assert list(back.target) == list(sim.campaign.target) and list(back.point) == list(sim.campaign.point)
    assert set(back.point) == {0, 1} and "spindle_2" in path.read_text()
    np.testing.assert_allclose(back.xyz, sim.campaign.xyz, atol=1e-9)
    write_targets(tmp_path / "t.csv", sim.targets)
    known = read_targets(tmp_path / "t.csv")
    assert set(known) == {"T1", "T2"} and np.allclose(known["T2"], np.array(TARGETS_MM[1]) * 1e-3)
    back.targets = known
    lik = Likelihood(make_model("ap", m, 1), back, _noise(m, sim))
    assert not any(n.startswith("target") for n in lik.names)  # known: no unknowns
    text = path.read_text().splitlines()
    text[1] = text[1].rsplit(",", 1)[0] + ",spindle_9"
    (tmp_path / "bad.csv").write_text("\n".join(text) + "\n")
    with pytest.raises(vecpin.errors.CampaignFileError, match="row 2, column 'tool_point'.*tool point 'spindle_9'"):
        read_campaign(tmp_path / "bad.csv", m)
    t = machines["trunnion_xyzac"]
    c = simulate(t, seed=1, design=Design(n_commands=10, n_validation=5)).campaign
    write_campaign(tmp_path / "n.csv", c, t)
    assert len(read_campaign(tmp_path / "n.csv", t).nest_rows) == 30
    rows = (tmp_path / "n.csv").read_text().splitlines()
    k = next(i for i, r in enumerate(rows) if ",nest," in r)
    rows[k] = rows[k].rsplit(",", 1)[0] + ","
    (tmp_path / "n2.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(vecpin.errors.CampaignFileError, match="nest row names its nest"):
        read_campaign(tmp_path / "n2.csv", t)


def test_relative_tip_of_a_model_with_tip_effects_by_finite_differences(machines, rng):
    """A model with a tip effect (gantry skew, acting in the base frame) still gives the
    tip relative to the workpiece with the right Jacobian (central differences)."""
    from vecpin.models.effects.gantry_skew import GantrySkew
    m = machines["head_table_bc"]
    model = make_model("ap", m, 2, effects=[GantrySkew(m, ("X",), about="z")])
    b = rng.normal(size=model.n_parameters) * 1e-4
    q = m.lower + rng.random((15, m.n_axes)) * (m.upper - m.lower)
    out = model.tool_tip(q, 0.2, b, frame="workpiece")
    base = model.tool_tip(q, 0.2, b, frame="base").tip
    wp = model.workpiece_points(q, out.tip, b, False).xyz
    np.testing.assert_allclose(wp, base, atol=1e-12)  # the relative tip, put back on the table, is the tip
    for k in (0, 3, model.n_parameters - 1):
        h = 1e-7
        bp, bm = b.copy(), b.copy()
        bp[k] += h
        bm[k] -= h
        fd = (model.tool_tip(q, 0.2, bp, False, frame="workpiece").tip
              - model.tool_tip(q, 0.2, bm, False, frame="workpiece").tip) / (2 * h)
        np.testing.assert_allclose(out.J_b[:, :, k], fd, atol=1e-7)


def test_subset_and_campaign_defaults():
    c = Campaign(["X"], np.zeros((4, 1)), np.zeros(4), np.zeros((4, 3)))
    assert c.plain and not c.mixed and list(c.point) == [0] * 4
    c.target[1] = "T1"
    assert not c.plain and c.subset([1, 2]).target[0] == "T1"


def test_command_line_nests_targets_zones_and_drives(tmp_path, capsys):
    """simulate --nests/--target, fit --targets/--zone/--tool-link, tables --zone with a
    twin-drive profile: the new options run end to end and say what they did."""
    from vecpin.cli import main
    t = tmp_path / "t"
    assert main(["simulate", "trunnion_xyzac", "--out", str(t), "--points", "60", "--nests", "2", "--seed", "3"]) == 0
    out = capsys.readouterr().out
    assert "+ 120 rows: 120 table nest rows (2 nests) (" in out   # no "0 more stations", no "0 ball bar rows"
    assert main(["fit", "trunnion_xyzac", str(t / "campaign.csv"), "--model", "6dof", "--basis",
                 "chebyshev", "--order", "3", "--zone", "C=-720:0", "--out", str(t / "m.json"), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "zone C=-720:0:" in out and "nest 1 (workpiece frame):" in out and "nest 2" in out
    assert main(["tables", str(t / "m.json"), "--out", str(t / "tab"), "--quiet"]) == 0
    assert "zone C=-720:0: tables fitted" in capsys.readouterr().out
    # issue 42: two nests end to end; what they cannot give (the table's pose at a command) is said, not guessed
    assert main(["evaluate", str(t / "m.json"), str(t / "validation.csv")]) == 0
    assert "fewer than three table nests" in capsys.readouterr().out
    assert main(["simulate", "trunnion_xyzac", "--truth", str(t / "truth.json"), "--validation-count", "10", "--nests", "2",
                 "--tables", str(t / "tab"), "--out", str(t / "after")]) == 0
    assert "through the tables: not judged here (fewer than three nests" in capsys.readouterr().out
    assert main(["verify", str(t / "after" / "validation.csv"), str(t / "after" / "validation_compensated.csv"),
                 "--model-file", str(t / "m.json"), "--tables", str(t / "tab")]) == 2
    assert "two give the table's place, not its turn" in capsys.readouterr().err
    r = tmp_path / "r"
    assert main(["simulate", "ur5", "--out", str(r), "--points", "60", "--target", "0,0,100", "--target",
                 "150,0,60", "--seed", "1"]) == 0
    assert (r / "targets.csv").is_file() and "T1 0.000, 0.000, 100.000" in capsys.readouterr().out
    assert main(["fit", str(_bundled_path("ur5")), str(r / "campaign.csv"), "--tool-link", "tool0", "--model", "6dof",
                 "--basis", "chebyshev", "--order", "2", "--targets", str(r / "targets.csv"),
                 "--out", str(r / "m.json"), "--quiet"]) == 0
    assert "target T" not in capsys.readouterr().out  # known targets: nothing to find
    assert main(["fit", "ur5", str(r / "campaign.csv"), "--model", "6dof", "--basis", "chebyshev", "--order", "2",
                 "--out", str(r / "m2.json"), "--quiet"]) == 0
    assert "target T2 (tool link frame):" in capsys.readouterr().out
    assert main(["fit", "trunnion_xyzac", str(t / "campaign.csv"), "--zone", "W=0:1", "--out", str(t / "x.json")]) == 2
    assert "no axis 'W'" in capsys.readouterr().err
