"""Real data: the public UR10 laser-tracker dataset (tests/data/ipa_ur10, PROVENANCE.md
there): the dataset reader (decimal commas, radians, time stamps out of order or rounded
away by a spreadsheet), its import on the command line, and the default fit on real
poses judged on poses it never saw, beside the nominal kinematics; a campaign of 36
poses is fitted without options, and one too small for any model is refused with how
many more poses it needs."""
import importlib.util
import json
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pytest

import vecpin
from vecpin.cli import main
from vecpin.errors import CampaignFileError, IdentifiabilityError, InputError
from vecpin.measurement.campaign import read_campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.registration import rigid_registration
from vecpin.measurement.robotaccuracy import JOINTS, read_dataset
from vecpin.selection.choice import choose_model
from vecpin.units import norm_mm

DATA = Path(__file__).resolve().parent / "data" / "ipa_ur10"
RANDOM = DATA / "random_poses_400.csv"
GRID = DATA / "grid_excerpt.csv"
EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "ur10_real_data.py"


@pytest.fixture(scope="module")
def ur10():
    return vecpin.Machine.load("ur10")


def test_reader_takes_the_file_as_published(ur10):
    """Series C: semicolons, decimal commas, joints in rad, T-Mac centre in mm, per-axis
    standard deviations; its time stamps are one rounded number, so no time column."""
    r = read_dataset(RANDOM, ur10)
    c = r.campaign
    assert len(c) == 400 and c.axis_names == list(JOINTS) == ur10.axis_names
    np.testing.assert_allclose(c.q[0], [-3.14159, -1.5708, 0.0, -1.5708, 0.0, 0.0])   # line 2, rad
    np.testing.assert_allclose(c.xyz[1], [335.14778e-3, -3134.3677e-3, -221.16088e-3])  # line 3, mm -> m
    np.testing.assert_allclose(c.tool, 0.109)
    assert c.time is None and any("rounded to a few digits by a spreadsheet ('2,02011E+13'" in n for n in r.notes)
    assert c.temperature[0] == pytest.approx(21.68000031)
    assert c.extra["std_x"][0] == pytest.approx(0.041565) and list(c.lines[:3]) == [2, 3, 4]


def test_reader_puts_series_a_in_time_order(ur10, tmp_path):
    """Series A stamps yyyymmddHHMMSS; line 1361 is 45 s earlier than the line above and
    the file's last rows were measured days before the rows above them: the campaign is
    in time order (the order of measurement), the note says which lines, and the CSV
    written by ``vecpin import`` reads back with that time column."""
    r = read_dataset(GRID, ur10)
    raw = [ln.split(";")[0] for ln in GRID.read_text().splitlines()[1:]]
    stamps = np.array([datetime.strptime(s, "%Y%m%d%H%M%S").replace(tzinfo=timezone.utc).timestamp() for s in raw])
    order = np.argsort(stamps, kind="stable")
    lines = np.array([1355 + k for k in range(11)] + [11899 + k for k in range(14)])  # lines in the source
    c = r.campaign
    np.testing.assert_array_equal(c.lines, np.arange(2, 27)[order])
    np.testing.assert_allclose(c.time, np.sort(stamps) - stamps.min())
    assert c.time[-1] == pytest.approx((datetime(2020, 7, 18, 21, 27, 57) - datetime(2020, 7, 14, 18, 36, 35))
                                       .total_seconds())
    assert lines[order][:3].tolist() == [11911, 1355, 1361]  # 14 July 18:36, then 21:37:26 and 21:37:35
    assert any("stamped earlier than the row before them (lines 8, 18" in n for n in r.notes)
    out = tmp_path / "grid.csv"
    assert main(["import", str(GRID), "--machine", "ur10", "--format", "ipa-robot-accuracy", "--out", str(out)]) == 0
    back = read_campaign(out, ur10)
    np.testing.assert_allclose(back.time, c.time)
    np.testing.assert_allclose(back.q, c.q, atol=1e-9)
    np.testing.assert_allclose(back.xyz, c.xyz, atol=1e-9)


def _edited(tmp_path, line: int, column: str, cell: str) -> Path:
    rows = [ln.split(";") for ln in RANDOM.read_text().splitlines()[:20]]
    rows[line - 1][rows[0].index(column)] = cell
    p = tmp_path / "edited.csv"
    p.write_text("\n".join(";".join(r) for r in rows) + "\n")
    return p


