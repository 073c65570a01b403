"""A table machine's validation run reads every point several times AT STANDSTILL.

* The NC program (read by the tests' own G-code interpreter, tests/gcode.py, no vecpin
  code, and by LinuxCNC's own, ``rs274``, where installed) moves to each command once,
  then reads there: one comment naming the point and one dwell per reading, no motion
  between the readings; its moves are exactly those of the same run reading every point
  once, with the machine at the point's axis values at every reading.
* The run's time counts a dwell per reading and no extra move: its moves and approaches
  are those of the run read once, its dwells the interpreter's sum of the program's G4s
  (``read_dwell_s``, the tracker's reading time, for every further reading).
* The simulator draws the axes' positioning noise once per standstill (every reading
  there, of the tool and of the nests, sees the same axis positions: repeated readings
  are equal without tracker noise, the nests' readings rigid) and the tracker's noise per
  reading.
* vecpin's noise netted out of the averaged readings is the tracker's variance divided by
  the readings plus the positioning variance NOT divided, the positioning part equal to
  the closed form sum_j sigma_j^2 |d tip / d q_j|^2 of the tip relative to the table (by
  finite differences); on a run of 150 commands the model error net of that noise is the
  simulated noise-free truth within three standard uncertainties, where dividing the
  positioning part too would miss it.
"""
import re
import shutil
import subprocess

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gcode import run
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.tableframe import net_of_noise, table_tips
from vecpin.measurement.tracker import Tracker, TrackerNoise
from vecpin.models import make_model
from vecpin.planning.ncprogram import DIALECTS, write_program
from vecpin.planning.nests import VALIDATION_READS
from vecpin.planning.plan import PlanSettings, make_plan
from vecpin.planning.route import axis_speeds
from vecpin.planning.timing import ProgramTiming, row_times, run_times
from vecpin.simulation.simulate import Design, simulate
from vecpin.workflows.evaluation import evaluate

TOL = 5e-4  # values are written with 3 decimals
DWELL, NEST_DWELL, READ = 3.0, 12.0, 1.5  # s: a point's first reading, a nest's first, every further one


@pytest.fixture(scope="module")
def plan(machines):
    m = machines["trunnion_xyzac"]
    return m, make_plan(m, PlanSettings(n_commands=24, model="6dof", order=1, candidates=300, validation_points=30,
                                        n_validation=12))


def _first_readings(t) -> np.ndarray:
    """Rows that do not repeat the row before them (instrument, nest, command): the run read once."""
    same = np.r_[False, (t.instrument[1:] == t.instrument[:-1]) & (t.target[1:] == t.target[:-1])
                 & np.all(t.q[1:] == t.q[:-1], axis=1)]
    return np.flatnonzero(~same)


def _standstill(t) -> np.ndarray:
    """(N,) id of each row's standstill: consecutive rows at one command."""
    return np.cumsum(np.r_[True, np.any(t.q[1:] != t.q[:-1], axis=1)])


