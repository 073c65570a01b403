"""vecpin's LinuxCNC files on the real LinuxCNC (2.9, headless simulation): the joint
corrections the controller applies equal vecpin's tables within 1 µm (sign,
interpolation, the ends of the tables, joint numbering; COMP_FILE types 0 and 1; the HAL
component for the cross tables), and a fitted model's tables through the controller give
the true machine the full tables' error. Runs wherever LinuxCNC is installed and the
tests run as root (CI: .ci/run installs it); skipped with the reason elsewhere.
The controller is the judge here: vecpin's own reader is not used to check the files.

The configuration has the following-error limits of LinuxCNC's sample configurations
(tests/linuxcnc_sim.py: 0.254 mm at rest, 1.27 mm at full speed; 1 and 5 deg), and every
run checks the component's feedback path: no fault on the way, motion's following error
0 at rest, a following error when the drives stall. Mutated copies of the component
(feedback held at 0, negated, keeping or doubling the correction, ...) must fail.
The component's product terms (a table over a rotary joint times a ramp over a linear
joint) reach the drive as planned within 1e-6 mm, and a component with the product's sign
flipped or its ramp read on the wrong joint fails.
"""
import re

import numpy as np
import pytest

import linuxcnc_sim as lcnc
import vecpin
from vecpin.compensation.tables import CompensationTable, ProductTable, TableSet
from vecpin.export import linuxcnc
from vecpin.export.common import ExportJob
from vecpin.export.profile import AxisProfile, ControllerProfile
from vecpin.fileio import OutputSet

WHY = lcnc.unavailable()
pytestmark = [pytest.mark.skipif(WHY is not None, reason=WHY or ""), pytest.mark.slow]
TOL_MM = 1e-3 * 1.0   # 1 µm


def smooth_tables(m, n_points: int, rng) -> TableSet:
    """Every pitch and cross table of ``m``: smooth errors of 10-40 µm (or 10-40 µrad
    scaled to degrees) over the travel, so that the tables' slopes are realistic."""
    tables = []
    for o in m.axes:
        for i in m.axes:
            x = np.linspace(0.0, 1.0, n_points)
            amp = rng.uniform(1e-5, 4e-5) * (1.0 if o.kind == "linear" else 1.0)
            phase, cycles = rng.uniform(0, 2 * np.pi), rng.uniform(0.5, 2.0)
            values = amp * np.sin(2 * np.pi * cycles * x + phase) + rng.uniform(-amp, amp)
            tables.append(CompensationTable(i.name, o.name, i.lower, (i.upper - i.lower) / (n_points - 1), values))
    return TableSet(m.axis_names, tables)


def write(tables, m, prof, out_dir):
    with OutputSet(out_dir) as out:
        job = ExportJob(tables, m, prof, linuxcnc.LIMITS, out)
        return linuxcnc.write(job)


def probe_commands(m, tables, rng, n_random=6):
    """Commands [SI] that probe each joint at a table point, between two points, and
    beyond both ends of its tables (the end values hold), plus random ones."""
    lo, hi = np.array([a.lower for a in m.axes]), np.array([a.upper for a in m.axes])
    step = np.array([m.axis(a).travel / (len(tables.table((a + a).lower()).values) - 1) for a in m.axis_names])
    at_point = lo + step * 3
    between = lo + step * 7.5
    below, above = lo - 0.03 * (hi - lo), hi + 0.03 * (hi - lo)
    rand = lo + (hi - lo) * rng.uniform(0, 1, (n_random, len(lo)))
    return np.vstack([at_point, between, below, above, rand])


def vecpin_corrections(m, tables: TableSet, pos_user: np.ndarray, which: str) -> np.ndarray:
    """vecpin's table increments [mm or deg] at the commanded positions the controller reports."""
    q = np.column_stack([m.axes[k].to_si(pos_user[:, k]) for k in range(len(m.axes))])
    keep = [t for t in tables.tables if (t.is_pitch if which == "pitch" else not t.is_pitch)]
    inc = TableSet(m.axis_names, keep).increments(q)
    return np.column_stack([m.axes[k].to_user(inc[:, k]) for k in range(len(m.axes))])


