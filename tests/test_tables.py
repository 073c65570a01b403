"""Compensation tables: interpolation, generation from models, effect on the true machine."""
import math

import numpy as np

from vecpin.measurement.partframe import part_frame_errors, spindle_axis
import vecpin
import pytest

from vecpin.compensation.functions import (all_table_names, from_ap_model, pitch_names, pseudo_commands,
                                           truth_as_actual)
from vecpin.compensation.tableproblem import TableProblem
from vecpin.compensation.frame import model_as_actual
from vecpin.compensation.report import CompensationReport, compensated_errors
from vecpin.models import make_model
from vecpin.measurement.noise import NoiseModel
from vecpin.simulation.simulate import simulate
from vecpin.compensation.tables import CompensationTable, TableSet

TOOLS = [0.21488, 0.31286]


@pytest.fixture(scope="module")
def fitted(machines):
    flow = machines["flow_xyzcb"]
    sim = simulate(flow, seed=0, mean_error_mm=0.65)
    noise = NoiseModel.default(flow, "spherical")
    return sim, {k: make_model(k, flow, 6).fit(sim.campaign, noise) for k in ("ap", "6dof")}


def test_linear_interpolation_is_eq14_and_ends_hold():
    t = CompensationTable("X", "Y", start=0.0, step=0.5, values=np.array([0.0, 1e-5, -2e-5, 4e-5]))
    q = np.array([-1.0, 0.0, 0.25, 0.5, 0.9, 1.5, 9.0])
    # eq. 14 by hand: t_{j-1} + (t_j - t_{j-1}) (q - q_{j-1}) / (q_j - q_{j-1})
    expected = [0.0, 0.0, 0.5e-5, 1e-5, 1e-5 + (-3e-5) * 0.8, 4e-5, 4e-5]
    np.testing.assert_allclose(t(q), expected, atol=1e-15)
    assert t.name == "yx" and not t.is_pitch


def test_modulo_table_repeats_every_turn():
    vals = np.sin(np.linspace(0, 2 * math.pi, 361)) * 1e-5
    t = CompensationTable("C", "X", 0.0, math.radians(1.0), vals, modulo=True)
    q = np.radians([10.5, 370.5, -349.5, 730.5])
    np.testing.assert_allclose(t(q), t(q[:1]).repeat(4), atol=1e-15)


def test_table_set_adds_tables_per_output_axis(flow):
    a = CompensationTable("X", "X", -0.01, 0.01, np.full(1000, 1e-5))
    b = CompensationTable("C", "X", -5.0, 0.01, np.full(1001, 2e-5))
    c = CompensationTable("X", "Z", -0.01, 0.01, np.full(1000, -3e-5))
    ts = TableSet(flow.axis_names, [a, b, c], 1e-4)
    q = np.array([[1.0, 0.5, 0.2, 0.1, 0.3]])
    np.testing.assert_allclose(ts.increments(q), [[3e-5, 0, -3e-5, 0, 0]], atol=1e-15)
    np.testing.assert_allclose(ts.apply(q), q + [[3e-5, 0, -3e-5, 0, 0]])
    assert ts.subset(["zx"]).names() == ["xx", "zx"]


def test_ap_tables_cancel_the_ap_model(flow, fitted):
    """eq. 17: F_AP(q + t_AP(q)) = F_n(q) to first order; 1024 points per table. (In the frame the
    fit settled in, which eq. 17 keeps: plan_tables uses it only when that is the model's reference frame.)"""
    from vecpin.compensation.frame import ReferenceFrame
    _, models = fitted
    model = models["ap"]
    tables = from_ap_model(model).discretise(1024)
    q = pseudo_commands(flow, 500, seed=4)
    tool = np.tile(TOOLS, 250)
    raw = model_as_actual(model, frame=ReferenceFrame(np.eye(3), np.zeros(3), "the fit's own frame"))
    before = np.linalg.norm(compensated_errors(raw, flow, None, q, tool), axis=1)
    after = np.linalg.norm(compensated_errors(raw, flow, tables, q, tool), axis=1)
    assert before.mean() > 0.3e-3
    assert after.max() < 2e-6
    assert tables.gauge_offset_change == pytest.approx(model.b_[0])


