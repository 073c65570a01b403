"""What the controller-files test and benchmark share (issue 21): the machines judged, the
profiles a user would write for each controller, and the controllers simulated from the
vendors' documents (tests/controller_appliers.py) applied to the true simulated machine.

Cases: a trunnion (its X/Y/Z constants are tool-to-rotary-centre offsets),
production_xyzbaw (W follows the rotaries) over the whole machine and in its East and
West zones (seed Section 2.6; the zones ASSUMED as the halves of X, as in
examples/seed_production_zones.py), and the Master Mill with a twin-drive X (seed
Section 2.5: a true gantry that yaws with Z, its two drives 5200 mm apart, ASSUMED as in
tests/test_drives_zones.py). On the twin drive the controller moves each drive by its
own tables; the true gantry follows the mean and turns by the difference
(:class:`GantryCommands`, geometry written here, not vecpin's ``TwinDrive``).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from controller_appliers import (fanuc_corrections, heidenhain_corrections, linuxcnc_corrections, linuxcnc_type0,
                                 siemens_corrections)
from linuxcnc_sim import ControllerCommands
from scipy.spatial.transform import Rotation

import vecpin
from vecpin.errors import ControllerLimitError
from vecpin.compensation.frame import in_reference_frame, reference_frame
from vecpin.compensation.functions import truth_as_actual
from vecpin.simulation.floor import PAPER_I_TOOLS
from vecpin.compensation.report import compensated_errors
from vecpin.export.profile import ControllerProfile
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.judge import validation_commands
from vecpin.simulation.simulate import Design, simulate
from vecpin.units import norm_mm
from vecpin.workflows.tables import make_tables

CONTROLLERS = ("siemens-840d", "fanuc-30i", "heidenhain", "linuxcnc")
SEPARATION_MM = 5200.0          # ASSUMED: the Master Mill's X drives either side of its 4 m Y travel
ZONES = {"east": {"X": (18415.0, 25400.0)}, "west": {"X": (11430.0, 18415.0)}}   # ASSUMED: the halves of X
JUDGED_BY = {"siemens-840d": "applier from the K3 manual", "fanuc-30i": "applier from the parameter manual",
             "heidenhain": "applier from the MANUALplus 620 technical manual",
             "linuxcnc": "applier from the LinuxCNC source (real controller: bench_linuxcnc)"}


@dataclass
class Case:
    """A true machine, the model fitted to its campaign, and how it is judged."""
    label: str
    machine: object
    truth: object
    model: object
    twin: tuple[str, ...] = ()      # twin-drive axes (following drive: '<axis>2')
    zone: dict | None = None        # {axis: (low, high)} mm/deg: the model's zone, the commands judged in it


def make_case(label: str, n_commands: int | None = None) -> Case:
    """``trunnion_xyzac``, ``production_xyzbaw`` (6-DoF order 4), ``production_xyzbaw east|west``
    (the same fitted to the zone's rows) or ``master_mill twin`` (AP order 3 with the gantry
    skew on a true machine whose gantry yaws): simulated with seed 2, ``n_commands`` commands."""
    design = Design(n_validation=5) if n_commands is None else Design(n_commands=n_commands, n_validation=5)
    name, _, kind = label.partition(" ")
    m = vecpin.Machine.load(name)
    if kind == "twin":
        return _twin_case(label, m, design)
    sim = simulate(m, seed=2, design=design)
    noise = NoiseModel.default(m, "spherical")
    if kind in ZONES:
        from vecpin.workflows.fitting import fit_campaign
        model = fit_campaign(m, sim.campaign, noise, kind="6dof", basis="chebyshev", order=4, zone=ZONES[kind]).model
        return Case(label, m, sim.truth, model, zone=ZONES[kind])
    return Case(label, m, sim.truth, make_model("6dof", m, 4).fit(sim.campaign, noise))


def _twin_case(label: str, m, design: Design) -> Case:
    from vecpin.models.effects.gantry_skew import GantrySkew
    from vecpin.simulation.effects import EffectSpec
    from vecpin.simulation.truth import TrueMachine
    truth = TrueMachine.random(m, np.random.default_rng(4), mean_error_mm=0.295, family="ap")
    skew = EffectSpec("gantry_skew", ("X",), 0.06, {"about": "z", "depends": "Z"}, seed=3)
    sim = simulate(m, seed=2, truth=truth, effects=[skew], design=design)
    model = make_model("ap", m, 3, effects=[GantrySkew(m, ("X",), about="z")])
    model.fit(sim.campaign, NoiseModel.default(m, "spherical", tracker=truth.tracker.noise))
    return Case(label, m, sim.truth, model, twin=("X",))


def reference_positions(m) -> dict[str, float]:
    """Reference points where real machines have them: linear axes at the positive end
    (5 mm inside), rotary axes at 0 (mm/deg, machine coordinates); a following drive's
    is its leading axis' (under ``<axis>2``)."""
    ref = {a.name: (float(a.to_user(a.upper)) - 5.0 if a.kind == "linear" else 0.0) for a in m.axes}
    return ref | {f"{a}2": ref[a] for a in list(ref)}