@pytest.mark.parametrize("machine, kind", [("trunnion_xyzac", 0), ("snk_120v", 1)])
def test_comp_files_and_component_applied_as_vecpin_predicts(tmp_path, machine, kind):
    m = vecpin.Machine.load(machine)
    rng = np.random.default_rng(7)
    tables = smooth_tables(m, 41, rng)
    prof = ControllerProfile(options={"comp_file_type": kind})
    names = write(tables, m, prof, tmp_path)
    assert "vecpin_vec.comp" in names and all(linuxcnc.comp_file_name(a) in names for a in m.axis_names)
    lcnc.build_component(tmp_path / "vecpin_vec.comp")
    q = probe_commands(m, tables, rng)
    joints = linuxcnc.joint_numbers(m, prof)
    pos, pitch, cross = lcnc.machine_run(m, tmp_path, q, joints, kind, component=True)
    want_q = np.column_stack([m.axes[k].to_user(q[:, k]) for k in range(len(m.axes))])
    np.testing.assert_allclose(pos, want_q, atol=1e-6)              # the controller went where it was told
    np.testing.assert_allclose(pitch, vecpin_corrections(m, tables, pos, "pitch"), atol=TOL_MM)
    np.testing.assert_allclose(cross, vecpin_corrections(m, tables, pos, "cross"), atol=TOL_MM)
    assert np.abs(pitch).max() > 0.005 and np.abs(cross).max() > 0.02   # the check is not trivially met


def test_joint_numbering_follows_the_configuration(tmp_path):
    """flow_xyzcb's axes are X Y Z C B; the configuration has B as joint 3 and C as joint 4
    (trivkins coordinates=XYZBC): the profile's numbers, checked against that INI, put every
    table on its own joint."""
    m = vecpin.Machine.load("flow_xyzcb")
    rng = np.random.default_rng(3)
    tables = smooth_tables(m, 21, rng)
    numbers = {"X": 0, "Y": 1, "Z": 2, "B": 3, "C": 4}
    ini = tmp_path / "machine.ini"
    ini.write_text("[KINS]\nKINEMATICS = trivkins coordinates=XYZBC\nJOINTS = 5\n[TRAJ]\nLINEAR_UNITS = mm\n"
                   "ANGULAR_UNITS = degree\n" + "".join(
                       f"[JOINT_{n}]\nTYPE = {'LINEAR' if m.axis(a).kind == 'linear' else 'ANGULAR'}\n"
                       for a, n in numbers.items()))
    prof = ControllerProfile(axes={a: AxisProfile(number=n) for a, n in numbers.items()},
                             options={"ini": str(ini)})
    out = tmp_path / "files"
    write(tables, m, prof, out)
    lcnc.build_component(out / "vecpin_vec.comp")
    q = probe_commands(m, tables, rng, n_random=3)
    pos, pitch, cross = lcnc.machine_run(m, out, q, linuxcnc.joint_numbers(m, prof), 0, component=True)
    np.testing.assert_allclose(pitch, vecpin_corrections(m, tables, pos, "pitch"), atol=TOL_MM)
    np.testing.assert_allclose(cross, vecpin_corrections(m, tables, pos, "cross"), atol=TOL_MM)
    # the same files on a configuration in the machine's axis order would apply B's tables to C
    swapped = linuxcnc.joint_numbers(m, ControllerProfile())
    assert swapped["C"] == 3 and numbers["C"] == 4


def test_a_fitted_model_through_the_controller_gets_the_full_tables_figure(tmp_path):
    """simulate -> fit -> ``tables --controller linuxcnc`` -> LinuxCNC -> the true machine:
    the commands the controller sends give the true machine vecpin's full-table error
    (within 2 %), where pitch-only COMP_FILEs leave much more."""
    from vecpin.compensation.functions import truth_as_actual
    from vecpin.compensation.report import compensated_errors
    from vecpin.measurement.noise import NoiseModel
    from vecpin.models import make_model
    from vecpin.simulation.judge import validation_commands
    from vecpin.simulation.simulate import Design, simulate
    from vecpin.units import norm_mm
    from vecpin.workflows.tables import make_tables
    m = vecpin.Machine.load("trunnion_xyzac")
    sim = simulate(m, seed=4, design=Design(n_commands=200, n_validation=5))
    model = make_model("6dof", m, 4).fit(sim.campaign, NoiseModel.default(m, "spherical"))
    run = make_tables(model, tmp_path, "linuxcnc", uncertainty=False)
    assert any(not t.is_pitch for t in run.plan.tables.tables)
    lcnc.build_component(tmp_path / "vecpin_vec.comp")
    q, tool = validation_commands(m, 10)
    pos, pitch, cross = lcnc.machine_run(m, tmp_path, q[:10], linuxcnc.joint_numbers(m, ControllerProfile()), 0, True)
    sent = lcnc.ControllerCommands(q[:10], lcnc.to_si(m, pos + pitch + cross), run.plan.tables.gauge_offset_change)
    truth = truth_as_actual(sim.truth)
    err = lambda t: norm_mm(compensated_errors(truth, m, t, q, tool)).mean()   # noqa: E731
    pitch_only = TableSet(m.axis_names, [t for t in run.plan.tables.tables if t.is_pitch],
                          run.plan.tables.gauge_offset_change)
    full, controller, uncompensated = err(run.plan.tables), err(sent), err(None)
    assert controller == pytest.approx(full, rel=0.02)
    assert controller < 0.5 * err(pitch_only) and controller < 0.3 * uncompensated


