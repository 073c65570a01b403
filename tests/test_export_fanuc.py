"""Fanuc 30i: the backup form (N0xxxxQ1 / N1xxxxQ0), anchoring at the reference position,
rotary-axis type, magnification and value range. Fixtures: tests/data/controllers/fanuc
(form of the real 0i-MF backup github IlyasMIM/HM100TS; point rule B-63980EN p.100)."""
import math
import re

import numpy as np
import pytest
from export_helpers import DATA, E_XX_MM, E_YX_MM, X_MM, fixture_tables, profile, tiny_machine

from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.errors import ControllerFileError, ControllerLimitError, InputError
from vecpin.export import fanuc, fanuc_read
from vecpin.export.common import ExportJob
from vecpin.fileio import OutputSet
from vecpin.units import from_mm, to_mm

FIX = DATA / "fanuc"


def write(tables, machine, prof, out_dir):
    with OutputSet(out_dir) as out:
        job = ExportJob(tables, machine, prof, fanuc.LIMITS, out)
        fanuc.write(job)
    return job.notes


def five_points(**kw):
    """The fixture's grid: 5 points per axis -> interval 50 mm over X -200 .. 0."""
    return profile(limits={"pitch_points_per_axis": 5}, **kw)


def test_reader_parses_the_backup_form():
    """Point n at (n - 3620) x 3624 from the reference; values are correction increments per section."""
    m = tiny_machine()
    back = fanuc_read.read(FIX, m, profile())
    xx = back.table("xx")
    assert back.names() == ["xx"]                                        # A2, A3 have no table (0, 0, 0)
    np.testing.assert_allclose(to_mm(xx.positions), [-250, -200, -150, -100, -50, 0, 50])
    np.testing.assert_allclose(to_mm(xx(from_mm(X_MM))), -E_XX_MM, atol=1e-12)


def test_writer_reproduces_the_backup_form(tmp_path):
    m = tiny_machine()
    write(fixture_tables(m), m, five_points(), tmp_path)
    para = (tmp_path / "CNC-PARA.TXT").read_text().splitlines()
    pitch = (tmp_path / "PITCH.TXT").read_text().splitlines()
    assert para[0] == "%" and para[-1] == "%" and pitch[0] == "%" and pitch[-1] == "%"
    assert all(re.fullmatch(r"N0\d{4}Q1(A\d+P-?\d+(\.\d+)?)+", ln) for ln in para[1:-1])
    assert all(re.fullmatch(r"N1\d{4}Q0P-?\d+", ln) for ln in pitch[1:-1])
    assert "N03624Q1A1P50.0" in para and "N03625Q1A1P0.0" in para     # reals with a decimal point
    assert "N03620Q1A1P3" in para and "N03621Q1A1P0" in para and "N03622Q1A1P4" in para
    fix = {int(n): int(v) for n, v in re.findall(r"N1(\d{4})Q0P(-?\d+)", (FIX / "PITCH.TXT").read_text())}
    ours = [int(v) for v in re.findall(r"Q0P(-?\d+)", "\n".join(pitch))]
    assert ours == [fix[n] for n in range(2, 7)]                          # the same sections, numbered from 0
    back = fanuc_read.read(tmp_path, m, five_points())
    np.testing.assert_allclose(to_mm(back.table("xx")(from_mm(X_MM))), -E_XX_MM, atol=1e-12)


def test_reader_reads_each_tape_once(tmp_path, monkeypatch):
    """fanuc_read.read parses CNC-PARA.TXT and PITCH.TXT once each (it used to parse CNC-PARA.TXT
    again for parameter 1240), and the 1240 shift it reads is the profile's reference
    position minus the tape's."""
    m = tiny_machine()
    write(fixture_tables(m), m, five_points(), tmp_path)
    para = tmp_path / "CNC-PARA.TXT"
    assert "N01240Q1A1P0.0" in para.read_text()
    para.write_text(para.read_text().replace("N01240Q1A1P0.0", "N01240Q1A1P-0.5"))
    seen = []
    real = fanuc_read.read_tape
    monkeypatch.setattr(fanuc_read, "read_tape", lambda path: seen.append(path.name) or real(path))
    back = fanuc_read.read(tmp_path, m, five_points())
    assert sorted(seen) == ["CNC-PARA.TXT", "PITCH.TXT"]
    # 1240 = -0.5 against the profile's reference 0: the axis goes 0.5 mm further at every command
    np.testing.assert_allclose(to_mm(back.table("xx")(from_mm(X_MM))), -E_XX_MM + 0.5, atol=1e-9)