def columns(m, twin=()) -> list[str]:
    """The drives a controller moves: the machine's axes, then each following drive ``<axis>2``."""
    return list(m.axis_names) + [f"{a}2" for a in twin]


def _facts(controller: str, name: str, k: int, ref: float) -> dict:
    if controller.startswith("siemens"):
        return {"nc_name": f"{name}1", "general_name": f"AX{k + 1}", "reference_position": ref}
    if controller == "fanuc-30i":
        return {"number": k + 1, "reference_position": ref, "detection_unit": 0.001}
    if controller == "heidenhain":
        return {"nc_name": name}
    if controller == "linuxcnc":
        return {"number": k}
    return {}


def profile(m, controller: str, twin=(), separation: bool = True, modulo=()) -> ControllerProfile:
    """The profile a user writes: per drive (in :func:`columns` order) its names and numbers,
    reference points from :func:`reference_positions`; a twin axis' following drive and
    (``separation``) the drives' separation [0, SEPARATION_MM, 0]; Heidenhain: rotary tables
    over 0..360 (its default) unless an axis travels more than a turn (``rotary_any_range``);
    ``modulo``: rotary axes the NC treats as modulo (Fanuc: rotary-axis type)."""
    ref, cols = reference_positions(m), columns(m, twin)
    axes = {a: _facts(controller, a, k, ref[a]) | ({"modulo": True} if a in modulo else {})
            for k, a in enumerate(m.axis_names)}
    for a in twin:
        axes[a]["following"] = _facts(controller, f"{a}2", cols.index(f"{a}2"), ref[a])
        if separation:
            axes[a]["drive_separation_mm"] = [0.0, SEPARATION_MM, 0.0]
    # a rotary axis travelling more than a turn: a TNC needs modulo tables, or takes other positions (assumed here)
    wide = any(a.kind == "rotary" and a.upper_user - a.lower_user > 360.0 + 1e-9 for a in m.axes)
    options = {"rotary_any_range": True} if controller == "heidenhain" and wide else {}
    return ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1, "axes": axes,
                                        "options": options}, f"{controller} profile of the tests")


def commands(case: Case, n: int = 150) -> tuple[np.ndarray, np.ndarray]:
    """Fresh commands [m, rad] x 2 tools (vecpin's validation set), squeezed into the case's
    zone along its axes."""
    m = case.machine
    q, tool = validation_commands(m, n)
    for a, (lo, hi) in (case.zone or {}).items():
        ax = m.axis(a)
        u = (q[:, ax.index] - ax.lower) / (ax.upper - ax.lower)
        q[:, ax.index] = ax.to_si(lo) + u * (ax.to_si(hi) - ax.to_si(lo))
    return q, tool