def test_projection_matches_ap_direct_tables(flow, fitted):
    _, models = fitted
    from vecpin.compensation.frame import ReferenceFrame
    model = models["ap"]
    raw = model_as_actual(model, frame=ReferenceFrame(np.eye(3), np.zeros(3), "the fit's own frame"))
    problem = TableProblem(raw, flow, pseudo_commands(flow, 600), TOOLS, order=6)
    projected = problem.solve(all_table_names(flow)).discretise(1024)
    q = pseudo_commands(flow, 300, seed=9)
    tool = np.tile(TOOLS, 150)
    err = np.linalg.norm(compensated_errors(raw, flow, projected, q, tool), axis=1)
    assert err.max() < 5e-6


def test_tables_compensate_the_true_machine(flow, fitted):
    """Paper I Table 3 shape: both models' tables cut the true machine's mean error by
    about 90%; pitch tables alone do much less; the model predicts what the truth does."""
    sim, models = fitted
    truth = truth_as_actual(sim.truth)
    q = pseudo_commands(flow, 1000, seed=11)
    tool = np.tile(TOOLS, 500)
    report = CompensationReport()
    report.add("uncompensated", compensated_errors(truth, flow, None, q, tool))
    base = report.rows[0][1]
    for kind, model in models.items():
        problem = TableProblem(model_as_actual(model), flow, pseudo_commands(flow, 800), TOOLS, order=6)
        full = problem.solve(all_table_names(flow)).discretise(1024)
        pitch = problem.solve(pitch_names(flow)).discretise(1024)
        true_full = np.linalg.norm(compensated_errors(truth, flow, full, q, tool), axis=1).mean() * 1e3
        true_pitch = np.linalg.norm(compensated_errors(truth, flow, pitch, q, tool), axis=1).mean() * 1e3
        predicted = np.linalg.norm(compensated_errors(model_as_actual(model), flow, full, q, tool), axis=1) * 1e3
        # the model in its reference frame against the truth where its table is: as a part sees them
        misfit = np.linalg.norm(part_frame_errors(model_as_actual(model)(q, tool, False)[0],
                                                  sim.truth.tool_tip(q, tool), spindle_axis(flow)), axis=1) * 1e3
        assert true_full < 0.1 * base
        assert true_pitch > 3 * true_full
        # compensated truth = (truth - model) + compensated model, point by point
        assert true_full <= 1.02 * (misfit.mean() + predicted.mean())
        assert true_full >= 0.98 * abs(misfit.mean() - predicted.mean())


def test_linearised_problem_predicts_the_nonlinear_error(flow, fitted):
    _, models = fitted
    problem = TableProblem(model_as_actual(models["6dof"]), flow, pseudo_commands(flow, 500), TOOLS, order=6)
    names = pitch_names(flow) + ["xz", "yc", "xc"]
    rms_lin = problem.cost(names)
    tables = problem.solve(names).discretise(4096)
    e = compensated_errors(problem.actual, flow, tables, problem.q, problem.L)
    rms = math.sqrt((np.linalg.norm(e, axis=1) ** 2).mean())
    assert rms == pytest.approx(rms_lin, rel=0.05)


