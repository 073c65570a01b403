"""Plans for machines with table axes (trunnions): table nests in the plan, its template,
its NC programs, a simulation of the plan and an import of a tracker export of it.

Truths the tests compare against are not the planner's own choice: the numerical rank
(SVD) of a dense design's Jacobian with and without the nests, the line of sight tested
again nest by nest, the simulated true machine, and the simulated readings joined back
by a second route (by name against by order)."""
import numpy as np
import pytest

from vecpin.measurement.campaign import Campaign
from vecpin.measurement.importer import import_export
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.plantemplate import point_name, read_template
from vecpin.models import make_model
from vecpin.planning.ncprogram import write_program
from vecpin.planning.plan import PlanSettings, make_plan
from vecpin.planning.sightline import SightLine
from vecpin.errors import CampaignFileError
from vecpin.simulation.judge import uncompensated_error, validation_commands, validation_error
from vecpin.simulation.simulate import simulate
from vecpin.units import to_mm

MODEL, ORDER = "6dof", 4   # the simulated truth has 6-DoF errors on every axis (an AP model cannot follow the table's)


@pytest.fixture(scope="module")
def trunnion_plan(machines):
    m = machines["trunnion_xyzac"]
    return make_plan(m, PlanSettings(n_commands=80, model=MODEL, order=ORDER, candidates=800, validation_points=150))


def _rank(W: np.ndarray) -> int:
    s = np.linalg.svd(W, compute_uv=False)
    return int(np.sum(s > 1e-8 * s[0]))


def test_plan_with_nests_identifies_the_table_axis_terms(trunnion_plan):
    """Counted against the SVD rank of a dense design (1000 quasi-random commands, every
    holder, every nest): the terms no design identifies are P - rank(dense with nests);
    the table-axis terms the nests add are the rank the nests add beyond their own 3
    coordinates each; the plan's own rows reach the dense design's rank, so they identify
    everything it does, and the table-axis terms end well below their prior (without the
    nests most keep it)."""
    p = trunnion_plan
    info, bare = p.information, p.bare
    assert len(p.nests) == 3 and p.machine.has_workpiece
    m = p.machine
    from scipy.stats import qmc
    q = m.lower + qmc.Halton(m.n_axes, seed=3).random(1000) * (m.upper - m.lower)
    dense = info.rows(q).reshape(-1, info.P)
    dense_bare = bare.rows(q).reshape(-1, bare.P)
    r_nests, r_bare = _rank(dense), _rank(dense_bare)
    seen_by = 6 * len(info.stations)  # a second station's pose: counted, seen by its own block only
    assert int((~info.keep).sum()) == info.P - seen_by - r_nests
    assert int((~bare.keep).sum()) == bare.P - seen_by - r_bare
    table = info.table_terms()
    assert table.sum() == (r_nests - 9) - r_bare and table.sum() > 20
    t = p.template
    W = info.measurement_rows(t.q, t.tool, t.instrument, t.target).reshape(-1, info.P)
    assert _rank(W) == r_nests
    sd = np.sqrt(np.diag(info.covariance(W)))
    ratio = sd[table] / info.sigma[table]
    assert np.median(ratio) < 0.1 and ratio.max() < 0.8  # 52 terms: median 0.01, worst 0.68 (a nest-height term)
    Wb = bare.row_blocks(t.q[t.tool_rows], t.tool[t.tool_rows]).reshape(-1, bare.P)
    post = np.sqrt(np.diag(bare.posterior(Wb)))[:bare.P]
    cols = np.flatnonzero(table[:bare.P])  # same model columns in both problems
    assert np.median(post[cols] / bare.sigma[cols]) > 0.95  # (a few are combinations: a tool-tip row sees part)
    assert p.without_nests.predicted.model_mean > 20 * p.score.predicted.model_mean


