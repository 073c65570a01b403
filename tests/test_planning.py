"""Planning: D-optimal choice against a brute-force greedy, the linearised covariance against
the fit's, tours against known optima, zones, approach, templates, NC programs read back
by a G-code reader of the tests' own (tests/gcode.py), byte-identical reruns, the CLI."""
import numpy as np
import pytest

from gcode import GCodeError, parse
from vecpin.cli import main
from vecpin.errors import CampaignFileError, InputError
from vecpin.measurement.campaign import read_campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.plantemplate import read_template
from vecpin.models import make_model
from vecpin.planning import route
from vecpin.planning.doptimal import greedy_d_optimal
from vecpin.planning.information import Information
from vecpin.planning.ncprogram import DIALECTS, write_program
from vecpin.planning.plan import PlanSettings, make_plan
from vecpin.planning.sightline import SightLine
from vecpin.planning.zones import inside, parse_zone
from vecpin.simulation.simulate import simulate
from vecpin.workflows.planning import plan_to_dir

SMALL = dict(n_commands=24, order=2, candidates=300, validation_points=100)


@pytest.fixture(scope="module")
def small_plan(flow):
    return make_plan(flow, PlanSettings(**SMALL, repeat_points=3, repeat_times=4,
                                        exclude=[{"X": (0.0, 2000.0), "B": (-111.0, -30.0)}]))


def test_greedy_matches_a_brute_force_greedy():
    """Woodbury-updated gains equal log det of the normal matrix computed directly, and
    each pick is the candidate a naive greedy (one determinant per candidate) picks."""
    rng = np.random.default_rng(1)
    C, r, P = 40, 6, 12
    W = rng.normal(size=(C, r, P)) * rng.uniform(0.1, 2.0, (C, 1, 1))
    keep = np.ones(P, bool)
    keep[[3, 7]] = False
    pick, logdet = greedy_d_optimal(W, 10, keep, refresh=4)
    Wk = W[:, :, keep]
    N = np.eye(keep.sum())
    for k, s in enumerate(pick):
        gains = [np.linalg.slogdet(N + Wk[c].T @ Wk[c])[1] if c not in pick[:k] else -np.inf for c in range(C)]
        assert s == int(np.argmax(gains))
        N = N + Wk[s].T @ Wk[s]
        np.testing.assert_allclose(logdet[k], np.linalg.slogdet(N)[1], rtol=1e-10)


def test_plan_covariance_is_the_fits(flow):
    """The plan's linearised covariance (nominal machine) against the covariance the
    estimator reports after fitting the plan measured on a true machine (Cartesian noise)."""
    s = PlanSettings(n_commands=40, order=2, candidates=400, noise=NoiseModel.default(flow, "cartesian"),
                     sight=False, validation_points=50)
    plan = make_plan(flow, s)
    sim = simulate(flow, 5, plan=(plan.template.q, plan.template.tool), mean_error_mm=0.3)
    model = make_model("ap", flow, 2).fit(sim.campaign, s.noise)
    fit_sd = np.sqrt(np.diag(model.cov_))
    plan_sd = np.sqrt(np.diag(plan.covariance))
    both = (fit_sd > 0) & (plan_sd > 0)
    assert both.sum() >= plan.information.keep.sum() - 6
    ratio = plan_sd[both] / fit_sd[both]
    assert np.median(np.abs(ratio - 1)) < 0.02 and np.all(np.abs(ratio - 1) < 0.15)


def test_doptimal_beats_random_on_its_own_criterion(flow):
    base = dict(n_commands=30, order=2, candidates=500, sight=False, validation_points=200)
    d = make_plan(flow, PlanSettings(**base))
    r = make_plan(flow, PlanSettings(**base, method="random"))
    assert d.score.log_det > r.score.log_det
    assert d.score.predicted.model_max < r.score.predicted.model_max