@pytest.mark.parametrize("dialect", list(DIALECTS))
def test_the_validation_program_reads_every_point_at_standstill(plan, dialect):
    m, p = plan
    v, reads = p.validation_template, p.validation_reads
    assert reads == VALIDATION_READS > 1 and len(v.tool_rows) == reads * p.settings.n_validation
    once = v.take(_first_readings(v))
    assert len(v) == reads * len(once)
    axes = {a.name: (a.lower_user, a.upper_user) for a in m.axes}
    kw = dict(dwell_s=DWELL, nest_dwell_s=NEST_DWELL, feed_mm_min=800.0, read_dwell_s=READ)
    prog = run(write_program(dialect, m, v, p.steps, reads=reads, **kw), dialect, axes)
    prog1 = run(write_program(dialect, m, once, p.steps, **kw), dialect, axes)
    # the same moves as reading every point once: no lift, plunge or approach for a further reading
    assert [(mv.code, mv.pos) for mv in prog.moves] == [(mv.code, mv.pos) for mv in prog1.moves]
    assert len(prog.moves) > len(once.tool_rows)
    # one dwell per reading; the comment before it names the one point read; the machine stands at its values
    row_of = {f"P{int(pt):04d}": k for k, pt in enumerate(v.point)}
    rows, dwell_rows, moved_since, pos, comment, moved = [], [], [], None, "", False
    for e in prog.events:
        if e[0] == "move":
            pos, moved = prog.moves[e[1]].pos, True
        elif e[0] == "comment":
            comment = e[1]
        elif e[0] == "dwell":
            names = [w for w in comment.upper().replace(",", " ").split() if w in row_of]
            assert len(names) == 1, comment
            k = row_of[names[0]]
            np.testing.assert_allclose([pos[a] for a in m.axis_names], m.to_user(v.q[k]), atol=TOL)
            rows.append(k)
            dwell_rows.append(prog.dwells[e[1]])
            moved_since.append(moved)
            moved = False
    assert rows == list(range(len(v)))  # every row read once, in order
    still = _standstill(v)
    for k in range(1, len(v)):  # no motion between two readings at one standstill, a move to every next one
        assert moved_since[k] == (still[k] != still[k - 1])
    np.testing.assert_allclose(dwell_rows, [d for _, d, _ in _expected_dwells(v)])


@pytest.mark.skipif(shutil.which("rs274") is None, reason="LinuxCNC's stand-alone interpreter rs274 is not installed")
def test_linuxcncs_own_interpreter_sees_no_motion_between_the_readings(plan, tmp_path):
    """LinuxCNC's interpreter (rs274, its canonical machining commands) runs the validation
    program: every DWELL follows the comment naming its point, with the axes at that
    point's values; no STRAIGHT_TRAVERSE or STRAIGHT_FEED between two readings of one
    standstill, at least one before every next standstill."""
    m, p = plan
    v = p.validation_template
    f = tmp_path / "validation.ngc"
    f.write_text(write_program("gcode", m, v, p.steps, dwell_s=DWELL, nest_dwell_s=NEST_DWELL,
                               reads=p.validation_reads, read_dwell_s=READ))
    out = subprocess.run(["rs274", "-g", str(f)], capture_output=True, text=True, timeout=120,
                         stdin=subprocess.DEVNULL)
    assert out.returncode == 0 and "PROGRAM_END()" in out.stdout, out.stdout[-2000:] + out.stderr[-2000:]
    canon = re.findall(r"N\.+\s+(\w+)\((.*)\)\s*$", out.stdout, re.M)
    row_of = {f"P{int(pt):04d}": k for k, pt in enumerate(v.point)}
    col = {a.name: "XYZABCUVW".index(a.name) for a in m.axes}
    pos, comment, moved, rows, moves, seconds = None, "", False, [], [], []
    for name, args in canon:
        if name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "ARC_FEED"):
            pos, moved = [float(x) for x in args.split(",")], True
        elif name == "COMMENT":
            comment = args
        elif name == "DWELL":
            k = row_of[re.findall(r"\bP\d{4}\b", comment)[-1]]
            np.testing.assert_allclose([pos[col[a]] for a in m.axis_names], m.to_user(v.q[k]), atol=TOL)
            rows.append(k)
            moves.append(moved)
            seconds.append(float(args))
            moved = False
    assert rows == list(range(len(v)))
    still = _standstill(v)
    assert moves == [True] + [bool(still[k] != still[k - 1]) for k in range(1, len(v))]
    assert sum(seconds) == pytest.approx(sum(d for _, d, _ in _expected_dwells(v)))


def _expected_dwells(t) -> list[tuple[int, float, bool]]:
    """(row, dwell [s], a further reading?) of every row: DWELL for the tool's first reading,
    NEST_DWELL for a nest's first, READ for every further reading of a point."""
    first = np.zeros(len(t), bool)
    first[_first_readings(t)] = True
    return [(k, (NEST_DWELL if t.instrument[k] == "nest" else DWELL) if first[k] else READ, not first[k])
            for k in range(len(t))]