def test_nest_rows_follow_their_command_and_the_line_of_sight(trunnion_plan):
    """Each nest row repeats the command and holder of the tool row before it; nests are
    read once per chosen command (first holder), and exactly the nests a fresh line-of-
    sight test sees there (station 0's rows: a second station's block has its own test,
    test_plan_stations.py)."""
    p = trunnion_plan
    t = p.template.take(np.flatnonzero(p.template.stations == 0))
    nest = t.instrument == "nest"
    assert nest.sum() > 0 and t.instrument[0] == "tracker"
    prev = np.maximum.accumulate(np.where(~nest, np.arange(len(t)), 0))
    assert np.array_equal(t.q[nest], t.q[prev[nest]]) and np.all(t.tool[nest] == p.tools[0])
    sl = SightLine(p.machine, p.tracker)
    seen = np.column_stack([~sl.check_nests(p.commands, x, p.tools[0]).blocked for x in p.nests.values()])
    assert nest.sum() == seen.sum() < seen.size  # some nests are hidden by the trunnion at some commands
    for c, q in enumerate(p.commands):
        rows = np.flatnonzero(nest & np.all(np.isclose(t.q, q, atol=1e-12), axis=1))
        assert sorted(t.target[rows]) == sorted(np.array(list(p.nests))[seen[c]])


def test_template_and_nc_program_carry_the_nests(trunnion_plan, tmp_path):
    """The template CSV round-trips nest rows (instrument, nest id, planned position); the
    NC program moves only to the tool rows and names the nest points at each dwell; a
    nest row with another command than its tool row is refused with row and column."""
    p, m = trunnion_plan, trunnion_plan.machine
    f = tmp_path / "plan.csv"
    f.write_text(p.template.to_csv(m))
    t = read_template(f, m)
    assert np.array_equal(t.instrument, p.template.instrument) and np.array_equal(t.target, p.template.target)
    assert np.allclose(t.nest[t.nest_rows], p.template.nest[t.nest_rows], atol=1e-9)
    assert {k: tuple(np.round(v, 9)) for k, v in t.nests().items()} == \
        {k: tuple(np.round(v, 9)) for k, v in p.nests.items()}
    prog = write_program("gcode", m, t, p.steps)
    assert prog.count("G4 P") == len(t.tool_rows)
    k = int(t.nest_rows[0])
    assert f"then the table nests in this order: {t.target[k]} as {point_name(t.point[k])}" in prog
    lines = f.read_text().splitlines()
    cells = lines[k + 1].split(",")
    cells[1] = str(float(cells[1]) + 1.0)
    lines[k + 1] = ",".join(cells)
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(CampaignFileError) as e:
        read_template(f, m)
    assert e.value.row == k + 2 and e.value.column == m.axis_names[0]


def _export(campaign: Campaign, names, order) -> str:
    """A foreign tracker export: semicolons, decimal commas, inches, rows in ``order``."""
    rows = ["Name;Meas X [in];Meas Y [in];Meas Z [in]"]
    for i in order:
        x = campaign.xyz[i] * 1e3 / 25.4
        rows.append(";".join([names[i]] + [f"{v:.7f}".replace(".", ",") for v in x]))
    return "\n".join(rows) + "\n"