def verdict(m, tables: TableSet, folder, q, joints, kind) -> list[str]:
    """Everything by which a run of vecpin's files in ``folder`` on the controller fails
    these tests, in words ([]: it passes): a controller fault (a following error), an
    unsound feedback path, corrections at the drive other than vecpin's tables."""
    try:
        rb = lcnc.machine_readback(m, folder, q, joints, kind, component=True)
    except lcnc.ControllerFault as exc:
        return [f"controller fault: {'; '.join(exc.errors) or exc}"]
    out = lcnc.feedback_problems(rb, TOL_MM)
    for which, got in (("pitch", rb.pitch), ("cross", rb.cross)):
        diff = np.abs(got - vecpin_corrections(m, tables, rb.pos, which)).max(axis=0)
        out += [f"{a}: the {which} correction the drive got differs from vecpin's tables by {d:.4g} mm or deg"
                for a, d in zip(m.axis_names, diff) if d > TOL_MM]
    return out


# the component's feedback and command lines (vecpin/export/linuxcnc_hal.py) and the line of its
# HAL file that places the feedback function; the mutants: what is broken -> (replacements of those
# lines, in the .comp or the .hal, and the verdict that must catch it: a pattern)
FB = "motor_pos_fb_out(j) = motor_pos_fb(j) - applied[j];"
CMD = "motor_pos_cmd_out(j) = motor_pos_cmd(j) + applied[j];"
FB_FIRST = "addf vecpin-vec.0.feedback servo-thread 1"
FAULT = r"^controller fault: .*joint \d following error"            # reported while moving
AT_REST = r"^\w: motion's following error at rest is"                # below the limit: no fault
TABLES = r"^\w: the cross correction the drive got differs from vecpin's tables"
STALLED = r"^with the drives stalled .* no following error"
MUTANTS = {
    "feedback held at 0": ({FB: "motor_pos_fb_out(j) = 0.0;"}, FAULT),
    "feedback sign flipped": ({FB: "motor_pos_fb_out(j) = -(motor_pos_fb(j) - applied[j]);"}, FAULT),
    "correction not taken off the feedback": ({FB: "motor_pos_fb_out(j) = motor_pos_fb(j);"}, AT_REST),
    "correction added to the feedback": ({FB: "motor_pos_fb_out(j) = motor_pos_fb(j) + applied[j];"}, AT_REST),
    "correction taken off the feedback twice": ({FB: "motor_pos_fb_out(j) = motor_pos_fb(j) - 2.0 * applied[j];"},
                                                AT_REST),
    "correction applied twice, command and feedback": (
        {CMD: "motor_pos_cmd_out(j) = motor_pos_cmd(j) + 2.0 * applied[j];",
         FB: "motor_pos_fb_out(j) = motor_pos_fb(j) - 2.0 * applied[j];"}, TABLES),
    "feedback is motion's command, not the drive's": ({FB: "motor_pos_fb_out(j) = motor_pos_cmd(j);"}, STALLED),
    "feedback a servo period late (run after motion)": ({FB_FIRST: "addf vecpin-vec.0.feedback servo-thread"},
                                                        FAULT),
}


def mutate(folder, edits: dict[str, str]) -> None:
    """Replace each line ``old`` of vecpin's component or HAL file in ``folder`` by ``new``."""
    files = [folder / "vecpin_vec.comp", folder / "vecpin_vec.hal"]
    texts = {f: f.read_text() for f in files}
    for old, new in edits.items():
        where = [f for f in files if texts[f].count(old) == 1]
        assert len(where) == 1 and sum(t.count(old) for t in texts.values()) == 1, \
            f"vecpin's files have no single line {old!r}: update MUTANTS"
        texts[where[0]] = texts[where[0]].replace(old, new)
    for f, t in texts.items():
        f.write_text(t)


@pytest.mark.parametrize("mutant", [None, *MUTANTS], ids=["vecpin's component", *MUTANTS])
def test_a_broken_feedback_path_fails(tmp_path, mutant):
    """vecpin's component passes the checks every run makes; each mutated copy of its
    source or HAL file (built with halcompile, same tables, same moves) fails them,
    caught by the observable named in MUTANTS: a following error the controller reports
    while moving (feedback held at 0 or negated; feedback a servo period late: velocity
    * 1 ms, up to 3 mm at these joints' full speed, over the 1.27 mm limit), motion's
    following error at rest (the feedback keeps, adds or doubles the correction:
    0.002-0.24 mm or deg here, below the 0.254 mm / 1 deg limits, so no fault, but the simulated drive
    sits exactly at its command), the drive's correction against vecpin's tables
    (doubled in command and feedback alike: motion sees nothing), or no following error
    with the drives stalled (feedback that is not the drive's)."""
    m = vecpin.Machine.load("trunnion_xyzac")
    rng = np.random.default_rng(7)
    tables = smooth_tables(m, 41, rng)
    prof = ControllerProfile()
    write(tables, m, prof, tmp_path)
    if mutant is not None:
        mutate(tmp_path, MUTANTS[mutant][0])
    lcnc.build_component(tmp_path / "vecpin_vec.comp")
    q = probe_commands(m, tables, rng, n_random=2)
    found = verdict(m, tables, tmp_path, q, linuxcnc.joint_numbers(m, prof), 0)
    if mutant is None:
        assert found == []
    else:
        assert any(re.search(MUTANTS[mutant][1], f) for f in found), f"{mutant}: not caught as expected; found {found}"