def test_the_run_time_counts_the_readings_and_no_extra_move(plan):
    """The validation run's time as the program runs it, and plan.json's figure, against
    the same run read once: equal moves and approaches, dwells longer by a reading time
    per further reading, the dwells' sum that of the program's G4 blocks."""
    m, p = plan
    v, reads = p.validation_template, p.validation_reads
    once = v.take(_first_readings(v))
    timing = ProgramTiming(axis_speeds(m, p.settings.rapid_mm_min, p.settings.rapid_deg_min), p.steps, DWELL,
                           NEST_DWELL, read_dwell_s=READ)
    t, time = row_times(m, v, timing, reads)
    t1, time1 = row_times(m, once, timing)
    assert run_times(m, v, timing, reads)[1:] == (time, time1)  # the run read once, from the one pass, to the bit
    assert time.moves_s == pytest.approx(time1.moves_s) and time.approach_s == pytest.approx(time1.approach_s)
    assert time.dwell_s - time1.dwell_s == pytest.approx((reads - 1) * READ * len(once))
    axes = {a.name: (a.lower_user, a.upper_user) for a in m.axes}
    prog = run(write_program("gcode", m, v, p.steps, dwell_s=DWELL, nest_dwell_s=NEST_DWELL, reads=reads,
                             read_dwell_s=READ), "gcode", axes)
    assert sum(prog.dwells) == pytest.approx(time.dwell_s)
    assert np.all(np.diff(t) > 0) and t[-1] <= time.total_s


def test_the_simulator_draws_the_axes_once_per_standstill(machines):
    """Without tracker noise every reading of a point at its standstill is the same, and the
    nests' readings there are rigid (one table pose: scipy's Kabsch fits them to the true
    nests to 1e-9 m), yet off the noise-free run by the positioning noise; without axis
    noise the readings differ by the tracker's noise alone, per reading."""
    m = machines["trunnion_xyzac"]
    sim = simulate(m, seed=3, design=Design(n_commands=60, n_validation=20))
    truth = sim.truth
    R, t0, noise = truth.tracker.rotation, truth.tracker.translation, truth.tracker.noise
    k = VALIDATION_READS
    truth.tracker = Tracker(R, t0, TrackerNoise(0.0, 0.0, 0.0, 0.0))
    a = simulate(m, seed=4, truth=truth, design=Design(n_commands=60, n_validation=20))
    runs = a.validation.xyz.reshape(-1, k, 3)  # every point's k readings in a row
    assert np.abs(runs - runs[:, :1]).max() < 1e-12
    off = np.linalg.norm(a.validation.xyz - a.validation_truth.xyz, axis=1)
    assert np.median(off) > 1e-6
    for start in range(0, len(a.validation), 4 * k):  # the tool, then 3 nests, each k times
        nest = np.arange(start + k, start + 4 * k, k)
        P = np.array([a.nests[str(a.validation.target[i])] for i in nest])
        Q = a.validation.xyz[nest]
        rot = Rotation.align_vectors(Q - Q.mean(axis=0), P - P.mean(axis=0))[0].as_matrix()
        assert np.abs(Q - Q.mean(axis=0) - (P - P.mean(axis=0)) @ rot.T).max() < 1e-9
    truth.tracker, truth.repeatability = Tracker(R, t0, noise), np.zeros(m.n_axes)
    b = simulate(m, seed=5, truth=truth, design=Design(n_commands=60, n_validation=20))
    dev = (b.validation.xyz - b.validation_truth.xyz).reshape(-1, k, 3)
    assert np.abs(dev - dev[:, :1]).max() > 1e-6
    r = np.linalg.norm(b.validation_truth.xyz, axis=1)  # range [m]: the tracker's noise per reading
    expected = np.sqrt(np.mean(noise.sigma_range(r) ** 2 + 2 * (noise.sigma_angle(r) * r) ** 2))
    got = np.sqrt(np.sum((dev - dev.mean(axis=1, keepdims=True)) ** 2) / (len(dev) * (k - 1)))
    assert got == pytest.approx(expected, rel=0.1)


