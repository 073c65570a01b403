"""The controller boundary (issue 39): what the files need from the controller beyond loading them.

* LinuxCNC's COMP_FILEs run without the HAL component: their own report row (the
  as-written pitch tables alone, on the same points, recomputed here with the
  independent COMP_FILE applier of tests/controller_appliers.py) and a first-line warning
  when they lose most of the gain, naming the component and the pitch-only set
  (``max_tables=0``), which does work alone.
* The gauge-line (T_offset) change as a named datum per controller with its sign in
  words: the value printed (printout and README) is read back and entered with each sign
  and not at all on the true simulated machine: the printed sign is the best.
* Modulo tables: the loss of folding onto one turn beside the same tables over the whole
  travel, and the controller's alternative.

Small campaigns (120 commands) and the tables fitted on the campaign's commands keep it fast.
"""
import copy
import dataclasses
import re

import numpy as np
import pytest
from controller_appliers import linuxcnc_type0
from linuxcnc_sim import ControllerCommands

import vecpin
from vecpin.compensation.frame import model_as_actual
from vecpin.compensation.functions import truth_as_actual
from vecpin.compensation.report import compensated_errors
from vecpin.compensation.plan import unfolded_label
from vecpin.compensation.tables import TableSet
from vecpin.export.profile import ControllerProfile
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.judge import validation_commands
from vecpin.simulation.simulate import Design, simulate
from vecpin.units import norm_mm
from vecpin.workflows.tables import PART_GAIN, make_tables

N_COMMANDS = 300
ALONE = "comp files without the component (model-predicted)"


def fitted(name: str, basis: str = "auto"):
    """(machine, simulated campaign and truth, 6-DoF order-3 model) of a bundled machine."""
    m = vecpin.Machine.load(name)
    sim = simulate(m, seed=2, design=Design(n_commands=N_COMMANDS, n_validation=5))
    kw = {} if basis == "auto" else {"basis": basis}
    return m, sim, make_model("6dof", m, 3, **kw).fit(sim.campaign, NoiseModel.default(m, "spherical"))


@pytest.fixture(scope="module")
def flow():
    return fitted("flow_xyzcb")


def rows(run) -> dict:
    return {r.label: r for r in run.plan.report.rows}


def readme(run):
    return next(f for f in run.files if f.name.startswith("README_")).read_text()


# ---------------------------------------------------------------- 1. COMP_FILEs without the component
def comp_files_alone(folder, m, q):
    """The commands a LinuxCNC without the HAL component sends: the COMP_FILE trims only
    (read by the applier's own parser, type 0), as a table set stand-in."""
    q_user = np.column_stack([a.to_user(q[:, a.index]) for a in m.axes])
    trims = np.column_stack([linuxcnc_type0(folder, a.name, q_user[:, a.index]) for a in m.axes])
    return np.column_stack([a.to_si(trims[:, a.index]) for a in m.axes])


