"""The tables workflow: limits and missing facts refused before any computation, the
profile, honest report rows (same points, parameter uncertainty), reproducible files."""
import json
from pathlib import Path

import numpy as np
import pytest

from vecpin.compensation import plan as plan_module
from vecpin.compensation.frame import model_as_actual
from vecpin.compensation.report import compensated_errors
from vecpin.compensation.plan import parameter_spread, plan_tables
from vecpin.errors import ControllerLimitError, InputError
from vecpin.export.profile import ControllerProfile
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.registration import registered_errors
from vecpin.models import make_model
from vecpin.simulation.simulate import Design, simulate
from vecpin.workflows.tables import make_tables

pytestmark = pytest.mark.slow   # a long matrix: the edit loop (-m 'not slow') leaves it to CI

PROFILE = {"format": "vecpin-controller-profile", "version": 1}


@pytest.fixture(scope="module")
def model(machines):
    flow = machines["flow_xyzcb"]
    sim = simulate(flow, seed=5, design=Design(n_commands=150))
    return make_model("ap", flow, 3).fit(sim.campaign, NoiseModel.default(flow, "spherical"))


@pytest.fixture
def no_solving(monkeypatch):
    def refuse(*a, **k):
        raise AssertionError("the table problem was built before the limits were checked")
    monkeypatch.setattr(plan_module, "TableProblem", refuse)


def test_limits_and_missing_facts_are_refused_before_computing(model, tmp_path, no_solving):
    with pytest.raises(ControllerLimitError, match="`points` 10000000"):
        make_tables(model, tmp_path, "generic", points=10_000_000)
    with pytest.raises(ControllerLimitError, match="`points` 10000000"):
        plan_tables(model, points=10_000_000)
    with pytest.raises(ControllerLimitError, match="at most 200 points"):
        make_tables(model, tmp_path, "siemens-828d", points=1024)
    with pytest.raises(InputError, match="reference position"):
        make_tables(model, tmp_path, "fanuc-30i", profile=ControllerProfile.from_dict(
            PROFILE | {"axes": {a: {"number": k + 1} for k, a in enumerate(model.machine.axis_names)}}))
    with pytest.raises(InputError, match="X=NAME"):
        make_tables(model, tmp_path, "siemens-840d", axis_map={"Y": "Y1"})
    with pytest.raises(ControllerLimitError, match="at most 0 cross tables, not 3"):
        make_tables(model, tmp_path, "linuxcnc", max_tables=3,
                    profile=ControllerProfile(limits={"max_cross_tables": 0}))
    with pytest.raises(InputError, match="`sign_test` Q"):
        make_tables(model, tmp_path, "linuxcnc", sign_test="Q")


def test_profile_checks(model, tmp_path):
    m = model.machine
    with pytest.raises(InputError, match="'axes.X.refrence_position': unknown"):
        ControllerProfile.from_dict(PROFILE | {"axes": {"X": {"refrence_position": 0.0}}})
    with pytest.raises(InputError, match="'axes.X.number': a whole number"):
        ControllerProfile.from_dict(PROFILE | {"axes": {"X": {"number": "1"}}})
    with pytest.raises(InputError, match="has no axis 'W'"):
        ControllerProfile.from_dict(PROFILE | {"axes": {"W": {}}}).check_machine(m, "generic")
    with pytest.raises(InputError, match="for machine 'snk_120v'"):
        ControllerProfile.from_dict(PROFILE | {"machine": "snk_120v"}).check_machine(m, "generic")
    with pytest.raises(InputError, match="both have nc_name 'X1'"):
        ControllerProfile.from_dict(PROFILE | {"axes": {"X": {"nc_name": "X1"}, "Y": {"nc_name": "X1"}}}
                                    ).check_machine(m, "generic")
    with pytest.raises(InputError, match="only rotary axes are modulo"):
        ControllerProfile.from_dict(PROFILE | {"axes": {"X": {"modulo": True}}}).check_machine(m, "generic")
    p = tmp_path / "p.json"
    p.write_text(json.dumps(PROFILE | {"axes": {"X": {"nc_name": "X1"}}}))
    prof = ControllerProfile.load(p).with_axis_map({"X": "X9"})
    assert prof.axis("X").nc_name == "X9" and prof.axis_by_nc_name("X9") == "X"
    with pytest.raises(InputError, match="'max_points' is not a limit"):
        from vecpin.export.registry import get_format
        get_format("fanuc-30i").limits_for(ControllerProfile.from_dict(PROFILE | {"limits": {"max_points": 3}}))