def test_table_is_anchored_at_the_reference_position_from_the_profile(tmp_path):
    """Parameter 1240 (machine coordinate of the reference position) from the profile:
    the points sit at reference + k x interval and the correction is zero there."""
    m = tiny_machine()
    t = CompensationTable("X", "X", -0.2, 0.05, from_mm(np.array([0.05, 0.04, 0.03, 0.02, 0.01])))
    notes = write(TableSet(m.axis_names, [t]), m, five_points(X={"reference_position": -75.0}), tmp_path)
    g = fanuc_read.read_grids(tmp_path, m, five_points(X={"reference_position": -75.0}))[0]
    assert g.reference_position == -75.0
    assert np.allclose((g.position(np.arange(g.first, g.last + 1)) + 75.0) % g.interval, 0.0, atol=1e-9)
    back = fanuc_read.grid_table(g, m)
    assert to_mm(back(from_mm(-75.0))) == pytest.approx(0.0, abs=1e-12)
    assert any("+0.0250 mm" in n for n in notes)                        # t(-75) = 0.025: the constant removed
    x = np.linspace(-200, -35, 34)            # inside the last grid point: the linear table is exact there
    np.testing.assert_allclose(to_mm(back(from_mm(x))) + 0.025, to_mm(t(from_mm(x))), atol=1e-3)


def test_rotary_axis_type_reference_value_equals_the_last(tmp_path):
    """B-63980EN p.100: over a turn the values sum to zero, and the reference point
    (= most negative point) gets the same value as the last point."""
    m = tiny_machine()
    c = np.linspace(0, 2 * math.pi, 361)
    t = CompensationTable("C", "C", 0.0, c[1], np.radians(0.01 * np.sin(c) + 0.004 * np.cos(3 * c)), modulo=True)
    prof = profile(C={"modulo": True}, limits={"pitch_points_per_axis": 73})
    write(TableSet(m.axis_names, [t]), m, prof, tmp_path)
    g = fanuc_read.read_grids(tmp_path, m, prof)[0]
    para = (tmp_path / "CNC-PARA.TXT").read_text()
    assert "N03625Q1A4P360.0" in para and g.first == g.reference and g.interval == 5.0
    assert g.values[1:].sum() == 0 and g.values[0] == g.values[-1] != 0
    back = fanuc_read.grid_table(g, m)
    q = np.radians(np.linspace(-400, 400, 97))
    np.testing.assert_allclose(np.degrees(back(q)), np.degrees(t(q) - t(0.0)), atol=2e-3)


def _rotary_type_set(flow):
    """flow_xyzcb's C (544 deg of travel) as a rotary-axis-type axis: a modulo pitch table
    and a modulo straightness table of X from C (each with a constant at the reference),
    beside X's own pitch table."""
    c = np.linspace(0.0, 2 * math.pi, 721)
    x = np.linspace(flow.axis("X").lower, flow.axis("X").upper, 201)
    u = (x - x[0]) / (x[-1] - x[0])
    return TableSet(flow.axis_names, [
        CompensationTable("X", "X", x[0], x[1] - x[0], from_mm(0.02 * np.sin(3 * u) + 0.01 * u)),
        CompensationTable("C", "C", 0.0, c[1], np.radians(0.01 * np.sin(c) + 0.004 * np.cos(3 * c) + 0.003),
                          modulo=True),
        CompensationTable("C", "X", 0.0, c[1], from_mm(0.03 * np.sin(c) + 0.02 * np.cos(2 * c)), modulo=True)])


def _flow_profile(flow, **limits):
    from vecpin.export.profile import ControllerProfile
    ref = {"X": 6096.0, "Y": 2552.0, "Z": 996.0, "C": 30.0, "B": 0.0}      # C's reference away from 0
    axes = {a: {"number": k + 1, "reference_position": ref[a], "detection_unit": 0.001}
            for k, a in enumerate(flow.axis_names)}
    axes["C"]["modulo"] = True
    return ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1, "axes": axes,
                                        "limits": limits}, "flow_xyzcb fanuc profile (test)"), ref


