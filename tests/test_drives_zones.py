"""Twin-drive axes (seed Section 2.5: the Master Mill's X with AX1 leading and AX8
following, 30 tables) and zones (Section 2.6, Table 2.12: East/West).

Independent truths: the seed's table count (25 + 5), the geometry of a beam whose two
drives move apart (closed form), the profile and zone texts a user writes."""
import json

import numpy as np
import pytest

from vecpin.compensation.plan import plan_tables
from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.errors import InputError
from vecpin.export import drives
from vecpin.export.profile import ControllerProfile
from vecpin.measurement.noise import NoiseModel
from vecpin.models import ErrorModel, make_model
from vecpin.models.effects.base import axis_chebyshev
from vecpin.models.effects.gantry_skew import GantrySkew
from vecpin.planning.zones import parse_zone
from vecpin.simulation.simulate import Design, simulate
from vecpin.workflows.fitting import fit_campaign
from vecpin.workflows.tables import make_tables

pytestmark = pytest.mark.slow   # a long matrix: the edit loop (-m 'not slow') leaves it to CI

SEPARATION_MM = 5200.0  # ASSUMED: the Master Mill's X drives on either side of a 4 m Y travel


def _profile(nc=False):
    axes = {"X": {"following": {}, "drive_separation_mm": [0.0, SEPARATION_MM, 0.0]}}
    if nc:
        names = {"X": "AX1", "Y": "AX2", "Z": "AX3", "C": "AX4", "A": "AX5"}
        axes = {a: {"nc_name": n, "reference_position": 0.0 if a != "Z" else 800.0} for a, n in names.items()}
        axes["X"] |= {"following": {"nc_name": "AX8", "reference_position": 0.0},
                      "drive_separation_mm": [0.0, SEPARATION_MM, 0.0]}
    return ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1, "axes": axes})


@pytest.fixture(scope="module")
def skewed_model(machines):
    """An AP model of the Master Mill with a gantry skew of X about z, fitted on a small
    simulated campaign, then given known skew parameters."""
    m = machines["master_mill"]
    sim = simulate(m, seed=3, design=Design(n_commands=80, n_validation=5))
    model = make_model("ap", m, 2, effects=[GantrySkew(m, ("X",), about="z")])
    model.fit(sim.campaign, NoiseModel.default(m, "spherical"))
    (_, sl), = model.effect_slices()
    model.b_[sl] = np.linspace(-40e-6, 30e-6, sl.stop - sl.start)
    return model


def test_profile_reads_and_writes_twin_drives():
    p = _profile(nc=True)
    x = p.axis("X")
    assert x.following.nc_name == "AX8" and x.drive_separation_mm == (0.0, SEPARATION_MM, 0.0)
    back = ControllerProfile.from_dict(json.loads(json.dumps(p.to_dict())))
    assert back.axis("X") == x and drives.twin_axes(back) == ["X"]
    bad = {"format": "vecpin-controller-profile", "version": 1}
    for axes, msg in (({"X": {"drive_separation_mm": [1, 2]}}, r"\[dx, dy, dz\]"),
                      ({"X": {"following": {"speed": 3}}}, "following.speed"),
                      ({"X": {"following": "AX8"}}, "following drive's facts")):
        with pytest.raises(InputError, match=msg):
            ControllerProfile.from_dict(bad | {"axes": axes})


def test_profile_refuses_a_rotary_twin_and_a_separation_without_drive(machines):
    m = machines["master_mill"]
    for axes, msg in (({"C": {"following": {}}}, "rotary"), ({"X": {"drive_separation_mm": [0, 1, 0]}}, "following")):
        p = ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1, "axes": axes})
        with pytest.raises(InputError, match=msg):
            p.check_machine(m, "generic")