def test_simulated_plan_imports_by_name_and_fits_the_table_axes(trunnion_plan, tmp_path):
    """simulate the plan -> a foreign export with the nest points named after the template
    and shuffled -> import joins every nest reading to its nest (the same as a join by
    order of the unshuffled export) -> the fit relative to the workpiece is far below the
    uncompensated error, where the same commands without the nest rows leave most of it."""
    p, m = trunnion_plan, trunnion_plan.machine
    sim = simulate(m, seed=4, plan=p.template, tracker_position=p.tracker, station_positions=p.placement.stations)
    c = sim.campaign
    assert np.array_equal(c.instrument, p.template.instrument) and np.array_equal(c.target, p.template.target)
    plan_csv = tmp_path / "plan.csv"
    plan_csv.write_text(p.template.to_csv(m))
    names = [point_name(k) for k in p.template.point]
    shuffled = np.random.default_rng(0).permutation(len(c))
    (tmp_path / "named.txt").write_text(_export(c, names, shuffled))
    plain = _export(c, names, np.arange(len(c))).splitlines()
    (tmp_path / "plain.txt").write_text("\n".join(r.split(";", 1)[1] for r in plain) + "\n")  # no names
    by_name = import_export(tmp_path / "named.txt", m, plan_csv).campaign
    by_order = import_export(tmp_path / "plain.txt", m, plan_csv).campaign
    order = np.argsort(by_name.extra["point"])
    assert np.array_equal(by_name.extra["point"][order], p.template.point)
    for joined in (by_name.subset(order), by_order):
        assert np.array_equal(joined.instrument, c.instrument) and np.array_equal(joined.target, c.target)
        assert np.allclose(joined.xyz, c.xyz, atol=1e-9) and np.allclose(joined.q, c.q, atol=0)
    noise = NoiseModel.default(m, "spherical", tracker=sim.truth.tracker.noise)
    q, tool = validation_commands(m, 150, seed=7)
    unc = uncompensated_error(sim.truth, q, tool)
    with_nests = validation_error(make_model(MODEL, m, ORDER).fit(by_name, noise), sim.truth, q, tool)[0]
    tips = by_name.subset(by_name.tracker_rows)
    without = validation_error(make_model(MODEL, m, ORDER).fit(tips, noise), sim.truth, q, tool)[0]
    assert with_nests < 0.15 * unc and without > 0.7 * unc


@pytest.mark.slow   # an end-to-end run: kept out of the fast tier (its 180 s budget)
def test_plan_command_prints_the_nest_figures_and_refuses_nests_without_a_table(machines, tmp_path, capsys):
    """The printout names the nests, the table-axis terms they identify and the error
    relative to the workpiece with and without them; the tracker line says where it is
    assumed and why, whole mm without "-0"; --nest on a machine without a table branch,
    --nests that disagrees with the --nest count, and a --compare plan with other nests,
    are refused naming the option."""
    from vecpin.cli import main
    args = ["plan", "trunnion_xyzac", "--points", "40", "--order", "2", "--candidates", "400", "--quiet",
            "--nest", "A=100,0,40", "--nest", "B=-80,60,30", "--out", str(tmp_path / "p")]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "table nests: 2 reflectors" in out and "A (100, 0, 40); B (-80, 60, 30)" in out
    assert "table-axis terms identified:" in out and "without them" in out
    assert "on its +y side, from which the tips are in sight" in out and "-0," not in out and "(-0" not in out
    t = read_template(tmp_path / "p" / "plan.csv", machines["trunnion_xyzac"])
    assert set(t.target[t.nest_rows]) == {"A", "B"}
    for argv, text in ((args[:-2] + ["--nests", "3", "--out", str(tmp_path / "q")], "--nests 3 but 2 --nest"),
                       (["plan", "flow_xyzcb", "--points", "20", "--order", "1", "--nest", "1=0,0,0", "--out",
                         str(tmp_path / "r")], "--nest: machine 'flow_xyzcb' has no table branch"),
                       (args[:-2] + ["--nest", "C=1,2", "--out", str(tmp_path / "s")], "--nest 'C=1,2'"),
                       (args[:4] + ["--quiet", "--compare", str(tmp_path / "p" / "plan.csv"), "--out",
                                    str(tmp_path / "u")], "--compare plan.csv: nest 'A' is not one of the plan's")):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert text in err and "Traceback" not in err