def test_a_rotary_type_axis_reads_back_as_the_control_applies_it(flow, tmp_path):
    """Issue 39: on a rotary-axis-type C (3625 = 360) the pitch table and the straightness
    table it moves cover one turn and repeat over C's whole travel (-272 .. 272 deg), as
    the independent applier (tests/controller_appliers.py, from B-63980EN p.100) applies
    them; vecpin's reader held the straightness table's end values outside 0 .. 360, so
    the printed prediction of the files as written was off (0.446 mm for 0.091 true on a
    simulated flow_xyzcb)."""
    from controller_appliers import fanuc_corrections
    prof, ref = _flow_profile(flow)
    write(_rotary_type_set(flow), flow, prof, tmp_path)
    back = fanuc_read.read(tmp_path, flow, prof)
    assert back.table("xc").modulo and back.table("cc").modulo
    rng = np.random.default_rng(7)
    q = flow.lower + rng.random((400, flow.n_axes)) * (flow.upper - flow.lower)
    q_user = flow.to_user(q)
    want = fanuc_corrections(tmp_path, flow.axis_names, ref, q_user)      # X, C: pitch, 1240 and straightness
    got = flow.to_user(back.increments(q))
    # the reader anchors C's table at the profile's reference, the control at the new 1240 (0.003 deg off)
    np.testing.assert_allclose(got, want, atol=2e-5)
    outside = (q_user[:, 3] < ref["C"]) | (q_user[:, 3] > ref["C"] + 360.0)
    assert outside.sum() > 100 and np.ptp(want[outside, 0]) > 0.05        # mm: C beyond the turn moves X's correction


def test_a_rotary_type_table_the_control_would_not_hold_is_refused(flow, tmp_path):
    """B-63980EN p.100: the values of a rotary-axis-type table sum to zero over the turn and
    the reference point repeats the last; its straightness rows must cover the turn."""
    prof, _ = _flow_profile(flow)
    write(_rotary_type_set(flow), flow, prof, tmp_path)
    pitch = (tmp_path / "PITCH.TXT").read_text().splitlines()
    g = next(g for g in fanuc_read.read_grids(tmp_path, flow, prof) if g.axis == "C")
    k = next(i for i, ln in enumerate(pitch) if ln.startswith(f"N{10000 + g.last}Q0P"))
    pitch[k] = f"N{10000 + g.last}Q0P{int(g.values[-1]) + 1}"
    (tmp_path / "PITCH.TXT").write_text("\n".join(pitch) + "\n")
    with pytest.raises(ControllerFileError, match="sum to 1, not 0"):
        fanuc_read.read(tmp_path, flow, prof)
    write(_rotary_type_set(flow), flow, prof, tmp_path / "b")
    rows = (tmp_path / "b" / "STRAIGHTNESS.CSV").read_text().splitlines()
    (tmp_path / "b" / "STRAIGHTNESS.CSV").write_text("\n".join(rows[:-1]) + "\n")   # the row at 360 deg gone
    with pytest.raises(ControllerFileError, match="must cover the turn"):
        fanuc_read.read(tmp_path / "b", flow, prof)


def test_magnification_is_chosen_and_the_range_checked(tmp_path):
    m = tiny_machine()
    steep = CompensationTable("X", "X", -0.2, 0.05, from_mm(np.array([0.0, 0.3, 0.6, 0.9, 1.2])))
    write(TableSet(m.axis_names, [steep]), m, five_points(), tmp_path)
    g = fanuc_read.read_grids(tmp_path, m, five_points())[0]
    assert g.magnification == 3 and np.abs(g.values).max() <= 127          # 300 units per section at mag 1
    with pytest.raises(ControllerLimitError, match="magnification"):
        write(TableSet(m.axis_names, [steep]), m, profile(limits={"pitch_points_per_axis": 5,
                                                                    "max_magnification": 2}), tmp_path / "b")


def test_straightness_is_written_for_entry_by_hand(tmp_path):
    m = tiny_machine()
    notes = write(fixture_tables(m), m, five_points(), tmp_path)
    rows = (tmp_path / "STRAIGHTNESS.CSV").read_text().splitlines()
    assert rows[0].startswith("#") and "not a Fanuc file" in rows[0]
    assert "yx,X,1,0,-150.0,mm,Y,2,0.001,mm,1" in rows                   # correction = -e_YX(-150)
    readme = (tmp_path / "README_FANUC.md").read_text()
    assert "by hand" in readme and "moving axis X (A1), compensation axis Y (A2)" in readme
    assert any("by hand" in n for n in notes)
    back = fanuc_read.read(tmp_path, m, five_points())
    # the rows name X's own pitch points only (3621..3622 of A1): X_MM[0] is the start of X's first section,
    # point first - 1, which belongs to no X point (on a second axis it would be the first axis' last point)
    para = (tmp_path / "CNC-PARA.TXT").read_text()
    first, last = (int(re.search(rf"N0{p}Q1A1P(\d+)", para).group(1)) for p in (3621, 3622))
    points = [int(r.split(",")[3]) for r in rows[2:] if r.startswith("yx,")]
    assert points == list(range(first, last + 1))
    np.testing.assert_allclose(to_mm(back.table("yx")(from_mm(X_MM[1:]))), -E_YX_MM[1:], atol=1e-12)