def corrections(controller: str, folder: Path, m, q_user: np.ndarray, twin=(), with_data: bool = True) -> np.ndarray:
    """What the simulated controller adds to every drive's command [mm or deg], columns as
    :func:`columns`; ``with_data`` False: without the reference point data (Siemens
    MD_REFP.INI, Fanuc parameter 1240)."""
    cols, ref = columns(m, twin), reference_positions(m)
    if controller == "siemens-840d":
        return siemens_corrections(folder, cols, ref, q_user, with_refp=with_data)
    if controller == "fanuc-30i":
        return fanuc_corrections(folder, cols, ref, q_user, with_1240=with_data)
    if controller == "heidenhain":
        return heidenhain_corrections(folder, cols, q_user, {c for c in cols if _axis(m, c).kind == "rotary"})
    return linuxcnc_corrections(folder, cols, q_user)


class GantryCommands(ControllerCommands):
    """The controller's drive commands on the true machine: a twin axis goes to the mean of
    its drives and its beam turns by their difference. The drives stand at -s/2 (leading)
    and +s/2 (following) from the beam's centre (the axis' joint origin), s = [0, S, 0]
    base frame; a turn phi about w moves a drive at r by (phi w x r) . x along the axis x,
    so leading minus following = -phi w . (s x x): phi w = -(lead - follow) (s x x) / |s x x|^2."""

    def __init__(self, m, q, qc, gauge, differences: dict[str, np.ndarray]):
        super().__init__(q, qc, gauge)
        self.m, self.differences = m, differences

    def turn_tips(self, machine, q, tip, frame="base"):
        assert not machine.has_workpiece, "the beam turn is written for head machines"
        reps = len(np.atleast_2d(q)) // len(self.q)
        s = np.array([0.0, SEPARATION_MM * 1e-3, 0.0])
        for a, diff in self.differences.items():
            F = machine.joint_frames(q, a)
            x = F[:, :3, :3] @ np.asarray(machine.axis(a).direction, float)
            sx = np.cross(s[None], x)
            phi = -np.tile(diff, reps)[:, None] * sx / np.einsum("pi,pi->p", sx, sx)[:, None]
            tip = F[:, :3, 3] + Rotation.from_rotvec(phi).apply(tip - F[:, :3, 3])
        return tip


def _axis(m, column: str):
    """The machine axis a drive column moves (a following drive ``X2``: X)."""
    return m.axis(column if column in m.axis_names else column[:-1])


def controller_commands(m, q: np.ndarray, corr_user: np.ndarray, gauge: float, twin=()) -> ControllerCommands:
    """The commands [m, rad] a controller that adds ``corr_user`` (columns as :func:`columns`)
    sends, as a table set stand-in for ``compensated_errors``."""
    cols = columns(m, twin)
    si = np.column_stack([_axis(m, c).to_si(corr_user[:, k]) for k, c in enumerate(cols)])
    dq, diff = si[:, :m.n_axes].copy(), {}
    for a in twin:
        i, f = m.axis(a).index, cols.index(f"{a}2")
        dq[:, i], diff[a] = (si[:, i] + si[:, f]) / 2, si[:, i] - si[:, f]
    return GantryCommands(m, q, q + dq, gauge, diff) if twin else ControllerCommands(q, q + dq, gauge)


def true_error(truth, m, tables, q, tool) -> float:
    """Mean true tool-tip error [mm] relative to the workpiece in the part's frame, on a table aligned to the
    truth's own reference frame (what a campaign that reads only the tool can aim at: the controller files,
    not the frame, are judged here; tests/test_part_frame.py and bench_part_frame judge the frame)."""
    actual = truth_as_actual(truth)
    return float(norm_mm(compensated_errors(in_reference_frame(actual, reference_frame(actual, m, PAPER_I_TOOLS)), m,
                                            tables, q, tool)).mean())