def product_set(m, rng) -> TableSet:
    """Pitch tables of every axis (smooth_tables) and two product terms, no cross table: Z += a table of C
    (cos and sin of C, 30-60 µm) times a ramp of X (-1 .. 1), Y += a table of A times a ramp of Z."""
    pitch = [t for t in smooth_tables(m, 41, rng).tables if t.is_pitch]
    products = []
    for out, r, f in (("Z", "C", "X"), ("Y", "A", "Z")):
        ar, af = m.axis(r), m.axis(f)
        angle = np.linspace(ar.lower, ar.upper, 41)
        values = rng.uniform(3e-5, 6e-5) * np.cos(angle + rng.uniform(0, 2 * np.pi)) + 1e-5 * np.sin(3 * angle)
        products.append(ProductTable(CompensationTable(r, out, ar.lower, ar.travel / 40, values),
                                     CompensationTable(f, out, af.lower, af.travel / 40, np.linspace(-1.0, 1.0, 41))))
    return TableSet(m.axis_names, pitch, products=products)


def product_corrections(m, tables: TableSet, pos_user: np.ndarray) -> np.ndarray:
    """The planned product terms at the commanded positions [mm or deg], computed here: each term's table
    (interpolated at its rotary axis) times its factor (at its linear axis), added to its output axis."""
    out = np.zeros_like(pos_user)
    for p in tables.products:
        t, f = p.table, p.factor
        value = [np.interp(m.axis(x.input_axis).to_si(pos_user[:, m.axis(x.input_axis).index]), x.positions, x.values)
                 for x in (t, f)]
        out[:, m.axis(t.output_axis).index] += m.axis(t.output_axis).to_user(value[0] * value[1])
    return out


PRODUCT = "target[t->out] += vecpin_lookup(t, pos_cmd(t->in)) * vecpin_lookup(f, pos_cmd(f->in));"
PRODUCT_MUTANTS = {
    "product sign flipped": {PRODUCT: PRODUCT.replace("+=", "-=")},
    "ramp read on the rotary joint": {PRODUCT: PRODUCT.replace("pos_cmd(f->in)", "pos_cmd(t->in)")},
}


@pytest.mark.parametrize("mutant", [None, *PRODUCT_MUTANTS], ids=["vecpin's component", *PRODUCT_MUTANTS])
def test_product_terms_reach_the_drive_as_planned(tmp_path, mutant):
    """trunnion_xyzac with pitch tables and two product terms: the correction LinuxCNC's drives get from the
    component (drive position - motor-pos-cmd, and its correction pin) equals the planned product terms,
    computed here from the plan's arrays, within 1e-6 mm at table points, between them, beyond the ends and at
    random poses; the feedback path stays sound. Each mutated copy (the product's sign flipped, the ramp read
    on the rotary joint instead of its linear one) fails."""
    m = vecpin.Machine.load("trunnion_xyzac")
    rng = np.random.default_rng(11)
    tables = product_set(m, rng)
    prof = ControllerProfile()
    write(tables, m, prof, tmp_path)
    if mutant is not None:
        mutate(tmp_path, PRODUCT_MUTANTS[mutant])
    lcnc.build_component(tmp_path / "vecpin_vec.comp")
    q = probe_commands(m, tables, rng, n_random=3)
    rb = lcnc.machine_readback(m, tmp_path, q, linuxcnc.joint_numbers(m, prof), 0, component=True, stall=False)
    want = product_corrections(m, tables, rb.pos)
    off = np.abs(rb.cross - want).max()
    if mutant is not None:
        assert off > 1e-3, f"{mutant}: not caught (the drive's correction is off the plan by {off:.3g} mm)"
        return
    assert lcnc.feedback_problems(rb, 1e-6) == []
    assert off < 1e-6 and np.abs(rb.correction - want).max() < 1e-6
    np.testing.assert_allclose(rb.pitch, vecpin_corrections(m, tables, rb.pos, "pitch"), atol=TOL_MM)
    assert np.abs(want).max() > 0.02      # the products are not trivially met