def test_report_rows_share_points_and_carry_the_parameter_spread(model):
    plan = plan_tables(model, n_commands=300)
    rep = plan.report
    assert "every row on these points" in rep.basis and "300 quasi-random commands" in rep.basis
    assert all("model" in r.label for r in rep.rows)
    assert any("fit residual" in n and "not these" in n for n in rep.notes)
    full = [r for r in rep.rows if r.label.startswith("full")][0]
    # the model almost cancels itself (what is left is the turn into its reference frame that the tables of
    # its rotary axes cannot follow exactly); the data do not
    assert full.mean < 0.01 and full.spread[0] > full.mean
    assert all(r.spread is not None and r.spread[1] <= r.spread[0] <= r.spread[2] for r in rep.rows)
    # a model read from a file keeps standard deviations only: no spread, said so
    model2 = make_model("ap", model.machine, 3)
    model2.__dict__.update({k: v for k, v in model.__dict__.items() if k.endswith("_")})
    model2.cov_ = np.diag(np.diag(model.cov_))
    rep2 = plan_tables(model2, n_commands=100).report
    assert all(r.spread is None for r in rep2.rows) and any("standard deviations only" in n for n in rep2.notes)


def test_a_model_read_back_from_its_file_keeps_the_spread(model, tmp_path):
    """Model files keep the correlations: the spread of a read-back model equals the
    in-session one (6-decimal correlations)."""
    from vecpin.models import ErrorModel
    model.save(tmp_path / "m.json")
    back = ErrorModel.load(tmp_path / "m.json")
    a = plan_tables(model, n_commands=100).report
    b = plan_tables(back, n_commands=100).report
    for ra, rb in zip(a.rows, b.rows):
        assert rb.spread is not None and abs(ra.spread[0] - rb.spread[0]) <= 0.01 * ra.spread[0] + 1e-7


def test_parameter_spread_matches_nonlinear_draws(model):
    """The linearised spread against the model evaluated at parameter draws (no linearisation)."""
    plan = plan_tables(model, n_commands=200, uncertainty=False)
    q, L, m = plan.problem.q, plan.problem.L, model.machine
    lin = parameter_spread(model, plan.tables, q, L, draws=400, seed=1)
    rng = np.random.default_rng(7)
    cov = model.cov_[6:, 6:]
    w, U = np.linalg.eigh(0.5 * (cov + cov.T))
    F = U * np.sqrt(np.clip(w, 0, None))
    b0 = model.b_.copy()
    means = []
    nominal = m.tool_tip(q, L + plan.tables.gauge_offset_change)
    for _ in range(60):
        b = b0 + F @ rng.standard_normal(len(b0))
        tip = model.tool_tip(plan.tables.apply(q), L, b, jacobian=False).tip
        means.append(np.linalg.norm(registered_errors(nominal, tip), axis=1).mean() * 1e3)
    assert np.mean(means) == pytest.approx(lin[0], rel=0.1)
    assert np.std(means) == pytest.approx((lin[2] - lin[1]) / 2, rel=0.5)
    actual = compensated_errors(model_as_actual(model), m, plan.tables, q, L)
    assert np.linalg.norm(actual, axis=1).mean() * 1e3 < lin[0]


def test_profile_modulo_axes_give_modulo_tables_and_pitch_only_controllers(model, tmp_path):
    prof = ControllerProfile.from_dict(PROFILE | {"axes": {"C": {"modulo": True}}})
    run = make_tables(model, tmp_path / "g", "generic", profile=prof, uncertainty=False)
    assert all(t.modulo for t in run.plan.tables.tables if t.input_axis == "C")
    pitch_only = ControllerProfile(limits={"max_cross_tables": 0})
    run = make_tables(model, tmp_path / "l", "linuxcnc", profile=pitch_only, uncertainty=False)
    assert sorted(run.plan.tables.names()) == ["bb", "cc", "xx", "yy", "zz"]
    assert not (tmp_path / "l" / "vecpin_vec.comp").exists()
    labels = [r.label for r in run.plan.report.rows]
    assert {"full tables (model-predicted)", "pitch only (model-predicted)", "files as written (model-predicted)"} <= set(labels)
    written = [r for r in run.plan.report.rows if r.label.startswith("files")][0]
    pitch = [r for r in run.plan.report.rows if r.label.startswith("pitch")][0]
    assert written.mean == pytest.approx(pitch.mean, rel=1e-3)           # 256 points, 1 nm: what was planned