def test_comp_files_without_the_component_get_their_row_and_a_first_line_warning(flow, tmp_path):
    m, sim, model = flow
    run = make_tables(model, tmp_path / "lc", "linuxcnc", commands=sim.campaign, uncertainty=False)
    r = rows(run)
    p = run.plan.problem
    # the row is the COMP_FILEs as LinuxCNC applies them (own parser), alone, on the report's points
    stand_in = ControllerCommands(p.q, p.q + comp_files_alone(tmp_path / "lc", m, p.q),
                                  run.plan.tables.gauge_offset_change)
    alone = norm_mm(compensated_errors(model_as_actual(model), m, stand_in, p.q, p.L, point=p._pt)).mean()
    assert r[ALONE].mean == pytest.approx(alone, rel=1e-6)
    before, files = r["uncompensated (model)"].mean, r["files as written (model-predicted)"].mean
    kept = (before - alone) / (before - files)
    print(f"flow_xyzcb linuxcnc: uncompensated {before:.4f} mm, files {files:.4f} mm, comp files alone {alone:.4f} mm "
          f"({100 * kept:.0f} % of the gain), refitted pitch only {r['pitch only (model-predicted)'].mean:.4f} mm")
    assert kept < PART_GAIN               # fitted with the cross tables, they do not work alone here
    warning = run.warnings[0]
    assert run.lines("m")[0] == warning and readme(run).splitlines()[0] == warning
    assert f"{alone:.4f} mm" in warning and "HAL component" in warning and "max_tables=0" in warning
    assert "## The COMP_FILEs (comp_<AXIS>.txt) without the HAL component" in readme(run)
    # the way out the warning names: pitch tables fitted alone; no component, better than uncompensated, no warning
    pitch = make_tables(model, tmp_path / "pitch", "linuxcnc", max_tables=0, commands=sim.campaign, uncertainty=False)
    assert not (tmp_path / "pitch" / "vecpin_vec.comp").exists() and not pitch.warnings
    alone_too = norm_mm(compensated_errors(model_as_actual(model), m, ControllerCommands(
        p.q, p.q + comp_files_alone(tmp_path / "pitch", m, p.q), pitch.plan.tables.gauge_offset_change),
        p.q, p.L, point=p._pt)).mean()
    assert alone_too == pytest.approx(rows(pitch)["files as written (model-predicted)"].mean, rel=1e-6)
    assert alone_too < 0.8 * before and alone_too < alone


def test_no_warning_where_the_comp_files_carry_the_gain(flow, tmp_path):
    """A machine whose only errors are pitch errors of X and Y (the model's other terms
    zeroed): the COMP_FILEs alone keep the gain, the row says so and nothing warns."""
    m, sim, model = flow
    pure = copy.copy(model)
    keep = [k for k, n in enumerate(model.parameter_names) if re.fullmatch(r"X\.dx\.[1-3]|Y\.dy\.[1-3]", n)]
    pure.b_ = np.zeros_like(model.b_)
    pure.b_[keep] = 2e-4
    run = make_tables(pure, tmp_path, "linuxcnc", commands=sim.campaign, uncertainty=False)
    r = rows(run)
    before, alone = r["uncompensated (model)"].mean, r[ALONE].mean
    assert (tmp_path / "vecpin_vec.comp").exists() and before > 0.05
    assert alone < 0.1 * before and not run.warnings
    assert not readme(run).startswith("WARNING")


# ---------------------------------------------------------------- 2. the gauge-line datum and its sign
DATUM_WORDS = {"siemens-840d": "$TC_DP3", "fanuc-30i": "19666", "heidenhain": "TOOL.T",
               "linuxcnc": "5axiskins.pivot-length", "beckhoff": "laenge", "generic": "tool length"}


def profile_for(controller: str) -> ControllerProfile | None:
    if controller in ("generic", "linuxcnc"):
        return None
    d = {"format": "vecpin-controller-profile", "version": 1,
         "axes": {a: {"nc_name": f"{a}1", "number": k + 1, "reference_position": 0.0, "detection_unit": 0.001}
                  for k, a in enumerate("XYZCB")},
         "options": {"rotary_any_range": True} if controller == "heidenhain" else {}}  # flow's C: 544 deg
    return ControllerProfile.from_dict(d, "test profile")