def _fd_axis_ms(m, c, sigma) -> float:
    """Mean over the rows of ``c`` of sum_j sigma_j^2 |d tip / d q_j|^2 [m^2], the tip
    relative to the table (workpiece frame) by central finite differences."""
    total = np.zeros(len(c))
    for j in range(m.n_axes):
        h = np.zeros(m.n_axes)
        h[j] = 1e-6
        d = (m.tool_tip(c.q + h, c.tool, frame="workpiece") - m.tool_tip(c.q - h, c.tool, frame="workpiece")) / 2e-6
        total += sigma[j] ** 2 * np.sum(d**2, axis=1)
    return float(total.mean())


def test_the_noise_netted_out_divides_the_tracker_not_the_axes(machines):
    """The noise vecpin nets out (net_of_noise) of a run whose points are read once and of
    the same run read VALIDATION_READS times: the tracker's part falls by the readings, the
    axes' part does not and is the finite-difference closed form; together they add."""
    m = machines["trunnion_xyzac"]
    sim = simulate(m, seed=3, design=Design(n_commands=60, n_validation=30))
    c4 = sim.validation_truth
    c1 = c4.subset(np.arange(0, len(c4), VALIDATION_READS))
    zero = TrackerNoise(0.0, 0.0, 0.0, 0.0)
    models = {"tracker": NoiseModel(np.zeros(m.n_axes), tracker=sim.truth.tracker.noise),
              "axes": NoiseModel(sim.truth.repeatability, tracker=zero),
              "both": NoiseModel(sim.truth.repeatability, tracker=sim.truth.tracker.noise)}
    ms = {}
    for label, noise in models.items():
        for reads, c in ((1, c1), (VALIDATION_READS, c4)):
            tt = table_tips(c, sim.nests)
            assert tt.commands == 30 and len(tt.rows) == 30
            net = net_of_noise(np.zeros((30, 3)), c, tt, noise, m, draws=120)
            ms[label, reads] = net.noise_rms**2 / (1 - 6 / (3 * 30)) * 1e-6  # [m^2], the registration's share back
    n = VALIDATION_READS
    assert ms["tracker", n] == pytest.approx(ms["tracker", 1] / n, rel=0.08)
    assert ms["axes", n] == pytest.approx(ms["axes", 1], rel=0.08)
    assert ms["axes", n] == pytest.approx(_fd_axis_ms(m, c1.primary(), sim.truth.repeatability), rel=0.08)
    assert ms["both", n] == pytest.approx(ms["tracker", n] + ms["axes", n], rel=0.08)
    assert ms["axes", n] > 0.5 * ms["tracker", n]  # the axes' part is no small share after averaging


def test_the_model_error_net_of_the_averaged_noise_is_the_noise_free_truth(machines):
    """150 validation commands of the A-C trunnion, every point read VALIDATION_READS times:
    evaluate's model error net of the noise is within three standard uncertainties of the
    truth's noise-free RMS (the true tip relative to the table against the model's, rigidly
    registered by scipy); netting out the axes' variance divided by the readings too would
    leave it more than three standard uncertainties above."""
    m = machines["trunnion_xyzac"]
    sim = simulate(m, seed=5, design=Design(n_commands=150, n_validation=150))
    model = make_model("6dof", m, 4, bases=sim.truth.family_bases()).fit(
        sim.campaign, NoiseModel.default(m, "spherical", tracker=sim.truth.tracker.noise))
    ev = evaluate(model, sim.validation)
    e = sim.validation_truth.primary()
    true = sim.truth.tool_tip(e.q, e.tool, None, frame="workpiece")
    mod = model.tool_tip(e.q, e.tool, model.b_, jacobian=False, frame="workpiece").tip
    cp, cq = mod.mean(axis=0), true.mean(axis=0)
    rot = Rotation.align_vectors(true - cq, mod - cp)[0].as_matrix()
    truth_rms = np.sqrt(np.mean(np.sum((true - ((mod - cp) @ rot.T + cq)) ** 2, axis=1))) * 1e3
    net = ev.net
    assert net.rows == 150 and abs(net.rms - truth_rms) < 3 * net.sd
    f = 1 - 6 / (3 * 150)
    axes_ms = f * _fd_axis_ms(m, e, model.noise_.axis_sigma) * 1e6  # [mm^2] the axes' share netted out
    wrong = np.sqrt(net.measured_rms**2 - (net.noise_rms**2 - axes_ms * (1 - 1 / VALIDATION_READS)))
    assert wrong - truth_rms > 3 * net.sd