def test_thirty_tables_for_the_master_mill(skewed_model, tmp_path):
    """25 tables of a 5-axis machine, plus the 5 that correct X for the following drive:
    the seed's 30 (Section 2.5); the Siemens files hold the following drive's pitch table
    and its straightness tables under its own NC name."""
    run = make_tables(skewed_model, tmp_path / "g", "generic", profile=_profile(), uncertainty=False)
    assert len(run.plan.tables.tables) == 25
    lines = (tmp_path / "g" / "tables_drives.csv").read_text().splitlines()
    names = {ln.split(",")[0] for ln in lines[1:] if not ln.startswith("#")}
    assert len(names) == 30 and {"x2x2", "x2y", "x2z", "x2c", "x2a"} <= names
    assert "AX8" not in (tmp_path / "g" / "DRIVES.md").read_text() and "X2" in (tmp_path / "g" / "DRIVES.md").read_text()
    run = make_tables(skewed_model, tmp_path / "s", "siemens-840d", profile=_profile(nc=True), uncertainty=False)
    cec = (tmp_path / "s" / "NC_CEC.INI").read_text()
    eec = (tmp_path / "s" / "AX_EEC.INI").read_text()
    # 20 cross tables + 4 for the following drive, 5 pitch tables + the following drive's
    assert cec.count("$AN_CEC_OUTPUT_AXIS") == 24 and cec.count("$AN_CEC_OUTPUT_AXIS[") == 24 and "=(AX8)" in cec
    assert eec.count("$AA_ENC_COMP_STEP") == 6 and "$AA_ENC_COMP_STEP[0,AX8]" in eec
    assert run.as_written is not None and len(run.as_written.tables) == 25  # folded back to the machine's axes


def test_a_controller_with_six_cross_tables_gets_the_best_six_counting_both_drives(machines, tmp_path):
    """Fanuc 30i holds 6 cross tables: the tables on X are loaded for both drives, so the
    choice counts them twice and is made again until the files fit (it used to stop with
    '8 cross tables > 6' and write nothing)."""
    m = machines["master_mill"]
    sim = simulate(m, seed=3, design=Design(n_commands=80, n_validation=5))
    model = make_model("ap", m, 2).fit(sim.campaign, NoiseModel.default(m, "spherical"))
    names = {"X": 1, "Y": 2, "Z": 3, "C": 4, "A": 5}
    axes = {a: {"number": n, "reference_position": 0.0 if a != "Z" else 800.0, "detection_unit": 0.001}
            for a, n in names.items()}
    axes["X"] |= {"following": {"number": 8, "reference_position": 0.0, "detection_unit": 0.001},
                  "drive_separation_mm": [0.0, SEPARATION_MM, 0.0]}
    prof = ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1, "axes": axes})
    run = make_tables(model, tmp_path, "fanuc-30i", profile=prof, uncertainty=False)
    cross = [t for t in run.plan.tables.tables if not t.is_pitch]
    on_drives = len(cross) + sum(t.output_axis == "X" for t in cross)
    assert on_drives <= 6 and len(cross) >= 3
    straight = (tmp_path / "STRAIGHTNESS.CSV").read_text()
    assert len({ln.split(",")[0] for ln in straight.splitlines()[2:]}) == on_drives


def test_skew_differential_is_half_the_separation_times_the_angle(skewed_model):
    """The differential tables: leading drive +k theta, following -k theta with
    k = (w x s) . x / 2 = -S/2 for a yaw (w = z) of an X gantry whose drives are S apart
    along y. Moving the drives so turns the beam by -theta: the skew is cancelled."""
    m = skewed_model.machine
    tables, taken, notes = drives.skew_differential(skewed_model, _profile(), 201)
    assert len(taken) == 1 and [t.input_axis for t in tables["X"]] == ["Y", "Z", "C", "A"]
    (eff, sl), = skewed_model.effect_slices()
    theta = skewed_model.b_[sl]
    S = SEPARATION_MM * 1e-3
    for j, t in enumerate(tables["X"]):
        q = np.zeros((len(t.values), m.n_axes))
        q[:, m.axis(t.input_axis).index] = t.positions
        angle = axis_chebyshev(m, t.input_axis, q, eff.order) @ theta[j * eff.order:(j + 1) * eff.order]
        lead, follow = t.values, -t.values
        # drives at y = -S/2 (leading) and +S/2 (following): a turn phi about z moves them by -phi*y along x
        phi = -(follow - lead) / S
        np.testing.assert_allclose(phi, -angle, atol=1e-15)
        np.testing.assert_allclose(lead, -S / 2 * angle, atol=1e-15)
    assert "differential" in " ".join(notes)