def test_modulo_tables_on_a_rotary_axis_past_a_turn(flow, fitted):
    """C travels 544 deg: modulo tables cover one turn and repeat; with a periodic model
    they compensate exactly like tables over the whole travel."""
    from vecpin.compensation.plan import plan_tables
    from vecpin.errors import VecpinError
    _, models = fitted
    for kind, model in models.items():
        plain = plan_tables(model, n_commands=400)
        modulo = plan_tables(model, n_commands=400, modulo_axes=["C"])
        c_tables = [t for t in modulo.tables.tables if t.input_axis == "C"]
        assert len(c_tables) == 5 and all(t.modulo for t in c_tables)
        assert all(abs(t.end - t.start - 2 * math.pi) < 1e-12 for t in c_tables)
        full_plain = [r for r in plain.report.rows if r[0].startswith("full")][0][1]
        full_modulo = [r for r in modulo.report.rows if r[0].startswith("full")][0][1]
        assert full_modulo == pytest.approx(full_plain, abs=2e-3)  # mm
    cheb = make_model("ap", flow, 4, basis="chebyshev").fit(fitted[0].campaign)
    with pytest.raises(VecpinError, match="not periodic"):
        plan_tables(cheb, n_commands=200, modulo_axes=["C"])
    with pytest.raises(VecpinError, match="only rotary axes"):
        plan_tables(cheb, n_commands=200, modulo_axes=["X"])


SHORT_Y_MM = 1500.0  # the short campaign stops here: 41% of Y's travel (-2.5 .. 2557.3 mm) never measured


@pytest.fixture(scope="module")
def short_and_full(machines):
    """One true machine (same seed) measured twice: over the whole workspace, and by a
    campaign that never goes beyond Y = 1500 mm; AP models of both."""
    from vecpin.simulation.simulate import Design
    flow = machines["flow_xyzcb"]
    noise = NoiseModel.default(flow, "spherical")
    out = {}
    for name, zones in (("full", []), ("short", [{"Y": (SHORT_Y_MM, 3000.0)}])):
        sim = simulate(flow, seed=8, design=Design(n_commands=150, n_validation=5, exclude=zones),
                       mean_error_mm=0.65)
        out[name] = (sim, make_model("ap", flow, 4).fit(sim.campaign, noise))
    return out


def test_measured_box_is_what_the_campaign_commanded(short_and_full):
    """measured_box: per axis the lowest and highest command of the model's campaign
    (read from the campaign itself); the whole travel for a model that does not record
    it and for an axis the campaign held still."""
    import copy
    from vecpin.compensation.frame import measured_box
    sim, model = short_and_full["short"]
    m = model.machine
    lo, hi = measured_box(model)
    np.testing.assert_allclose(lo, sim.campaign.q.min(axis=0), rtol=0, atol=1e-12)
    np.testing.assert_allclose(hi, sim.campaign.q.max(axis=0), rtol=0, atol=1e-12)
    assert hi[m.axis("Y").index] < SHORT_Y_MM * 1e-3
    bare = copy.copy(model)
    bare.report_ = copy.copy(model.report_)
    bare.report_.measured_range = {}
    np.testing.assert_array_equal(np.array(measured_box(bare)), [m.lower, m.upper])
    bare.report_.measured_range = dict(model.report_.measured_range, Z=[400.0, 400.0])
    z = m.axis("Z").index
    assert measured_box(bare)[0][z] == m.lower[z] and measured_box(bare)[1][z] == m.upper[z]