def test_plan_respects_zones_sight_limits_and_grid(flow, small_plan):
    p = small_plan
    t = p.template
    assert len(p.commands) == 24
    # 3 points x 4 sequences of repeats (2 at the start, 2 at the end) + 24 x 2 holders
    assert len(t) == 12 + 48 and list(t.point) == list(range(1, 61))
    assert not inside(flow, t.q, p.settings.exclude).any()
    assert SightLine(flow, p.tracker).check(p.commands, p.tools[0]).blocked.sum() == 0
    assert SightLine(flow, p.tracker).check(p.commands, p.tools[1]).blocked.sum() == 0
    steps = p.steps
    pre = t.q - t.approach * steps
    assert np.all(pre >= flow.lower - 1e-12) and np.all(t.q <= flow.upper + 1e-12)
    user = flow.to_user(t.q)
    np.testing.assert_allclose(user, np.round(user, 3), atol=1e-9)  # on the 0.001 mm / 0.001 deg grid
    np.testing.assert_allclose(t.tool[:6], p.tools[0])
    # the second holder visits the commands in reverse order
    main1, main2 = t.q[6:30], t.q[30:54]
    np.testing.assert_allclose(main1, main2[::-1])
    assert (p.removed == "exclusion").sum() > 0 and (p.removed == "sight").sum() > 0


def test_tour_on_a_line_is_monotone():
    """Points on a line in random order: the shortest open tour visits them sorted."""
    rng = np.random.default_rng(0)
    x = rng.permutation(np.linspace(0, 1, 60))
    q = np.c_[x, 0.3 * x, np.zeros(60)]
    speed = np.array([1.0, 1.0, 1.0])
    order = route.order_points(q, speed, start=np.zeros(3))
    np.testing.assert_allclose(np.sort(x), x[order])
    assert route.travel_time(q[order], speed) == pytest.approx(1.0)


def test_two_opt_undoes_a_crossing_and_move_time_is_the_slowest_axis():
    q = np.array([[0, 0], [1, 1], [1, 0], [0, 1.0]])
    D = route.move_times(q[:, None], q[None], np.array([1.0, 1.0]))
    assert D[0, 1] == 1.0  # diagonal move of both axes together takes the slower one's time
    tour = route.two_opt(np.array([0, 1, 2, 3]), D)
    assert route.travel_time(q[tour], np.ones(2)) == pytest.approx(3.0)
    assert route.move_times(np.zeros(2), np.array([1.0, 1.0]), np.array([1.0, 0.5])) == 2.0


def test_zone_parsing_and_errors(flow):
    z = parse_zone("X=0:500,B=-111:-80")
    assert z == {"X": (0.0, 500.0), "B": (-111.0, -80.0)}
    q = flow.to_si(np.array([[100, 0, 0, 0, -90], [100, 0, 0, 0, 0], [600, 0, 0, 0, -90.0]]))
    assert list(inside(flow, q, [z])) == [True, False, False]
    with pytest.raises(InputError, match="exclusion zone"):
        parse_zone("X=0..500")
    with pytest.raises(InputError, match="`zone`"):
        make_plan(flow, PlanSettings(n_commands=5, zone={"X": (7000.0, 8000.0)}))


def test_template_round_trip_and_filled_template_reads_as_a_campaign(flow, small_plan, tmp_path):
    t = small_plan.template
    path = tmp_path / "plan.csv"
    path.write_text(t.to_csv(flow))
    back = read_template(path, flow)
    np.testing.assert_allclose(back.q, t.q, atol=1e-12)
    np.testing.assert_allclose(back.tool, t.tool)
    np.testing.assert_array_equal(back.approach, t.approach)
    with pytest.raises(CampaignFileError) as e:
        read_campaign(path, flow)
    # a plan's template (no reading on any row) is named as such, not as an empty cell of row 2
    assert e.value.row is None and e.value.column == "x" and "vecpin import" in str(e.value)
    tips = flow.tool_tip(t.q, t.tool) * 1e3
    lines = path.read_text().splitlines()
    filled = [lines[0]] + [ln.replace(",,,", f",{a:.6f},{b:.6f},{c:.6f}", 1) for ln, (a, b, c) in zip(lines[1:], tips)]
    (tmp_path / "filled.csv").write_text("\n".join(filled) + "\n")
    c = read_campaign(tmp_path / "filled.csv", flow)
    np.testing.assert_allclose(c.xyz, tips * 1e-3, atol=1e-9)
    np.testing.assert_array_equal(c.extra["point"], t.point)