def baseline(case: Case, folder: Path, q, tool) -> dict:
    """Uncompensated and full tables (vecpin's generic set, with the twin drives' differential)."""
    m = case.machine
    full = make_tables(case.model, folder, "generic", profile=profile(m, "generic", case.twin), uncertainty=False)
    return {"uncompensated": true_error(case.truth, m, None, q, tool),
            "full": true_error(case.truth, m, full.plan.tables, q, tool)}


def judge(case: Case, controller: str, folder: Path, q, tool, separation: bool = True, modulo=(), **kw) -> dict:
    """Write ``controller``'s files for the case into ``folder`` and judge them on the true
    machine at commands ``q`` x ``tool``: 'planned' (the table set vecpin chose), 'written'
    (the files applied by the simulated controller), 'without data' (Siemens, Fanuc: without
    the reference point data), 'reader' (the files as vecpin's reader reads them), 'run'.
    ``separation`` False: the profile leaves out the twin drives' separation (no differential);
    ``modulo``: rotary axes the profile declares modulo."""
    m, twin = case.machine, case.twin
    run = make_tables(case.model, folder, controller, profile=profile(m, controller, twin, separation, modulo),
                      uncertainty=False, **kw)
    gauge = run.plan.tables.gauge_offset_change
    q_user = np.column_stack([_axis(m, c).to_user(q[:, _axis(m, c).index]) for c in columns(m, twin)])
    err = lambda t: true_error(case.truth, m, t, q, tool)   # noqa: E731
    applied = lambda data: controller_commands(  # noqa: E731
        m, q, corrections(controller, folder, m, q_user, twin, data), gauge, twin)
    out = {"run": run, "tables": len(run.plan.tables.tables), "planned": err(run.plan.tables),
           "written": err(applied(True)), "judged by": JUDGED_BY[controller]}
    if controller in ("siemens-840d", "fanuc-30i"):
        out["without data"] = err(applied(False))
    if controller == "linuxcnc" and (folder / "vecpin_vec.comp").exists():   # the component not built
        alone = np.zeros_like(q_user)
        for k, col in enumerate(columns(m, twin)):
            if (folder / f"comp_{col}.txt").exists():
                alone[:, k] = linuxcnc_type0(folder, col, q_user[:, k])
        out["comp files alone"] = err(controller_commands(m, q, alone, gauge, twin))
    if run.as_written is not None:
        run.as_written.gauge_offset_change = gauge
        out["reader"] = err(run.as_written)
    return out


def check_written(case, controller, r, base):
    """The files applied: no worse than the planned set, equal to vecpin's reader of them; far below uncompensated;
    the printout's rows agree; a shortfall against the full tables is said first."""
    c, run = case, r["run"]
    # writing loses nothing (a controller's grid may resample the planned set: Heidenhain's rotary
    # entries over 0..360 land up to ~2 % better on the truth), and vecpin reads back what the machine gets
    assert r["written"] <= 1.02 * r["planned"]
    assert r["written"] < (0.5 if run.headline is None else 1.0) * base["uncompensated"]
    assert r["reader"] == pytest.approx(r["written"], rel=0.02)
    rows = {x.label: x for x in run.plan.report.rows}
    assert rows["files as written (model-predicted)"].mean == pytest.approx(
        [x for x in run.plan.report.rows if x.tables == len(run.plan.tables.tables)][0].mean, rel=0.02, abs=1e-3)
    before, full = rows["uncompensated (model)"].mean, rows["full tables (model-predicted)"].mean
    lost = rows["files as written (model-predicted)"].mean - full
    text = next(f for f in run.files if f.name.startswith("README_")).read_text().splitlines()
    assert text[:2 * len(run.warnings):2] == run.warnings == run.lines("m")[:len(run.warnings)]  # warnings first
    readme = text[2 * len(run.warnings)]
    if lost > max(0.02 * (before - full), 1e-3):   # a real share of what the full tables remove is given up
        assert run.headline and run.lines("m")[len(run.warnings)] == run.headline == readme and "takes" in readme
        assert f"give up {100 * lost / (before - full):.0f} % of what the full tables remove" in readme
    else:   # and on the true machine the files give up at most about as little
        assert run.headline is None, c.label
        assert r["written"] - base["full"] <= 0.04 * (base["uncompensated"] - base["full"]) + 1e-3, c.label
    if controller in ("siemens-840d", "fanuc-30i"):   # without the reference point data: worse, and said
        assert r["without data"] > 1.1 * r["written"]
        assert "files without the reference point data (model-predicted)" in rows
    if "comp files alone" in r:   # LinuxCNC's COMP_FILEs without the HAL component: the true machine agrees with
        gain = base["uncompensated"] - r["written"]   # the warning (the model's row keeps less than half the gain)
        kept = (base["uncompensated"] - r["comp files alone"]) / gain
        assert "comp files without the component (model-predicted)" in rows
        assert (kept < 0.5) == bool(run.warnings), (c.label, kept, run.warnings)