@pytest.mark.slow   # an end-to-end run: kept out of the fast tier (its 180 s budget)
def test_predicted_error_matches_a_monte_carlo_of_simulate_and_fit(trunnion_plan):
    """The plan's predicted error of the tool tip relative to the workpiece (linearised
    covariance through the one likelihood, nests included) against 8 simulated campaigns
    of the planned rows (nest readings too) from one true machine, each fitted with a
    model of the truth's own error family (so model-form error is absent and only the
    measurement noise spreads the fit): the mean validation error agrees within a factor
    of 1.5 (measured: 0.0108 mm simulated, 0.0107 mm predicted, the second station's rows
    read from where it stands with its pose unknown)."""
    from vecpin.planning.information import Information
    from vecpin.planning.plan import score_rows
    from vecpin.simulation.truth import TrueMachine
    p, m = trunnion_plan, trunnion_plan.machine
    truth = TrueMachine.random(m, np.random.default_rng(11))
    noise = NoiseModel.default(m, "spherical", tracker=truth.tracker.noise)
    info = Information(make_model(MODEL, m, ORDER, bases=truth.family_bases()), noise, p.tracker, p.tools, nests=p.nests,
                       stations=p.placement.stations[1:])
    predicted = to_mm(score_rows(info, p.template, p.validation, p.tools[0], "plan")[0].predicted.model_mean)
    tool = np.full(len(p.validation), p.tools[0])
    runs = []
    for seed in range(8):
        sim = simulate(m, seed=seed, plan=p.template, truth=truth, tracker_position=p.tracker,
                       station_positions=p.placement.stations)
        fitted = make_model(MODEL, m, ORDER, bases=truth.family_bases()).fit(sim.campaign, noise)
        runs.append(validation_error(fitted, sim.truth, p.validation, tool)[0])
    assert 1 / 1.5 < np.mean(runs) / predicted < 1.5


# A rotary table C (about z at the origin) carrying the workpiece frame 0.5 m up, a spindle
# on X-Y-Z far away, and one fixed post on the base: 0.95 < x < 1.05, -0.1 < y < 0.1,
# 0 < z < 1. A nest at (0.5, 0, 0.05) in the workpiece frame is at
# (0.5 cos C, 0.5 sin C, 0.55) on the base; the tracker at (3, 0, 0.55) sees it unless the
# straight line crosses the post: at x = 1 the line is at y = 2 * 0.5 sin C / (3 - 0.5 cos C).
NEST_URDF = """<robot name="nest_los">
  <link name="base"><visual><origin xyz="1.0 0 0.5"/><geometry><box size="0.1 0.2 1.0"/></geometry></visual></link>
  <joint name="C" type="revolute"><parent link="base"/><child link="table"/><axis xyz="0 0 1"/>
    <limit lower="-3.14159" upper="3.14159" effort="1" velocity="1"/></joint>
  <link name="table"/>
  <joint name="wp" type="fixed"><parent link="table"/><child link="workpiece"/><origin xyz="0 0 0.5"/></joint>
  <link name="workpiece"/>
  <joint name="X" type="prismatic"><parent link="base"/><child link="xc"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="xc"/>
  <joint name="Y" type="prismatic"><parent link="xc"/><child link="yc"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="yc"/>
  <joint name="Z" type="prismatic"><parent link="yc"/><child link="spindle"/><axis xyz="0 0 1"/>
    <origin xyz="-2 0 2"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>
  <link name="spindle"/>
</robot>"""