def test_template_errors_name_row_and_column(flow, tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("point,X,Y,Z,C,B,tool,x,y,z\n1,10,10,10,0,0,214.88,,,\n1,20,10,10,0,0,214.88,,,\n")
    with pytest.raises(CampaignFileError, match="point 1 appears on rows 2, 3") as e:
        read_template(p, flow)
    assert e.value.row == 3 and e.value.column == "point"
    p.write_text("point,X,Y,Z,C,B,tool,x,y,z\n1,10,10,10,0,300,214.88,,,\n")
    with pytest.raises(CampaignFileError, match="outside the axis limits") as e:
        read_template(p, flow)
    assert e.value.column == "B"


def _axes(machine, names=None):
    names = names or machine.axis_names
    return {n: (a.lower_user, a.upper_user) for n, a in zip(names, machine.axes)}


@pytest.mark.parametrize("dialect", list(DIALECTS))
def test_nc_program_visits_the_template(flow, small_plan, dialect):
    """Run by the tests' own interpreter (tests/gcode.py; the safety of the moves between
    points: tests/test_ncprogram_safety.py): every row of the template is approached from
    below, reached at the feed, and followed by the dwell; the holder changes are
    programmed stops naming the length; each point's name is a comment."""
    p = small_plan
    t = p.template
    text = write_program(dialect, flow, t, p.steps, dwell_s=3.5, feed_mm_min=800.0)
    prog = parse(text, dialect, _axes(flow))
    assert len(prog.dwells) == len(t) and set(prog.dwells) == {3.5}
    g1 = [mv for mv in prog.moves if mv.code == 1]
    assert len(g1) == len(t)
    cmd = np.array([[mv.pos[a] for a in flow.axis_names] for mv in g1])
    app = np.array([[mv.before[a] for a in flow.axis_names] for mv in g1])
    np.testing.assert_allclose(cmd, flow.to_user(t.q), atol=5e-4)
    np.testing.assert_allclose(cmd - app, t.approach * flow.to_user(p.steps), atol=1e-3)  # the plan's approach column
    assert np.all(app[:, 2] >= cmd[:, 2] - 1e-3)  # Z never from below (toward the work; issue 41)
    assert all(mv.feed == 800.0 for mv in g1)
    # each point: the G1 to it, then its dwell
    kinds = [("g1" if prog.moves[e[1]].code == 1 else "g0") if e[0] == "move" else e[0] for e in prog.events
             if e[0] in ("move", "dwell")]
    assert [k for i, k in enumerate(kinds) if i + 1 < len(kinds) and kinds[i + 1] == "dwell"] == ["g1"] * len(t)
    # holder changes: a stop before the first row, one when the length changes to 312.86 and back for the repeats
    assert len(prog.stops) == 3
    assert "214.880" in prog.stops[0][1] and "312.860" in prog.stops[1][1]
    names = [c for c in prog.comments if c.upper().startswith("P0")]
    assert names[:2] == ["P0001", "P0002"] and len(names) == len(t)


def test_nc_axis_names_and_options_are_checked(flow, small_plan):
    p = small_plan
    with pytest.raises(InputError, match="`axis_map`"):
        write_program("fanuc", flow, p.template, p.steps, axis_map={"B": "Q"})
    with pytest.raises(InputError, match="repeat"):
        write_program("gcode", flow, p.template, p.steps, axis_map={"B": "C"})
    text = write_program("siemens-840d", flow, p.template, p.steps, axis_map={"B": "B1"})
    prog = parse(text, "siemens-840d", _axes(flow, ["X", "Y", "Z", "C", "B1"]))
    assert sum(mv.code == 1 for mv in prog.moves) == len(p.template) and "B1=" in text
    with pytest.raises(InputError, match="`dwell_s`"):
        write_program("gcode", flow, p.template, p.steps, dwell_s=0)
    with pytest.raises(InputError, match="`nest_dwell_s`"):
        write_program("gcode", flow, p.template, p.steps, nest_dwell_s=-1)


def test_gcode_reader_rejects_what_the_programs_must_not_contain(flow):
    axes = _axes(flow)
    head = "G21\nG17 G40 G49 G80 G90 G94\n"
    ok = head + "G90 G53 G0 X1 Y1 Z1 C0 B0\nG90 G53 G1 X1 Y1 Z2 C0 B0 F100\nG4 P1\nM2\n"
    parse(ok, "gcode", axes)
    for bad in (head + "G90 G53 G0 X1 Y1 Z1 C0 B0\nG90 G53 G2 X1 Y1 Z1 C0 B0\nM2\n",      # an arc
                head + "G90 G53 G0 X1 Y1 Z1 C0 B200\nM2\n",                             # beyond B's limit
                head + "G91 G1 X1 F100\nM2\n",                                         # from an unknown position
                head + "G43 H1\nM2\n",                                                 # tool length compensation
                "G90 G53 G0 X1 Y1 Z1 C0 B0\nM2\n"):                                   # no G21, no G49
        with pytest.raises(GCodeError):
            parse(bad, "gcode", axes)


def test_plan_files_are_byte_identical_on_rerun(flow, tmp_path):
    s = PlanSettings(**SMALL)
    a = plan_to_dir(flow, tmp_path / "a", s)
    plan_to_dir(flow, tmp_path / "b", PlanSettings(**SMALL))
    names = sorted(p.name for p in a.files)
    assert names == sorted(["plan.csv", "PLAN_840D.MPF", "O1000.nc", "plan.ngc", "plan.png", "plan.json",
                            "validation.csv", "VALID_840D.MPF", "O1001.nc", "validation.ngc"])
    for n in names:
        assert (tmp_path / "a" / n).read_bytes() == (tmp_path / "b" / n).read_bytes(), n


def test_plan_cli_prints_prediction_and_comparison(tmp_path, capsys):
    out = tmp_path / "p"
    assert main(["plan", "flow_xyzcb", "--points", "20", "--order", "2", "--candidates", "300", "--repeat", "3", "4",
                 "--tracker", "3000,-2300,-300", "--exclude", "X=0:1000", "--compare", "random", "--out", str(out),
                 "--quiet"]) == 0
    text = capsys.readouterr().out
    for needle in ("model error from parameter uncertainty", "validation residual", "random commands",
                   "this plan (doptimal)", "(given)", "out of sight", "repeated points (eq. 22): 3 commands x 4"):
        assert needle in text
    assert "no repeated points" not in text
    assert "less than the 30 min that part two sessions" in text   # a short campaign: no long-term repeatability
    assert main(["plan", "flow_xyzcb", "--points", "20", "--order", "2", "--candidates", "300", "--compare",
                 str(out / "plan.csv"), "--out", str(tmp_path / "q"), "--quiet"]) == 0
    text = capsys.readouterr().out
    # without repeated points the decision cannot be made from the campaign: the plan says how to add them
    assert "plan.csv" in text and "no repeated points" in text and "--repeat 9 4:" in text


@pytest.mark.parametrize("argv, message", [
    (["--tracker", "1,2"], "--tracker '1,2'"),
    (["--tools", "a,b"], "--tools 'a,b'"),
    (["--repeat", "3", "1"], "--repeat"),
    (["--tracker", "3000,1000,-1300"], "inside the machine's geometry"),
    (["--points", "5000"], "--candidates 300: between --points (5000)"),
])
def test_plan_cli_errors(tmp_path, capsys, argv, message):
    assert main(["plan", "flow_xyzcb", "--order", "1", "--candidates", "300", "--out", str(tmp_path / "o")] + argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_information_rows_are_whitened_like_the_fit(flow):
    """With Cartesian noise and (almost) no axis noise the whitened, prior-scaled rows are
    the model's J_b times the prior sigma over the tracker sigma."""
    m = make_model("ap", flow, 1)
    noise = NoiseModel(np.zeros(flow.n_axes) + 1e-12, "cartesian", 2e-5)
    info = Information(m, noise, np.array([3.0, -2.0, 0.0]), [0.2])
    q = flow.lower + np.random.default_rng(2).random((5, 5)) * (flow.upper - flow.lower)
    W = info.row_blocks(q, np.full(5, 0.2))
    J = m.tool_tip(q, 0.2, np.zeros(m.n_parameters)).J_b
    ref = J * info.sigma[6:] / 2e-5
    np.testing.assert_allclose(W[:, :, 6:], ref, rtol=1e-6, atol=1e-9 * np.abs(ref).max())