def test_expand_and_fold(machines):
    m = machines["master_mill"]
    ts = TableSet(m.axis_names, [CompensationTable("X", "X", -8.0, 0.1, np.linspace(0, 1e-5, 161)),
                                 CompensationTable("Y", "X", -2.0, 0.1, np.linspace(0, 2e-6, 41)),
                                 CompensationTable("X", "Y", -8.0, 0.1, np.linspace(0, 3e-6, 161))])
    diff = {"X": [CompensationTable("Y", "X", -2.0, 0.1, np.full(41, 5e-6))]}
    xt, xm, xp = drives.expand(ts, m, _profile(), diff)
    assert xm.axis_names[-1] == "X2" and xm.axis("X2").lower == m.axis("X").lower
    byname = {t.name: t for t in xt.tables}
    assert set(byname) == {"xx", "xy", "yx", "x2x2", "x2y"}
    np.testing.assert_allclose(byname["xy"].values - byname["x2y"].values, 1e-5)  # +d on the leading, -d following
    back = drives.fold(xt, m, _profile())
    for t in ts.tables:
        np.testing.assert_allclose(back.table(t.name).values, t.values, atol=1e-18)
    (d,) = back.drives  # half the difference of the drives' tables: the differential
    assert [t.name for t in d.differential] == ["xy"] and d.following == "X2"
    np.testing.assert_allclose(d.differential[0].values, 5e-6, atol=1e-18)
    assert drives.fold(back, m, _profile()) is back  # already on the machine's axes (tables.json)
    one = drives.fold(TableSet(xm.axis_names, [CompensationTable("Z", "X2", -1.0, 0.5, np.full(5, 4e-6))]), m,
                      _profile())  # on the following drive only: the gantry moves by half, the drives differ by all
    np.testing.assert_allclose([one.table("xz").values, one.drives[0].differential[0].values], [[2e-6] * 5, [-2e-6] * 5])


def test_a_differential_turns_the_beam_by_minus_2d_over_the_separation(machines):
    """Closed form, by hand: drives S apart along y (leading at y = -S/2 from the beam's
    centre, following at +S/2), X along x. A differential d (leading +d, following -d)
    turns the beam about z by alpha = 2 d / S (= -2 d / |s x x| about s x x = -S z): a
    point at the following drive, r = (0, S/2, 0) from the centre, goes to
    (-S/2 sin alpha, S/2 cos alpha, 0), i.e. by -d along x to first order; a point on
    the turn axis below the centre does not move; (a, 0, 0) moves by a sin alpha in y."""
    m = machines["master_mill"]
    S, d = SEPARATION_MM * 1e-3, 40e-6
    diff = [CompensationTable("Y", "X", m.axis("Y").lower, 0.5, np.full(41, d))]
    ts = TableSet(m.axis_names, [], drives=drives.twin_drives(m, _profile(), {"X": diff}))
    q = np.clip(np.array([[0.3, 0.2, 0.1, 0.0, 0.0]]), m.lower, m.upper).repeat(4, axis=0)
    centre = m.joint_frames(q, "X")[0, :3, 3]
    np.testing.assert_allclose(m.joint_frames(q, "X")[0, :3, 0] @ m.axis("X").direction, [1, 0, 0][0], atol=1e-12)
    a, alpha = 0.7, 2 * d / S
    r = np.array([[0, S / 2, 0], [0, -S / 2, 0], [0, 0, -1.3], [a, 0, 0]])
    moved = ts.turn_tips(m, q, centre + r) - centre
    expect = np.array([[-S / 2 * np.sin(alpha), S / 2 * np.cos(alpha), 0],
                       [S / 2 * np.sin(alpha), -S / 2 * np.cos(alpha), 0],
                       [0, 0, -1.3], [a * np.cos(alpha), a * np.sin(alpha), 0]])
    np.testing.assert_allclose(moved, expect, atol=1e-15)
    np.testing.assert_allclose(moved[:2, 0] - r[:2, 0], [-d, d], rtol=1e-6)  # following -d, leading +d
    # the same through a file: tables.json keeps the drives
    back = TableSet.from_dict(json.loads(json.dumps(ts.to_dict(m))), m)
    np.testing.assert_allclose(back.turn_tips(m, q, centre + r), centre + moved, atol=1e-15)