def test_line_of_sight_to_a_nest_on_a_turning_table_in_closed_form():
    """The nest is hidden by the post exactly where the closed form says (angles whose
    line grazes the post's edge left out): the table turns the nest behind the post and
    out again."""
    from vecpin import Machine
    m = Machine.from_urdf_string(NEST_URDF, "nest_los")
    assert m.has_workpiece
    sl = SightLine(m, np.array([3.0, 0.0, 0.55]), tool_radius=0.0, target_clearance=0.0)
    C = np.radians(np.arange(-180.0, 180.0, 1.0))
    xn, yn = 0.5 * np.cos(C), 0.5 * np.sin(C)   # the nest on the base, always behind the post (xn < 0.95)
    y_faces = np.abs(np.array([(3 - x) * yn / (3 - xn) for x in (0.95, 1.05)]))  # the line at the post's faces
    hidden = y_faces.max(axis=0) < 0.1
    seen = y_faces.min(axis=0) > 0.1
    clear = hidden | seen                       # angles whose line does not graze the post's edge
    q = np.zeros((len(C), m.n_axes))
    q[:, m.axis_names.index("C")] = C
    blocked = sl.check_nests(q, np.array([0.5, 0.0, 0.05]), 0.1).blocked
    assert clear.sum() > 300 and hidden.sum() > 20 and seen.sum() > 200
    assert np.array_equal(blocked[clear], hidden[clear])


def test_placed_nests_and_a_second_station_see_the_table_as_recounted_nest_by_nest(machines):
    """The B-C trunnion seen from the default tracker: the default nests give few commands
    three nests. The placement's figures are recounted here with the line of sight tested
    again nest by nest and station by station (no shared poses): the covered share per
    tenth of each table axis equals the placement's own; the placed nests stand on the
    table, in directions at least 60 deg apart; the proposed second station stands apart
    from the first and the pair sees the table over more of its travel than the default
    nests from one station."""
    from vecpin.planning.nestplacement import BINS, place_nests
    from vecpin.planning.nests import NEST_HEIGHTS, nest_reach
    from vecpin.planning.sightline import default_tracker_position
    m, tool = machines["trunnion_xyzbc"], 0.21488
    tracker = default_tracker_position(m)
    p = place_nests(m, tracker, 3, tool)
    q = p.commands
    covered = np.zeros(len(q), bool)
    for st in p.stations:
        sl = SightLine(m, st)
        seen = np.array([~sl.check_nests(q, x, tool).blocked for x in p.nests.values()]).T
        covered |= ~sl.check(q, tool).blocked & (seen.sum(axis=1) >= 3)
    for name, share in p.covered.items():
        a = m.axis(name)
        b = np.clip(((q[:, a.index] - a.lower) / a.travel * BINS).astype(int), 0, BINS - 1)
        np.testing.assert_allclose(share, [covered[b == k].mean() for k in range(BINS)])
    xyz = np.array(list(p.nests.values()))
    assert np.all(np.hypot(xyz[:, 0], xyz[:, 1]) <= nest_reach(m) + 1e-9)
    assert np.all((xyz[:, 2] >= NEST_HEIGHTS[0]) & (xyz[:, 2] <= NEST_HEIGHTS[1]))
    ang = np.degrees(np.arctan2(xyz[:, 1], xyz[:, 0]))
    gaps = np.abs((ang[:, None] - ang[None, :] + 180) % 360 - 180)[np.triu_indices(3, 1)]
    assert gaps.min() >= 60 - 1e-6
    assert len(p.stations) == 2 and np.linalg.norm(p.stations[1] - p.stations[0]) > 0.5
    assert p.commands_seen(p.covered) > p.commands_seen(p.default_covered) + 0.1
    assert p.travel_seen(p.covered) >= p.travel_seen(p.default_covered)


def test_the_plan_reads_the_placed_nests_and_prints_the_second_station(trunnion_plan):
    """The plan's template reads the nests the placement chose, and its nest lines say
    where the second station stands."""
    from vecpin.workflows.planning import PlanRun
    p = trunnion_plan.placement
    assert p is not None and set(trunnion_plan.nests) == set(p.nests)
    t = trunnion_plan.template
    for nid, x in p.nests.items():
        np.testing.assert_allclose(t.nest[t.target == nid], np.tile(x, ((t.target == nid).sum(), 1)))
    text = "\n".join(PlanRun(trunnion_plan, []).nest_lines())
    assert "table nests placed for the line of sight" in text
    if len(p.stations) > 1:
        assert "tracker station 2 at" in text