def test_a_campaign_short_of_an_axis_end_gives_held_tables(short_and_full):
    """A campaign that stops short of an axis end (more than 1/16 of the travel): the
    tables are finite, constant beyond the measured range (exactly: the same number at
    every point beyond), and inside the measured range they compensate the true machine
    about as well as tables from a campaign over the whole workspace."""
    from vecpin.compensation.plan import plan_tables
    from vecpin.compensation.frame import measured_box
    sim, short = short_and_full["short"]
    _, full = short_and_full["full"]
    m = short.machine
    plan_s = plan_tables(short, n_commands=600, uncertainty=False)
    plan_f = plan_tables(full, n_commands=600, uncertainty=False)
    lo, hi = measured_box(short)
    y = m.axis("Y").index
    assert plan_s.problem.hold["Y"] == (lo[y], hi[y])
    assert any(n.startswith("measured range") and "Y (" in n for n in plan_s.report.notes)
    for t in plan_s.tables.tables:
        assert np.all(np.isfinite(t.values)), t.name
        if t.input_axis in plan_s.problem.hold:
            a, b = plan_s.problem.hold[t.input_axis]
            pos = t.positions
            for side in (pos >= b, pos <= a):
                if side.any():
                    assert np.all(t.values[side] == t.values[side][0]), t.name
    q = np.tile(m.axis("X").lower, (3, m.n_axes))
    step = plan_s.tables.table("yy").step                          # from the first table point beyond the range
    q[:, y] = [hi[y] + step, 0.5 * (hi[y] + m.upper[y]), m.upper[y]]
    inc = plan_s.tables.increments(q)
    assert np.all(inc[1:] == inc[0])      # the table set as a whole: nothing changes beyond the measured Y
    # inside the measured range: the true machine through each set of tables
    qi = pseudo_commands(m, 600, seed=21, lower=lo, upper=hi)
    tool = np.tile(TOOLS, 300)
    truth = truth_as_actual(sim.truth)
    err = {k: np.linalg.norm(compensated_errors(truth, m, p.tables, qi, tool), axis=1).mean() * 1e3
           for k, p in (("short", plan_s), ("full", plan_f))}
    before = np.linalg.norm(compensated_errors(truth, m, None, qi, tool), axis=1).mean() * 1e3
    noise_mm = short.report_.residuals_mm["all"]["mean"]             # what the fit cannot tell from noise
    print(f"inside the measured range: uncompensated {before:.4f} mm, short campaign {err['short']:.4f} mm, "
          f"full campaign {err['full']:.4f} mm, fit residual {noise_mm:.4f} mm")
    assert err["short"] < 0.2 * before
    assert err["short"] <= err["full"] + 0.5 * noise_mm


def test_a_quill_along_the_tool_is_found_despite_angular_errors_of_the_head():
    """production_xyzbaw: W moves along the tool after the B and A rotaries, so a constant
    W table and a gauge-line (T_offset) change are the same correction. With mrad angular
    errors of the head the actual quill tilts off the tool; the check is on the nominal
    machine, where W's tip Jacobian column equals the tool direction exactly (closed form
    of the chain: W is the last axis, along the spindle's z). Before, the tilt hid the
    quill and the tables came with a T_offset change of tens of mm against a W table of
    the opposite sign."""
    m = vecpin.Machine.load("production_xyzbaw")
    q = pseudo_commands(m, 200, seed=3)
    kin = m.kinematics(q, 0.3, jacobian=True)
    w = m.axis("W").index
    np.testing.assert_allclose(np.abs(np.einsum("pi,pi->p", kin.jacobian[:, :, w], kin.tool_dir)), 1.0, atol=1e-12)
    model = make_model("6dof", m, 1)
    model.b_ = np.zeros(model.n_parameters)
    for name, v in {"B.ex.0": 2e-3, "A.ey.1": 1.5e-3, "A.ez.0": -1e-3, "W.dz.1": 2e-5, "X.dy.1": 3e-5}.items():
        model.b_[model.parameter_names.index(name)] = v
    problem = TableProblem(model_as_actual(model), m, q, TOOLS)
    assert problem.along_tool == ["W"] and not problem.free_gauge
    functions = problem.solve(all_table_names(m))
    assert functions.gauge_offset_change == 0.0
    # the quill's pitch table carries what the gauge change would: the compensated error is small
    after = np.linalg.norm(compensated_errors(model_as_actual(model), m, functions.discretise(256), q,
                                              np.full(len(q), TOOLS[0])), axis=1)
    before = np.linalg.norm(compensated_errors(model_as_actual(model), m, None, q, np.full(len(q), TOOLS[0])), axis=1)
    assert after.mean() < 0.2 * before.mean()