def test_reruns_write_identical_files(model, tmp_path):
    prof = Path(__file__).parent / "data" / "controllers" / "flow_xyzcb_profile.json"
    for d in ("a", "b"):
        make_tables(model, tmp_path / d, "fanuc-30i", profile=prof, max_tables=1, method="heuristic",
                    sign_test="X", uncertainty=False)
    names = sorted(p.name for p in (tmp_path / "a").iterdir())
    assert names == sorted(p.name for p in (tmp_path / "b").iterdir()) and len(names) > 8
    for n in names:   # the manifest records the time and a new generation id
        assert n == "vecpin-manifest.json" or (tmp_path / "a" / n).read_bytes() == (tmp_path / "b" / n).read_bytes(), n


def test_the_first_line_measures_the_files_against_what_the_tables_remove(model, tmp_path):
    """Issue 39: the AP model's full tables almost cancel the model (in its reference frame, to
    about 0.01 mm); the first line measured the files against that ('+4545 %'). Fanuc's six
    cross tables give up a share of what the full tables remove, which the first line (and
    the README's) now states from the rows; Siemens takes every table and says nothing."""
    prof = Path(__file__).parent / "data" / "controllers" / "flow_xyzcb_profile.json"
    run = make_tables(model, tmp_path / "f", "fanuc-30i", profile=prof, max_tables=6, uncertainty=False)
    rows = {r.label: r.mean for r in run.plan.report.rows}
    before, full = rows["uncompensated (model)"], rows["full tables (model-predicted)"]
    files = rows["files as written (model-predicted)"]
    assert full < 0.05 * before and 0.1 < before            # mm: near degenerate, the tables are almost the model
    share = (files - full) / (before - full)
    assert share > 0.02 and run.headline == run.lines("m")[0]
    assert run.headline.startswith(f"NOTE: these files give up {100 * share:.0f} % of what the full tables remove")
    assert "takes 11 of the 25 tables" in run.headline and "+" not in run.headline.split(":")[0]
    assert (tmp_path / "f" / "README_FANUC.md").read_text().splitlines()[0] == run.headline
    run = make_tables(model, tmp_path / "s", "siemens-840d", profile=prof, uncertainty=False)
    rows = {r.label: r.mean for r in run.plan.report.rows}
    assert rows["files as written (model-predicted)"] < rows["full tables (model-predicted)"] + 0.001
    assert run.headline is None


@pytest.fixture(scope="module")
def backlash_skew(machines):
    """A model with a row-dependent effect (backlash of X) and a geometric one (a gantry
    skew of Y about x), fitted on a campaign simulated with both; and that simulation."""
    from vecpin.models.effects.backlash import Backlash
    from vecpin.models.effects.gantry_skew import GantrySkew
    from vecpin.simulation.effects import EffectSpec
    flow = machines["flow_xyzcb"]
    sim = simulate(flow, seed=6, design=Design(n_commands=120, n_validation=5),
                   effects=[EffectSpec("backlash", ("X",), 0.03), EffectSpec("gantry_skew", ("Y",), 0.3,
                                                                             {"about": "x", "depends": "Z"}, seed=2)])
    model = make_model("ap", flow, 3, effects=[Backlash(flow, ("X",)), GantrySkew(flow, ("Y",), about="x")])
    return sim, model.fit(sim.campaign, NoiseModel.default(flow, "spherical"))