def test_missing_facts_and_point_budget():
    m = tiny_machine()
    with pytest.raises(InputError, match="controlled-axis number"):
        fanuc.check(m, profile(Y={"number": None}), fanuc.LIMITS)
    with pytest.raises(InputError, match=r"reference position in mm \(parameter 1240"):
        fanuc.check(m, profile(Y={"reference_position": None}), fanuc.LIMITS)
    with pytest.raises(InputError, match="detection unit"):
        fanuc.check(m, profile(C={"detection_unit": None}), fanuc.LIMITS)
    t = [CompensationTable(a, a, -0.2, 0.05, np.zeros(5)) for a in "XYZ"]
    with pytest.raises(ControllerLimitError, match="pitch_points_total"):
        fanuc.grids(TableSet(m.axis_names, t), m, profile(limits={"pitch_points_total": 5}))
    g = fanuc.grids(TableSet(m.axis_names, t), m, profile(limits={"pitch_points_total": 9}))
    assert [x.last - x.first + 1 for x in g] == [3, 3, 3] and g[2].last == 8      # 9 // 3 points each, from 0


@pytest.mark.parametrize("bad, message, line", [
    ("N10003Q0P3", "N10003Q0Px", 6),                      # line 1 is the leader
    ("N03624Q1A1P50.0A2P0.0A3P0.0", "N03624Q1A1P50.0A2", 7),
    ("N03621Q1A1P1A2P0A3P0", "N03621Q1A1P7A2P0A3P0", 4),       # 3620 = 5 below 3621 - 1
])
def test_bad_tapes_name_file_and_line(tmp_path, bad, message, line):
    for f in ("CNC-PARA.TXT", "PITCH.TXT"):
        text = (FIX / f).read_text()
        (tmp_path / f).write_text(text.replace(bad, message))
    with pytest.raises(ControllerFileError) as exc:
        fanuc_read.read(tmp_path, tiny_machine(), profile())
    assert exc.value.line == line


def test_a_cut_tape_is_refused(tmp_path):
    (tmp_path / "CNC-PARA.TXT").write_text("%\nN03620Q1A1P5\n")
    with pytest.raises(ControllerFileError, match="no closing %"):
        fanuc_read.read(tmp_path, tiny_machine(), profile())


def test_reads_a_0i_mf_style_backup():
    """A parameter tape laid out as a real 0i-MF backup is (tests/data/controllers/fanuc/0imf_style:
    20 axes per line, L-fields, trailing blanks, CR LF, a B axis whose reference point is one below
    its first pitch point): vecpin's reader gives the pitch corrections an applier written from the
    parameter manual (tests/controller_appliers.py) gives."""
    from controller_appliers import fanuc_pitch
    import vecpin
    from vecpin.export.profile import ControllerProfile
    m = vecpin.Machine.load("snk_120v")
    numbers = {"X": 1, "Y": 2, "Z": 3, "B": 4}
    prof = ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1, "axes": {
        a: {"number": n, "reference_position": 0.0, "detection_unit": 0.001} for a, n in numbers.items()}})
    folder = DATA / "fanuc" / "0imf_style"
    back = fanuc_read.read(folder, m, prof)
    assert sorted(back.names()) == ["bb", "xx", "yy", "zz"]
    for a, n in numbers.items():
        t = back.table(a + a)
        x = m.axis(a).to_user(np.linspace(t.start, t.end, 97))
        want = fanuc_pitch(folder, n, x)
        np.testing.assert_allclose(m.axis(a).to_user(t(m.axis(a).to_si(x))), want, atol=1e-9)
        assert np.abs(want).max() > 0.0005
    b = back.table("bb")
    assert m.axis("B").to_user(b.start) == pytest.approx(0.0) and m.axis("B").to_user(b.end) == pytest.approx(360.0)


def test_a_rotary_axis_over_a_turn_without_a_modulo_word_is_warned(tmp_path):
    """C of the tiny machine travels more than a turn: with tables over the whole travel and
    no "modulo" in the profile, the files say what a modulo NC axis needs."""
    m = tiny_machine()
    c = m.axis("C")
    assert c.upper_user - c.lower_user >= 360.0 - 1e-6
    t = CompensationTable("C", "C", c.lower, c.travel / 4, np.radians([0.0, 0.001, 0.0, -0.001, 0.0]))
    notes = write(TableSet(m.axis_names, [t]), m, profile(), tmp_path)
    assert any("C travels" in n and "modulo" in n for n in notes)