def test_a_machine_that_is_only_moved_rigidly_needs_no_tables(flow):
    """The actual machine is the nominal one turned by 1 mrad about a tilted axis and
    shifted by 0.3 mm (closed form: R tip + t, R J). Its reference lines are the nominal
    ones turned by R: in its reference frame it is the nominal machine, so the tables
    spend nothing (values at the size of the rotation's second-order term, r w^2 / 2: a
    few um at most) and the compensated error is as small. Tables fitted to the machine
    as it stands, with no rotation free, cancel the turn instead."""
    from scipy.spatial.transform import Rotation
    from vecpin.compensation.frame import in_reference_frame, reference_frame
    R = Rotation.from_rotvec(1e-3 * np.array([0.3, -0.5, 0.81]) / np.linalg.norm([0.3, -0.5, 0.81])).as_matrix()
    t = np.array([3e-4, -2e-4, 1e-4])

    def moved(q, tool, jacobian=False, point=0):
        k = flow.kinematics(q, tool, jacobian=jacobian, frame="workpiece", point=point)
        return k.tip @ R.T + t, (None if k.jacobian is None else np.einsum("ij,pjk->pik", R, k.jacobian))
    frame = reference_frame(moved, flow, TOOLS)
    np.testing.assert_allclose(frame.R, R.T, atol=1e-9)           # the turn is the frame's, found exactly
    q = pseudo_commands(flow, 300, seed=5)
    kept = in_reference_frame(moved, frame)
    tables = TableProblem(kept, flow, q, TOOLS).solve(all_table_names(flow)).discretise(256)
    assert max(np.abs(tb.values).max() for tb in tables.tables if tb.output_axis in "XYZ") < 5e-6
    assert abs(tables.gauge_offset_change) < 1e-6
    qv = pseudo_commands(flow, 200, seed=6)
    before = np.linalg.norm(compensated_errors(moved, flow, None, qv, TOOLS[0], judged="none"), axis=1)
    after = np.linalg.norm(compensated_errors(kept, flow, tables, qv, TOOLS[0]), axis=1)
    assert before.mean() > 3e-4 and after.max() < 2e-6
    seq = TableProblem(moved, flow, q, TOOLS).solve(all_table_names(flow)).discretise(256)
    assert max(np.abs(tb.values).max() for tb in seq.tables if tb.output_axis in "XYZ") > 1e-4  # what it spent


def test_the_files_shortfall_is_measured_against_what_the_tables_remove():
    """Issue 39: the first line of `vecpin tables` compared the files with the full tables
    in relative terms, so a model its full tables cancel to 0.0006 mm made files within a
    few um of it '+500 %' and a real loss '+4545 %'. The shortfall is now the share of
    what the full tables remove (mm: uncompensated, full tables, files as written)."""
    from vecpin.workflows.tables import LOST_SHARE, ROUNDING_MM, _given_up
    # degenerate full set, files 3.4 um above it: fine (the relative rule said +567 %)
    assert _given_up(0.40, 0.0006, 0.0040) is None and 0.0040 > 1.02 * 0.0006 + ROUNDING_MM
    # degenerate full set, a controller that takes 6 of 20 cross tables loses 0.027 mm of 0.40: said
    assert _given_up(0.40, 0.0006, 0.0279) == pytest.approx((0.0279 - 0.0006) / (0.40 - 0.0006))
    # an ordinary full set (trunnion_xyzac, Fanuc's 6 cross tables): 0.049 mm of 0.50 lost
    assert _given_up(0.5515, 0.0486, 0.0972) == pytest.approx(0.0966, abs=1e-3)
    # a grid that costs 1.5 % of what the tables remove, and the files' rounding (1 um): fine
    assert _given_up(0.5515, 0.0486, 0.0486 + 0.015 * 0.5029) is None
    assert _given_up(0.0030, 0.0002, 0.0011) is None
    # just over the share, and tables that remove nothing at all while the files add 5 um
    assert _given_up(0.5515, 0.0486, 0.0486 + (LOST_SHARE + 1e-3) * 0.5029) is not None
    assert _given_up(0.0100, 0.0120, 0.0170) == math.inf
