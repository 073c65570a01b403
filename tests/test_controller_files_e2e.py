"""What the machine gets is what vecpin predicts: the files vecpin writes for Siemens and
Fanuc, applied by controllers simulated from the vendors' documentation
(tests/controller_appliers.py: own parsers, documented rules, nothing of vecpin's
readers), on the true simulated machine (a trunnion whose X/Y/Z constants are
tool-to-rotary-centre offsets, and production_xyzbaw whose W follows the rotaries):
the true error equals that of the table set vecpin planned (within 2 %) and is far
below the uncompensated one; without the reference point data it is worse. LinuxCNC
is judged by the real controller (tests/test_linuxcnc_real.py)."""
import numpy as np
import pytest
from controller_appliers import fanuc_corrections, siemens_corrections
from linuxcnc_sim import ControllerCommands

import vecpin
from vecpin.compensation.functions import compensated_errors, truth_as_actual
from vecpin.export.profile import ControllerProfile
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.judge import validation_commands
from vecpin.simulation.simulate import Design, simulate
from vecpin.units import norm_mm
from vecpin.workflows.tables import make_tables

MACHINES = ("trunnion_xyzac", "production_xyzbaw")
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module", params=MACHINES)
def case(request):
    m = vecpin.Machine.load(request.param)
    sim = simulate(m, seed=2, design=Design(n_commands=200, n_validation=5))
    model = make_model("6dof", m, 4).fit(sim.campaign, NoiseModel.default(m, "spherical"))
    return m, sim.truth, model


def reference_positions(m) -> dict[str, float]:
    """Reference points where real machines have them: linear axes at the positive end
    (a few mm inside), rotary axes at 0 (mm/deg, machine coordinates)."""
    return {a.name: (float(a.to_user(a.upper)) - 5.0 if a.kind == "linear" else 0.0) for a in m.axes}


def siemens_profile(m):
    ref = reference_positions(m)
    return ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1, "axes": {
        a: {"nc_name": f"{a}1", "general_name": f"AX{k + 1}", "reference_position": ref[a]}
        for k, a in enumerate(m.axis_names)}}, "e2e profile")


def fanuc_profile(m):
    ref = reference_positions(m)
    return ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1, "axes": {
        a: {"number": k + 1, "reference_position": ref[a], "detection_unit": 0.001}
        for k, a in enumerate(m.axis_names)}}, "e2e profile")


def true_error(truth, m, tables, q, tool) -> float:
    return float(norm_mm(compensated_errors(truth_as_actual(truth), m, tables, q, tool)).mean())


@pytest.mark.parametrize("controller", ["siemens-840d", "fanuc-30i"])
def test_the_files_as_written_give_the_machine_what_vecpin_predicts(case, controller, tmp_path):
    m, truth, model = case
    prof = siemens_profile(m) if controller == "siemens-840d" else fanuc_profile(m)
    kw = {"max_tables": 6} if controller == "fanuc-30i" else {}
    run = make_tables(model, tmp_path, controller, profile=prof, uncertainty=False, **kw)
    q, tool = validation_commands(m, 150)
    q_user = np.column_stack([m.axes[k].to_user(q[:, k]) for k in range(len(m.axes))])
    apply = siemens_corrections if controller == "siemens-840d" else fanuc_corrections
    applied = lambda c: ControllerCommands(q, q + np.column_stack(   # noqa: E731
        [m.axes[k].to_si(c[:, k]) for k in range(len(m.axes))]), run.plan.tables.gauge_offset_change)
    planned, uncompensated = true_error(truth, m, run.plan.tables, q, tool), true_error(truth, m, None, q, tool)
    written = true_error(truth, m, applied(apply(tmp_path, m.axis_names, reference_positions(m), q_user)), q, tool)
    assert written == pytest.approx(planned, rel=0.02)
    assert written < 0.5 * uncompensated
    rows = {r.label: r for r in run.plan.report.rows}
    assert rows["files as written (model-predicted)"].mean == pytest.approx(
        [r for r in run.plan.report.rows if r.tables == len(run.plan.tables.tables)][0].mean, rel=0.02)
    if controller == "siemens-840d":             # without MD_REFP.INI the constants are lost: worse, and said
        without = true_error(truth, m, applied(siemens_corrections(tmp_path, m.axis_names, reference_positions(m),
                                                                   q_user, with_refp=False)), q, tool)
        assert without > 1.1 * written
        assert "files without the reference point data (model-predicted)" in rows