def test_the_turn_relative_to_a_workpiece_is_the_base_frame_turn(machines):
    """On a machine with a workpiece (a trunnion), turning a tip given relative to the
    workpiece is turning it in the base frame, expressed in the workpiece frame."""
    m = machines["trunnion_xyzac"]
    diff = [CompensationTable("C", "X", m.axis("C").lower, 0.1, np.linspace(-50e-6, 50e-6, 64))]
    ts = TableSet(m.axis_names, [], drives=drives.twin_drives(m, _profile(), {"X": diff}))
    rng = np.random.default_rng(0)
    q = m.lower + rng.random((6, m.n_axes)) * (m.upper - m.lower)
    base = m.tool_tip(q, np.full(6, 0.2), frame="base")
    T = m.workpiece_pose(q)
    rel = np.einsum("pji,pj->pi", T[:, :3, :3], base - T[:, :3, 3])
    turned = ts.turn_tips(m, q, base)
    assert np.abs(turned - base).max() > 1e-6  # the turn moves the tips
    np.testing.assert_allclose(ts.turn_tips(m, q, rel, "workpiece"),
                               np.einsum("pji,pj->pi", T[:, :3, :3], turned - T[:, :3, 3]), atol=1e-13)


@pytest.fixture(scope="module")
def skewed_truth(machines):
    """A simulated Master Mill (AP-type errors of the seed's size, 0.295 mm) whose X gantry
    yaws about z with Z (a gantry skew, 0.06 mm RMS), and an AP model with the skew fitted
    to its campaign."""
    from vecpin.simulation.effects import EffectSpec
    from vecpin.simulation.truth import TrueMachine
    m = machines["master_mill"]
    skew = EffectSpec("gantry_skew", ("X",), 0.06, {"about": "z", "depends": "Z"}, seed=3)
    truth = TrueMachine.random(m, np.random.default_rng(4), mean_error_mm=0.295, family="ap")
    design = Design(n_commands=150, n_validation=100)
    sim = simulate(m, seed=4, truth=truth, effects=[skew], design=design)
    model = make_model("ap", m, 3, effects=[GantrySkew(m, ("X",), about="z")])
    model.fit(sim.campaign, NoiseModel.default(m, "spherical", tracker=truth.tracker.noise))
    return truth, skew, design, sim, model


def test_the_differential_shrinks_the_true_compensated_error(skewed_truth, tmp_path):
    """tables.json carries the differential; the simulator (``simulate --tables``) and
    ``verify`` turn the beam with it, and the true machine with its skew, commanded
    through the tables, is closer to nominal with the differential than without it
    (the same tables) and than with tables fitted to the whole model (a yaw whose lever
    is the Y carriage's place on the beam is not a sum of one-axis tables)."""
    from vecpin.simulation.floor import true_compensated_error
    from vecpin.workflows.verifying import load_tables, verify
    truth, skew, design, sim, model = skewed_truth
    m = model.machine
    make_tables(model, tmp_path / "t", "generic", profile=_profile(), uncertainty=False)
    ts, _ = load_tables(tmp_path / "t", m)
    (drive,) = ts.drives
    assert drive.axis == "X" and drive.following == "X2" and [t.input_axis for t in drive.differential] == \
        ["Y", "Z", "C", "A"]
    np.testing.assert_allclose(drive.separation, [0, SEPARATION_MM * 1e-3, 0])
    bare = TableSet(ts.axis_names, ts.tables, ts.gauge_offset_change, ts.source)  # the same without the differential
    whole = plan_tables(model, uncertainty=False).tables
    v = sim.validation
    with_d, without_d = (true_compensated_error(truth, t, v.q, v.tool) for t in (ts, bare))
    whole_mm = true_compensated_error(truth, whole, v.q, v.tool)
    assert with_d[0] < 0.9 * without_d[0] and with_d[0] < 0.9 * whole_mm[0]
    # the simulator measures the validation commands through the tables on the true machine
    runs = {k: simulate(m, seed=4, truth=truth, effects=[skew], design=design, tables=t)
            for k, t in (("with", ts), ("without", bare))}
    after = {k: verify(m, r.validation, r.compensated, model, t, "t")
             for (k, r), t in zip(runs.items(), (ts, bare))}
    assert after["with"].after.measured.mean() < 0.9 * after["without"].after.measured.mean()
    assert after["with"].after.predicted.mean() < 0.9 * after["without"].after.predicted.mean()
    # noise-free: what the simulator measured through the tables is the closed form's turn
    r = runs["with"]
    np.testing.assert_allclose(r.compensated_truth.xyz, truth.tracker.to_tracker(
        ts.turn_tips(m, ts.apply(v.q), truth.tool_tip(ts.apply(v.q), v.tool))), atol=1e-12)