@pytest.mark.parametrize("line, column, cell, expected", [
    (5, "elbow_joint", "1,2x", "'1,2x' is not a number"),
    (6, "wrist_1_joint", "", "empty cell"),
    (7, "shoulder_pan_joint", "-180,0", "beyond one turn: joint angles in this dataset are radians"),
    (4, "measurement_y", "-3134.3677", "decimal point while the other cells have decimal commas"),
    (8, "Timestamp", "14.07.2020 16:39", "neither yyyymmddHHMMSS"),
    (9, "Timestamp", "20201105101500", "unlike line 2's '2,02011E\\+13'"),
])
def test_reader_refuses_bad_cells_with_file_row_and_column(ur10, tmp_path, line, column, cell, expected):
    p = _edited(tmp_path, line, column, cell)
    with pytest.raises(CampaignFileError, match=expected) as exc:
        read_dataset(p, ur10)
    assert (exc.value.path, exc.value.row, exc.value.column) == (str(p), line, column)


def test_reader_refuses_other_files_and_machines(ur10, tmp_path, capsys):
    p = tmp_path / "other.csv"
    p.write_text("Name;X;Y;Z\nP1;1,0;2,0;3,0\n")
    with pytest.raises(CampaignFileError, match="not a measurement file of the ipa-robot-accuracy dataset: the header "
                                                "has no column shoulder_pan_joint"):
        read_dataset(p, ur10)
    with pytest.raises(CampaignFileError, match="machine 'flow_xyzcb' has axes X, Y, Z, C, B .use the bundled ur10"):
        read_dataset(RANDOM, vecpin.Machine.load("flow_xyzcb"))
    with pytest.raises(InputError, match="`tool_mm` -1"):
        read_dataset(RANDOM, ur10, tool_mm=-1.0)
    assert main(["import", str(RANDOM), "--machine", "ur10", "--format", "ipa-robot-accuracy", "--plan", "p.csv",
                 "--out", str(tmp_path / "c.csv")]) == 2
    assert "--plan does not apply" in capsys.readouterr().err
    assert main(["import", str(RANDOM), "--machine", "ur10", "--tool-mm", "109", "--out", str(tmp_path / "c.csv")]) == 2
    err = capsys.readouterr().err
    assert "row 1: a measurement file of the public UR10 dataset" in err and "--format ipa-robot-accuracy" in err