def test_the_plan_files_carry_the_readings_and_both_times(machines, tmp_path):
    """plan_to_dir on a table machine: validation.ngc is the program reading every point
    VALIDATION_READS times at standstill, plan.json's validation minutes are its run's time
    and the time of the same run read once, which the plan's text prints beside it."""
    import json

    from vecpin.measurement.plantemplate import read_template
    from vecpin.workflows.planning import plan_timing, plan_to_dir
    from vecpin.workflows.simulating import plan_companions
    m = machines["trunnion_xyzac"]
    s = PlanSettings(n_commands=24, model="6dof", order=1, candidates=300, validation_points=30, n_validation=12)
    r = plan_to_dir(m, tmp_path, s, dialects=("gcode",), dwell_s=DWELL, nest_dwell_s=NEST_DWELL, read_dwell_s=READ)
    js = json.loads((tmp_path / "plan.json").read_text())["validation"]
    v = read_template(tmp_path / "validation.csv", m)
    timing = plan_timing(tmp_path / "plan.csv")
    assert timing.read_dwell_s == READ  # plan.json keeps it for the simulator, which stamps the further readings so
    assert plan_companions(m, tmp_path / "plan.csv", read_template(tmp_path / "plan.csv", m))["read_dwell_s"] == READ
    t4 = row_times(m, v, timing, VALIDATION_READS)[1].total_s
    t1 = row_times(m, v.take(_first_readings(v)), timing)[1].total_s
    assert js["reads"] == VALIDATION_READS and js["commands"] == 12 and js["rows"] == len(v)
    assert js["minutes"] == pytest.approx(t4 / 60, abs=1e-4)
    assert js["minutes_one_reading"] == pytest.approx(t1 / 60, abs=1e-4)
    assert f"{t4 / 60:.0f} min a run ({t1 / 60:.0f} min reading every point once)" in "\n".join(r.lines())
    axes = {a.name: (a.lower_user, a.upper_user) for a in m.axes}
    prog = run((tmp_path / "validation.ngc").read_text(), "gcode", axes)
    assert len(prog.dwells) == len(v)
    assert sum(prog.dwells) == pytest.approx(row_times(m, v, timing, VALIDATION_READS)[1].dwell_s)


def test_a_bad_read_dwell_is_named_by_its_flag(tmp_path, capsys):
    """`--read-dwell 0` (read_dwell_s) is refused before any planning, named by its flag."""
    from vecpin.cli.main import main
    from vecpin.errors import InputError
    with pytest.raises(InputError, match="`read_dwell_s` nan"):
        write_program("gcode", *_head_plan(), read_dwell_s=float("nan"))
    assert main(["plan", "trunnion_xyzac", "--read-dwell", "0", "--quiet", "--out", str(tmp_path / "p")]) == 2
    err = capsys.readouterr().err
    assert "--read-dwell 0: the dwell per further reading of a point is a time in seconds > 0" in err
    assert "Traceback" not in err and not (tmp_path / "p").exists()


def _head_plan():
    """(machine, template, steps) of a two-row plan template: enough for write_program to check its options."""
    import vecpin
    from vecpin.measurement.plantemplate import PlanTemplate
    m = vecpin.Machine.load("flow_xyzcb")
    q = (m.lower + m.upper)[None] / 2 * np.ones((2, 1))
    return m, PlanTemplate(np.array([1, 2]), q, np.full(2, 0.2)), np.zeros(m.n_axes)