@pytest.mark.parametrize("controller", ["linuxcnc", "siemens-840d", "fanuc-30i"])
def test_tables_of_a_model_with_backlash_and_skew(backlash_skew, controller, tmp_path):
    """A model with backlash (row-dependent) gives tables for a controller with a reader:
    the files are read back and judged on the model's geometric part (the skew in, the
    backlash left to the controller's own backlash compensation, with advice). Truth
    independent of vecpin's model: the true simulated machine (its skew, no backlash as
    the geometry goes) commanded through the tables read back from the files."""
    from vecpin.compensation.functions import truth_as_actual
    sim, model = backlash_skew
    assert model.row_dependent
    prof = Path(__file__).parent / "data" / "controllers" / ("flow_xyzcb_linuxcnc_profile.json" if controller == "linuxcnc"
                                                           else "flow_xyzcb_profile.json")
    run = make_tables(model, tmp_path / controller, controller, profile=prof)  # with the parameter spread
    rows = {r.label.split(" (")[0]: r for r in run.plan.report.rows}
    assert any(n.startswith("backlash[X] is not in the tables") for n in run.plan.report.notes)
    written = rows["files as written"]
    planned, = [r for r in run.plan.report.rows                           # the row of the set written
                if not r.label.startswith("files") and r.tables == len(run.plan.tables.tables)]
    assert written.mean == pytest.approx(planned.mean, rel=0.02, abs=2e-4)   # mm: the files hold what was planned
    # the true machine (with its skew) through the tables: the skew is corrected, not only the model's AP part
    m, q, L = model.machine, run.plan.problem.q, run.plan.problem.L
    truth = truth_as_actual(sim.truth)
    before = np.linalg.norm(compensated_errors(truth, m, None, q, L), axis=1).mean()
    after = np.linalg.norm(compensated_errors(truth, m, run.plan.tables, q, L), axis=1).mean()
    assert after < 0.3 * before
    if controller == "siemens-840d":  # the same model without its skew: its tables leave the skew on the truth
        from vecpin.workflows.tables import _without
        geometric = [e for e, _ in model.effect_slices() if e.name == "gantry_skew"]
        no_skew = plan_tables(_without(model, geometric), n_commands=300, uncertainty=False).tables
        left = np.linalg.norm(compensated_errors(truth, m, no_skew, q, L), axis=1).mean()
        assert left > 1.5 * after


def test_a_manifest_removes_only_the_files_an_earlier_run_of_the_same_command_wrote(tmp_path):
    """With a manifest, files the previous set wrote and this one does not are removed if
    unchanged; a user's files, an edited file, a name leading out of the folder and the
    sets of another command (or without a manifest) are never touched."""
    from vecpin.fileio import OutputSet
    d = tmp_path / "out"
    with OutputSet(d, manifest="tables") as out:
        for n in ("a.txt", "sub/b.txt", "c.txt"):
            out.write_text(n, n)
    (d / "user.txt").write_text("mine")
    (d / "c.txt").write_text("edited by hand")
    (tmp_path / "outside.txt").write_text("x")
    manifest = d / ".vecpin-tables.manifest"
    import hashlib
    manifest.write_text(manifest.read_text() + hashlib.sha256(b"x").hexdigest() + "  ../outside.txt\n")
    with OutputSet(d, manifest="other") as out:  # another command's set removes nothing
        out.write_text("o.txt", "o")
    assert (d / "sub" / "b.txt").is_file()
    with OutputSet(d, manifest="tables") as out:
        out.write_text("a.txt", "a2")
    assert out.removed == [d / "sub" / "b.txt"] and not (d / "sub").exists()
    assert sorted(p.name for p in d.iterdir()) == [".vecpin-other.manifest", ".vecpin-tables.manifest", "a.txt",
                                                   "c.txt", "o.txt", "user.txt", "vecpin-manifest.json"]
    assert (d / "c.txt").read_text() == "edited by hand" and (tmp_path / "outside.txt").is_file()
    assert manifest.read_text().splitlines()[1:] == [hashlib.sha256(b"a2").hexdigest() + "  a.txt"]
    with OutputSet(d) as out:  # no manifest: nothing removed
        out.write_text("z.txt", "z")
    assert (d / "a.txt").is_file() and (d / "c.txt").is_file()


def test_tables_for_another_controller_replace_the_former_files(model, tmp_path):
    """``vecpin tables`` into the folder of an earlier run for another controller: the
    former controller's files go (they would be loaded by mistake), the user's stay."""
    prof = Path(__file__).parent / "data" / "controllers" / "flow_xyzcb_linuxcnc_profile.json"
    make_tables(model, tmp_path, "linuxcnc", profile=prof, uncertainty=False)
    before = {p.name for p in tmp_path.iterdir()}
    (tmp_path / "notes.txt").write_text("my notes")
    run = make_tables(model, tmp_path, "generic", uncertainty=False)
    after = {p.name for p in tmp_path.iterdir()}
    gone = before - after
    assert gone and not {"tables.json", "tables.csv"} & gone and "notes.txt" in after
    assert after == {"tables.json", "tables.csv", ".vecpin-tables.manifest", "notes.txt", "vecpin-manifest.json"}
    assert any("removed the files of an earlier" in n for n in run.notes)