@pytest.mark.parametrize("controller", list(DATUM_WORDS))
def test_the_printed_gauge_line_sign_is_the_one_the_compensated_machine_needs(flow, tmp_path, controller):
    """The value as printed (printout and README), entered with its sign, with the other
    sign and not at all, into the files as the controller holds them (vecpin's reader),
    on the true simulated machine at fresh commands: as printed is the best, by far."""
    m, sim, model = flow
    run = make_tables(model, tmp_path, controller, profile=profile_for(controller), commands=sim.campaign,
                      uncertainty=False)
    line = next(ln for ln in run.lines("m") if "gauge line (T_offset) change of these tables" in ln)
    printed = float(re.search(r"tables: ([+-]\d+\.\d+) mm", line).group(1))
    assert printed == pytest.approx(run.plan.tables.gauge_offset_change * 1e3, abs=5e-5) and abs(printed) > 0.05
    assert DATUM_WORDS[controller] in line and "add it, with its sign" in line
    assert (f"{abs(printed):.4f} mm closer to the gauge line" in line) == (printed < 0)
    if controller != "generic":
        text = readme(run)
        assert float(re.search(r"by \*\*([+-]\d+\.\d+) mm\*\*", text).group(1)) == printed
        assert DATUM_WORDS[controller] in text and "Source:" in text
        held = run.as_written
    else:
        held = TableSet.load_json(tmp_path / "tables.json", m)
    q, tool = validation_commands(m, 150)
    truth = truth_as_actual(sim.truth)
    err = {s: norm_mm(compensated_errors(truth, m, dataclasses.replace(held, gauge_offset_change=s * printed * 1e-3),
                                         q, tool)).mean() for s in (1, 0, -1)}
    print(f"{controller}: printed {printed:+.4f} mm; true mean error entered {err[1]:.4f}, not entered {err[0]:.4f}, "
          f"other sign {err[-1]:.4f} mm")
    assert err[1] < 0.7 * err[0] < 0.7 * err[-1]
    e = run.gauge_effect   # the model's figures, printed beside the datum: the same order
    assert e["entered"] < e["none"] < e["flipped"] and f"{e['none']:.4f} mm not entered" in line


# ---------------------------------------------------------------- 3. modulo tables fold the travel onto one turn
@pytest.fixture(scope="module")
def ingersoll():
    """ingersoll_xyzca (C -400 .. 400 deg), its C errors given a trend over the travel
    that no table over one turn can follow (an X offset growing with C)."""
    m, sim, model = fitted("ingersoll_xyzca", basis="chebyshev")
    model.b_[model.parameter_names.index("C.dx.1")] += 2e-4
    return m, sim, model


@pytest.mark.parametrize("controller", ["generic", "siemens-840d"])
def test_modulo_tables_say_what_folding_costs_and_name_the_whole_travel_table(ingersoll, tmp_path, controller):
    m, sim, model = ingersoll
    prof = None if controller == "generic" else ControllerProfile.from_dict(
        {"format": "vecpin-controller-profile", "version": 1,
         "axes": {a: {"nc_name": f"{a}1", "reference_position": 0.0} for a in m.axis_names}}, "test profile")
    folded = make_tables(model, tmp_path / "mod", controller, profile=prof, modulo_axes=["C"], commands=sim.campaign,
                         uncertainty=False)
    flat = make_tables(model, tmp_path / "flat", controller, profile=prof, commands=sim.campaign, uncertainty=False)
    r = rows(folded)
    written, unfolded = r["full tables (model-predicted)"].mean, r[unfolded_label(["C"])].mean
    # the unfolded row is the same tables over the whole travel: what the run without modulo writes
    assert unfolded == pytest.approx(rows(flat)["full tables (model-predicted)"].mean, rel=1e-3)
    assert written > 1.3 * unfolded
    print(f"ingersoll_xyzca {controller}: modulo C {written:.4f} mm, the same tables over C's travel {unfolded:.4f} mm")
    out = "\n".join(folded.lines("m"))
    assert f"the set written leaves {written:.4f} mm, the same tables over the whole travel {unfolded:.4f} mm" in out
    assert "C -400 .. 400 deg" in out and "the table over the whole travel on" in out
    if controller == "siemens-840d":
        text = readme(folded)
        assert "## Modulo tables" in text and f"{unfolded:.4f} mm" in text and "IS_MODULO" in text
        assert re.search(r"\$AN_CEC_IS_MODULO\[\d+\]=1", (tmp_path / "mod" / "NC_CEC.INI").read_text())
    assert unfolded_label(["C"]) not in rows(flat)      # no modulo, no such row