def test_files_as_written_keep_the_differential(skewed_model, tmp_path):
    """Siemens files hold the differential in the leading and following drives' tables;
    read back and folded it is the differential the table set carries (to the files'
    rounding). (The Z reference position of 800 mm shifts Z's pitch table: the row with
    the reference shifts is the controller's.)"""
    run = make_tables(skewed_model, tmp_path / "s", "siemens-840d", profile=_profile(nc=True), uncertainty=False)
    (want,), (got,) = run.plan.tables.drives, run.as_written.drives
    assert [t.input_axis for t in got.differential] == [t.input_axis for t in want.differential]
    for a, b in zip(got.differential, want.differential):
        np.testing.assert_allclose(a(b.positions), b.values, atol=1e-9)
    # the whole model (with its skew) through the files read back, the drives turning the beam, is
    # compensated as well as the skew-free rest of the model through the planned tables
    rows = {r.label: r for r in run.plan.report.rows}
    full, files = rows["full tables (model-predicted)"], rows["files as written (model-predicted)"]
    assert files.mean < full.mean + 0.002 and files.max < full.max + 0.005
    assert rows["uncompensated (model)"].mean > 0.3  # registered: the rigid part of the error does not count


def test_zone_fit_records_and_restricts(machines, tmp_path):
    """--zone: the fit uses only the rows commanded in the zone, the model file keeps the
    zone, the tables are fitted (and held) in it; a zone the campaign never reached or
    too small is refused with the option's name."""
    m = machines["production_xyzbaw"]
    sim = simulate(m, seed=2, design=Design(n_commands=160, n_validation=5))
    west = parse_zone("X=11430:18415", "--zone")
    run = fit_campaign(m, sim.campaign, NoiseModel.default(m, "spherical"), kind="ap", basis="chebyshev", order=3,
                       zone=west)
    inside = sim.campaign.q[:, 0] <= 18.415
    assert run.rows_in_zone == int(inside.sum()) and run.model.report_.n_rows == int(inside.sum())
    assert run.model.report_.measured_range["X"][1] <= 18415.0
    run.model.save(tmp_path / "west.json")
    back = ErrorModel.load(tmp_path / "west.json")
    assert back.zone_ == {"X": (11430.0, 18415.0)}
    plan = plan_tables(back, uncertainty=False, n_commands=200)
    assert plan.problem.q[:, 0].max() <= 18.415 + 1e-9 and "X" in plan.problem.hold
    narrow = plan_tables(back, uncertainty=False, n_commands=200, zone=parse_zone("X=12000:13000", "--zone"))
    assert narrow.problem.q[:, 0].min() >= 12.0 - 1e-9 and narrow.problem.q[:, 0].max() <= 13.0 + 1e-9
    with pytest.raises(InputError, match="`zone`.*outside what the model's campaign measured"):
        plan_tables(back, uncertainty=False, zone=parse_zone("X=20000:21000", "--zone"))
    with pytest.raises(InputError, match="`zone` X=11430:11500: only"):
        fit_campaign(m, sim.campaign, NoiseModel.default(m), kind="ap", basis="chebyshev", order=2,
                     zone=parse_zone("X=11430:11500", "--zone"))
    with pytest.raises(InputError, match="AXIS=LO:HI"):
        parse_zone("X=1-2", "--zone")