def test_default_fit_of_36_poses_is_not_refused(ur10, tmp_path, capsys):
    """Poses 200-247 of the 400 (lines 202-249), every 4th held out: ``vecpin fit``
    without options on the 36 others (108 equations) was refused before ("36 rows give
    108 equations for 112 unknowns": the choice took a model the campaign cannot
    determine); now it fits the best model the campaign supports and says what it left
    out. Measured: held-out mean 6.42 mm nominal, 0.52 mm fitted (max 9.80 and 0.85 mm)."""
    c = read_dataset(RANDOM, ur10).campaign.subset(np.arange(200, 248))
    test = np.arange(48) % 4 == 3
    train, held = c.subset(~test), c.subset(test)
    vecpin.write_campaign(tmp_path / "train.csv", train, ur10)
    assert main(["fit", "ur10", str(tmp_path / "train.csv"), "--out", str(tmp_path / "m.json"), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "larger candidates left out: as many unknowns as the campaign's 108 equations or more" in out
    assert "unknowns: the tracker pose's, the instruments' and the model terms that move" in out
    model = vecpin.ErrorModel.load(tmp_path / "m.json")
    assert model.n_parameters + 6 < 108
    assert json.loads((tmp_path / "m.json").read_text())["selection"]["left_out_unsupported"] > 0
    R, t = rigid_registration(ur10.tool_tip(train.q, train.tool), train.xyz)
    nominal = norm_mm(held.xyz - (ur10.tool_tip(held.q, held.tool) @ R.T + t))
    fitted = norm_mm(model.residuals(held))
    assert fitted.mean() < 0.15 * nominal.mean() and fitted.max() < 0.15 * nominal.max()


def test_too_small_for_constant_errors_is_refused_with_the_poses_needed(ur10):
    """8 poses give 24 equations; the 6-DoF model's constant errors have 42 unknowns
    (E_0 and the model's active terms): 7 more poses give 45 equations."""
    c = read_dataset(RANDOM, ur10).campaign.subset(np.arange(8))
    with pytest.raises(IdentifiabilityError, match="8 rows give 24 equations, and the smallest model tried "
                                                   r"\(6-DoF with constant errors\) has 42 unknowns: measure at least "
                                                   "7 more poses"):
        choose_model(ur10, c, NoiseModel.default(ur10, "cartesian"), kinds=("6dof",))
    small = choose_model(ur10, c, NoiseModel.default(ur10, "cartesian"))  # the AP model's constants fit
    assert small.chosen.kind == "ap" and small.left_out > 0
    assert small.equations == 24 and "larger candidates left out" in small.table()
    every = choose_model(ur10, c, NoiseModel.default(ur10, "cartesian"), kinds=("6dof",), underdetermined=True)
    assert every.left_out == 0 and min(cand.n_terms for cand in every.candidates) > 24  # the priors decide


def test_the_example_beats_the_nominal_model_on_held_out_poses():
    """examples/ur10_real_data.py on the 400 poses, every 4th held out: the default fit's
    held-out mean is under a tenth of the nominal model's (measured 0.41 against 5.30 mm;
    max 0.91 against 10.21 mm)."""
    spec = importlib.util.spec_from_file_location("ur10_real_data", EXAMPLE)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    r, = mod.run(splits=("interleaved",), say=lambda s: None)
    assert (r["train"], r["held_out"]) == (300, 100)
    assert r["nominal_mean"] > 4.0
    assert r["fit_mean"] < 0.1 * r["nominal_mean"] and r["fit_max"] < 0.15 * r["nominal_max"]


def test_beyond_the_measured_joint_range(ur10, tmp_path):
    """The 20% of the 400 poses with the highest joint 1 angle held out: no fit saw that
    part of joint 1's range (measured over 128° of its ±360°). The default choice tries
    no series per turn on such joints, and its fit leaves 0.73 / 1.38 mm held-out mean /
    max (nominal 5.06 / 10.9 mm); the choice used to take Fourier series of 12 terms per
    turn there: 12.0 / 70.8 mm. A fixed model of that kind (AP, Fourier order 12)
    extrapolates alike (12.3 / 78.5 mm); its errors held at their values at the edge of
    the measured range, as the tables hold them, leave 0.84 / 5.30 mm. A loaded model
    holds them alike; a new fit drops the hold."""
    from vecpin.workflows.fitting import fit_campaign
    c = read_dataset(RANDOM, ur10).campaign
    test = c.q[:, 0] > np.quantile(c.q[:, 0], 0.8)
    train, held = c.subset(~test), c.subset(test)
    noise = NoiseModel.default(ur10, "cartesian")
    R, t = rigid_registration(ur10.tool_tip(train.q, train.tool), train.xyz)
    nominal = norm_mm(held.xyz - (ur10.tool_tip(held.q, held.tool) @ R.T + t))
    run = fit_campaign(ur10, train, noise)
    assert "shoulder_pan_joint" in run.choice.part_turn and "no series per turn on" in run.choice.table()
    assert not any(a.family.startswith("fourier") for a in run.choice.chosen.axes[:1])
    default = norm_mm(run.model.residuals(held))
    assert default.mean() < 0.2 * nominal.mean() and default.max() < 0.2 * nominal.max()
    model = fit_campaign(ur10, train, noise, kind="ap", basis="fourier", order=12).model
    free = norm_mm(model.residuals(held))
    assert free.mean() > nominal.mean()  # extrapolated series: worse than no model
    inside = model.residuals(train)
    model.hold_beyond_measured()
    np.testing.assert_allclose(model.range_[0], train.q.min(axis=0), rtol=1e-12)
    np.testing.assert_allclose(model.range_[1], train.q.max(axis=0), rtol=1e-12)
    np.testing.assert_allclose(model.residuals(train), inside, atol=1e-12)  # nothing changes where it was measured
    kept = norm_mm(model.residuals(held))
    assert kept.mean() < 0.25 * nominal.mean() and kept.max() < 0.6 * nominal.max()
    model.save(tmp_path / "m.json")
    back = vecpin.ErrorModel.load(tmp_path / "m.json").hold_beyond_measured()
    np.testing.assert_allclose(back.predict_tip(held.q, held.tool), model.predict_tip(held.q, held.tool), atol=1e-9)
    model.fit(c, noise)
    assert model.range_ is None


def test_evaluate_judges_one_joints_sweep_without_registering(ur10):
    """Series A's wrist_3 sweep at one position (grid lines 1357-1366: wrist_3 from -40°
    to +40°, the T-Mac on its axis), joints 1-5 at their median reading: the commanded tool
    tips are one point. A model fitted to the excerpt's 15 other poses judges them from its
    own tracker pose, registering nothing, so they are not refused for lying on a line (or
    at one point); the figures are the distances to the measured points."""
    from vecpin.workflows.evaluation import evaluate
    from vecpin.workflows.fitting import fit_campaign
    c = read_dataset(GRID, ur10).campaign
    sweep = np.zeros(len(c), bool)
    sweep[2:12] = True
    held = c.subset(sweep)
    held.q[:, :5] = np.median(held.q[:, :5], axis=0)
    tips = ur10.tool_tip(held.q, held.tool)
    assert np.ptp(tips, axis=0).max() < 1e-6  # one point: no frame could be registered on them
    model = fit_campaign(ur10, c.subset(~sweep), NoiseModel.default(ur10, "cartesian"), kind="ap", order=1).model
    ev = evaluate(model, held)
    assert ev.rows == 10 and not ev.reregistered
    R, t = model.setup_.R, model.setup_.t
    np.testing.assert_allclose(ev.uncompensated, norm_mm(held.xyz - (tips @ R.T + t)), atol=1e-9)
    assert ev.residual.mean() < ev.uncompensated.mean()


ROS_FLANGE_URDF = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base_link"/>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="wrist_3_link"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <link name="wrist_3_link"/>
  <!-- as ur_description's ur.urdf.xacro: flange +x and tool0 +z point out of the flange (wrist_3's +z) -->
  <joint name="wrist_3-flange" type="fixed"><parent link="wrist_3_link"/><child link="flange"/>
    <origin xyz="0 0.2 0" rpy="0 -1.5707963267948966 -1.5707963267948966"/></joint>
  <link name="flange"/>
  <joint name="flange-tool0" type="fixed"><parent link="flange"/><child link="tool0"/>
    <origin xyz="0 0 0" rpy="1.5707963267948966 0 1.5707963267948966"/></joint>
  <link name="tool0"/>
</robot>
"""


def test_ros_industrial_flange_points_along_x(tmp_path):
    """ROS-Industrial: ``tool0``'s +z and ``flange``'s +x point out of the flange. A tool of
    100 mm on either link lies 100 mm beyond the flange along the wrist's +z (by hand: the
    flange at (0, 0.2, 0.1) m, turned by j1 about z)."""
    p = tmp_path / "arm.urdf"
    p.write_text(ROS_FLANGE_URDF)
    q = np.array([[0.0], [0.5]])
    by_hand = np.array([[0.0, 0.2, 0.2], [-0.2 * np.sin(0.5), 0.2 * np.cos(0.5), 0.2]])
    for link, axis in (("flange", "+x"), ("tool0", "+z")):
        m = vecpin.Machine.load(p, tool_link=link)
        assert m.tool_axis_name == axis and any(f"tool along {axis} of '{link}'" in n for n in m.notes)
        np.testing.assert_allclose(m.tool_tip(q, np.full(2, 0.1)), by_hand, atol=1e-12)


def test_underdetermined_changes_nothing_for_a_determined_fit(ur10):
    """100 real poses with wrist 3 at one angle (the T-Mac lies on its axis: a campaign
    in which wrist 3 never turns), a 6-DoF model of order 1 (73 model terms, 300
    equations): determined. The data cannot tell wrist 3's order-1 terms from its
    constants; since wrist 3 stood still, the fit holds them by their priors and removes
    only the 24 terms no design could identify (by term order it removed 29). Allowing an
    underdetermined fit once judged redundancy differently for a determined fit (the
    parameters 3e-3 apart); it changes nothing."""
    from vecpin.workflows.fitting import fit_campaign
    c = read_dataset(RANDOM, ur10).campaign.subset(np.arange(100))
    c.q[:, 5] = 0.3
    noise = NoiseModel.default(ur10, "cartesian")
    plain = fit_campaign(ur10, c, noise, kind="6dof", order=1).model
    allowed = fit_campaign(ur10, c, noise, kind="6dof", order=1, underdetermined=True).model
    assert plain.n_parameters + 6 < 3 * len(c)
    assert len(plain.report_.removed) == 24 and allowed.report_.removed == plain.report_.removed
    np.testing.assert_allclose(allowed.b_, plain.b_, atol=1e-12)
    np.testing.assert_allclose(allowed.residuals(c), plain.residuals(c), atol=1e-12)