def prepared_case(name: str, tmp_path_factory):
    """The case ``name`` simulated and fitted, its judging commands and its generic-tables baseline."""
    c = make_case(name, n_commands=200)
    q, tool = commands(c)
    return c, q, tool, baseline(c, tmp_path_factory.mktemp("generic"), q, tool)


#: Fanuc's 6 of the 30 cross tables as scoring all 593,775 combinations ranks them (every combination scored
#: in 14.6 s on the search problem of plan_tables, the model in its reference frame, after the part's-frame
#: change): the best set, its linearised score and its mean error re-solved on the model [mm]
EXHAUSTIVE_CHOICE = {"production_xyzbaw": (["xy", "xa", "yx", "yz", "zy", "aw"], 0.061550544353696605,
                                           0.055193059111555344)}


def run_case(case, controller, tmp_path):
    """Write one case's files for ``controller``, apply them with the independent applier and
    check them (:func:`check_written`); Fanuc's selection against :data:`EXHAUSTIVE_CHOICE`."""
    c, q, tool, base = case
    kw = {"max_tables": 6} if controller == "fanuc-30i" else {}
    if c.twin and controller == "fanuc-30i":
        # 6 cross tables cannot hold the differential on both drives: refused, naming the way out; taken,
        # the skew stays in the other tables and the shortfall against the full tables is said first
        with pytest.raises(ControllerLimitError, match="drive_separation_mm"):
            judge(c, controller, tmp_path / "refused", q, tool, **kw)
        r = judge(c, controller, tmp_path, q, tool, separation=False, **kw)
    else:
        r = judge(c, controller, tmp_path, q, tool, **kw)
    check_written(c, controller, r, base)
    if controller == "fanuc-30i" and c.label in EXHAUSTIVE_CHOICE:
        tables, rms, mean = EXHAUSTIVE_CHOICE[c.label]
        sel = r["run"].plan.selection
        first, score, planned = sel.finalists[0]                       # the branch and bound's best by the score
        assert sel.evaluations < 10_000 and first == tables            # it scored a few
        assert score == pytest.approx(rms, rel=1e-9) and planned == pytest.approx(mean, rel=1e-9)


def e2e_tests(cases: tuple[str, ...]):
    """The module-scoped ``case`` fixture over ``cases`` and the end-to-end test over every
    controller, for a test module to bind: ``case, test_… = e2e_tests(CASES)``."""
    @pytest.fixture(scope="module", params=cases)
    def case(request, tmp_path_factory):
        return prepared_case(request.param, tmp_path_factory)

    @pytest.mark.parametrize("controller", CONTROLLERS)
    def test_the_files_as_written_give_the_machine_what_vecpin_predicts(case, controller, tmp_path):
        run_case(case, controller, tmp_path)
    return case, test_the_files_as_written_give_the_machine_what_vecpin_predicts
