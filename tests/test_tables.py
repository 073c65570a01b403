"""Compensation tables: interpolation, generation from models, effect on the true machine."""
import math

import numpy as np
import pytest

from vecpin.compensation.functions import (CompensationReport, TableProblem, all_table_names, compensated_errors, from_ap_model,
                                 model_as_actual, pitch_names, pseudo_commands, truth_as_actual)
from vecpin.models import make_model
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.registration import registered_errors
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
    """eq. 17: F_AP(q + t_AP(q)) = F_n(q) to first order; 1024 points per table."""
    _, models = fitted
    model = models["ap"]
    tables = from_ap_model(model).discretise(1024)
    q = pseudo_commands(flow, 500, seed=4)
    tool = np.tile(TOOLS, 250)
    before = np.linalg.norm(compensated_errors(model_as_actual(model), flow, None, q, tool), axis=1)
    after = np.linalg.norm(compensated_errors(model_as_actual(model), flow, tables, q, tool), axis=1)
    assert before.mean() > 0.3e-3
    assert after.max() < 2e-6
    assert tables.gauge_offset_change == pytest.approx(model.b_[0])


def test_projection_matches_ap_direct_tables(flow, fitted):
    _, models = fitted
    model = models["ap"]
    problem = TableProblem(model_as_actual(model), flow, pseudo_commands(flow, 600), TOOLS, order=6)
    projected = problem.solve(all_table_names(flow)).discretise(1024)
    q = pseudo_commands(flow, 300, seed=9)
    tool = np.tile(TOOLS, 150)
    err = np.linalg.norm(compensated_errors(model_as_actual(model), flow, projected, q, tool), axis=1)
    assert err.max() < 5e-6


def test_tables_compensate_the_true_machine(flow, fitted):
    """Paper I Table 3 shape: both models' tables cut the true machine's mean error by
    about 90%; pitch tables alone do much less; the model predicts what the truth does."""
    sim, models = fitted
    truth = truth_as_actual(sim.truth)
    q = pseudo_commands(flow, 1000, seed=11)
    tool = np.tile(TOOLS, 500)
    report = CompensationReport()
    report.add("uncompensated", compensated_errors(truth, flow, None, q, tool, register=True))
    base = report.rows[0][1]
    for kind, model in models.items():
        problem = TableProblem(model_as_actual(model), flow, pseudo_commands(flow, 800), TOOLS, order=6)
        full = problem.solve(all_table_names(flow)).discretise(1024)
        pitch = problem.solve(pitch_names(flow)).discretise(1024)
        true_full = np.linalg.norm(compensated_errors(truth, flow, full, q, tool, register=True), axis=1).mean() * 1e3
        true_pitch = np.linalg.norm(compensated_errors(truth, flow, pitch, q, tool, register=True), axis=1).mean() * 1e3
        predicted = np.linalg.norm(compensated_errors(model_as_actual(model), flow, full, q, tool), axis=1) * 1e3
        misfit = np.linalg.norm(registered_errors(model.predict(q, tool, "machine"), sim.truth.tool_tip(q, tool)), axis=1) * 1e3
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
    from vecpin.errors import VecpinError
    from vecpin.compensation.plan import plan_tables
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
