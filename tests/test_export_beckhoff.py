"""Beckhoff TwinCAT CNC / ISG: SSFK and cross-compensation lists, ISG CSV, volumetric list.
Fixtures: tests/data/controllers/beckhoff (TF5200 examples 308695435, 15273973131; TF5280 ISG CSV)."""
import numpy as np
import pytest
from export_helpers import DATA, E_XX_MM, E_YX_MM, X_MM, fixture_tables, profile, tiny_machine

from vecpin.compensation.tables import CompensationTable, TableSet, cross_table_axes
from vecpin.errors import ControllerFileError, ControllerLimitError
from vecpin.export import beckhoff, iso230
from vecpin.export.common import ExportJob
from vecpin.fileio import OutputSet
from vecpin.units import to_mm

FIX = DATA / "beckhoff"


def named_profile(**kw):
    return profile(X={"nc_name": "X"}, Y={"nc_name": "Y"}, **kw)


def write(tables, machine, prof, out_dir, model=None):
    with OutputSet(out_dir) as out:
        job = ExportJob(tables, machine, prof, beckhoff.LIMITS, out, model)
        beckhoff.write(job)
    return job.notes


def test_reader_parses_the_documented_lists():
    """SSFK value = measured - programmed (TF5200 example): the error; 0.1 um units."""
    m = tiny_machine()
    xx = beckhoff.read_axis_list(FIX / "achskw1.lis", m, named_profile())[0]
    yx = beckhoff.read_axis_list(FIX / "achskw2.lis", m, named_profile())[0]
    assert (xx.name, yx.name) == ("xx", "yx")
    np.testing.assert_allclose(to_mm(xx.positions), X_MM)
    np.testing.assert_allclose(to_mm(xx.values), -E_XX_MM, atol=1e-12)
    np.testing.assert_allclose(to_mm(yx.values), -E_YX_MM, atol=1e-12)


def test_writer_reproduces_the_documented_lists(tmp_path):
    """Same keys, same order, same values as the examples (comments aside)."""
    m = tiny_machine()
    write(fixture_tables(m), m, named_profile(), tmp_path)
    for ours, fix in (("achskw_X.lis", "achskw1.lis"), ("achskw_Y.lis", "achskw2.lis")):
        a = list(beckhoff.read_list(tmp_path / ours).items())
        b = list(beckhoff.read_list(FIX / fix).items())
        assert [(k, v) for k, (v, _) in a] == [(k, v) for k, (v, _) in b]
    start = (tmp_path / "startup_entries.lis").read_text()
    assert "zahl_kw" in start and "achs_kw[1]                          achskw_Y.lis" in start
    readme = (tmp_path / "README_BECKHOFF.md").read_text()
    assert "`lr_param.ssfk 1`" in readme and "`lr_param.crosscomp 1` (yx)" in readme


def test_round_trip(tmp_path):
    m = tiny_machine()
    x = np.linspace(-0.2, 0.0, 400)
    ts = [CompensationTable("X", "X", -0.2, x[1] - x[0], 1e-5 * np.sin(30 * x)),
          CompensationTable("Z", "Y", -0.2, x[1] - x[0], 2e-5 * np.cos(20 * x))]
    write(TableSet(m.axis_names, ts), m, named_profile(), tmp_path)
    back = beckhoff.read(tmp_path, m, named_profile())
    q = np.linspace(-0.25, 0.05, 301)
    for t in ts:
        np.testing.assert_allclose(back.table(t.name)(q), t(q), atol=0.5e-7)    # 0.05 um rounding


def test_one_cross_table_per_compensated_axis(flow):
    lim = beckhoff.LIMITS
    cons = lim.constraints(axis_names=flow.axis_names)
    axes = cross_table_axes(flow.axis_names)
    assert cons.max_tables == 5 and not cons.admissible(["yx", "yz"], axes) and cons.admissible(["yx", "zx"], axes)
    m = tiny_machine()
    two = TableSet(m.axis_names, [CompensationTable("X", "Y", -0.2, 0.05, np.zeros(5)),
                                  CompensationTable("Z", "Y", -0.2, 0.05, np.zeros(5))])
    with pytest.raises(ControllerLimitError, match="one cross table per compensated axis"):
        lim.check_tables(two)


def test_isg_csv_form_and_reader(tmp_path):
    m = tiny_machine()
    c = iso230.read_isg(FIX / "vc_x.csv", m)
    np.testing.assert_allclose(to_mm(c.positions), X_MM)
    np.testing.assert_allclose(to_mm(c.errors["EXX"]), E_XX_MM, atol=1e-12)     # ISO errors, not corrections
    np.testing.assert_allclose(to_mm(c.errors["EYX"]), E_YX_MM, atol=1e-12)
    text = iso230.write_isg(c, m, "test")
    lines = [ln.split() for ln in text.splitlines() if not ln.startswith("//")]
    fix = [ln.split() for ln in (FIX / "vc_x.csv").read_text().splitlines() if not ln.startswith("//")]
    assert lines[0] == fix[0]
    np.testing.assert_allclose(np.array(lines[1:], float), np.array(fix[1:], float), atol=1e-12)
    p = tmp_path / "bad.csv"
    p.write_text("X EXX EQX\n0 0 0\n")
    with pytest.raises(ControllerFileError, match="EQX") as exc:
        iso230.read_isg(p, m)
    assert exc.value.line == 1


def test_bad_list_names_file_and_line(tmp_path):
    p = tmp_path / "achskw_X.lis"
    p.write_text((FIX / "achskw1.lis").read_text().replace("kw.ssfk.table[3].pos               20",
                                                             "kw.ssfk.table[3].pos               2x0"))
    with pytest.raises(ControllerFileError, match="not a number") as exc:
        beckhoff.read_axis_list(p, tiny_machine(), named_profile())
    assert exc.value.line == 17 and exc.value.path == str(p)
    p.write_text("kopf.achs_nr 1\nkw.crosscomp2.interval 5\n")
    with pytest.raises(ControllerFileError, match="crosscomp2") as exc:
        beckhoff.read_axis_list(p, tiny_machine(), named_profile())
    assert exc.value.line == 2


@pytest.mark.slow   # a whole report or day: several seconds, in the slow tier
@pytest.mark.parametrize("machine, why", [("production_xyzbaw", "W is none of them"), ("trunnion_xyzac", "table axes")])
def test_axis_lists_without_tf5280_where_it_cannot_describe_the_machine(machines, tmp_path, machine, why):
    """A 6-DoF model of a machine with a W axis or with table axes: the axis compensation
    lists are written and the missing TF5280 files are said (before: no file at all)."""
    from vecpin.export.profile import ControllerProfile
    from vecpin.measurement.noise import NoiseModel
    from vecpin.models import make_model
    from vecpin.simulation.simulate import Design, simulate
    from vecpin.workflows.tables import make_tables
    m = machines[machine]
    sim = simulate(m, seed=2, design=Design(n_commands=100, n_validation=5))
    model = make_model("6dof", m, 2).fit(sim.campaign, NoiseModel.default(m))
    prof = ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1,
                                        "axes": {a: {"number": k + 1} for k, a in enumerate(m.axis_names)}})
    run = make_tables(model, tmp_path, "beckhoff", profile=prof, uncertainty=False, points=64)
    assert all((tmp_path / f"achskw_{a}.lis").is_file() for a in m.axis_names)
    assert not (tmp_path / "vol_comp_0.lis").exists()
    assert any("no volumetric files (TF5280)" in n and why in n for n in run.notes)
