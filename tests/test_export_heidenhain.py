"""Heidenhain .COM / .CMA: the technical-manual form, round trip, limits.
Fixtures: tests/data/controllers/heidenhain (MANUALplus 620 TM p.716/718; pyLSV2 table syntax)."""
import dataclasses
import math

import numpy as np
import pytest
from export_helpers import DATA, E_XX_MM, E_YX_MM, X_MM, fixture_tables, profile, tiny_machine

import vecpin
from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.errors import ControllerFileError, ControllerLimitError
from vecpin.export import heidenhain
from vecpin.export.common import ExportJob
from vecpin.export.profile import ControllerProfile
from vecpin.fileio import OutputSet
from vecpin.units import to_mm

FIX = DATA / "heidenhain"


def named_profile(**kw):
    return profile(X={"nc_name": "X"}, Y={"nc_name": "Y"}, Z={"nc_name": "Z"}, C={"nc_name": "C"}, **kw)


def write(tables, machine, prof, out_dir):
    with OutputSet(out_dir) as out:
        heidenhain.write(ExportJob(tables, machine, prof, heidenhain.LIMITS, out))


def test_reader_parses_the_documented_tables():
    m = tiny_machine()
    back = heidenhain.read(FIX, m, named_profile())
    assert sorted(back.names()) == ["xx", "yx"]
    np.testing.assert_allclose(to_mm(back.table("xx").positions), X_MM)
    np.testing.assert_allclose(to_mm(back.table("xx").values), -E_XX_MM, atol=1e-12)
    np.testing.assert_allclose(to_mm(back.table("yx").values), -E_YX_MM, atol=1e-12)


def test_writer_reproduces_the_documented_tables(tmp_path):
    """Byte for byte up to [END] (the fixture's provenance line follows it)."""
    m = tiny_machine()
    write(fixture_tables(m), m, named_profile(), tmp_path)
    for name in ("X.COM", "CONFIG.CMA"):
        fix = (FIX / name).read_text().split("[END]")[0]
        assert (tmp_path / name).read_text() == fix + "[END]\n"


def test_round_trip_with_a_modulo_rotary_input(tmp_path):
    m = tiny_machine()
    c = np.linspace(0, 2 * math.pi, 181)
    ts = [CompensationTable("C", "C", 0.0, c[1], np.radians(0.01 * np.sin(c)), modulo=True),
          CompensationTable("C", "X", 0.0, c[1], 2e-5 * np.cos(c), modulo=True)]
    write(TableSet(m.axis_names, ts), m, named_profile(), tmp_path)
    back = heidenhain.read(tmp_path, m, named_profile())
    q = np.radians(np.linspace(-400, 400, 101))
    for t in ts:
        bt = back.table(t.name)
        assert bt.modulo
        np.testing.assert_allclose(bt(q), t(q), atol=np.radians(0.5e-4) if t.output_axis == "C" else 0.5e-7)


def test_limits(tmp_path):
    """A rotary travel of at most a turn is taken by default (written over 0..360); more
    than a turn needs modulo tables or the profile's rotary_any_range."""
    m = tiny_machine()
    assert heidenhain.LIMITS.max_points == 256
    heidenhain.check(m, named_profile(), heidenhain.LIMITS, [])            # C travels -180 .. 180: one turn
    t = vecpin.Machine.load("trunnion_xyzac")                              # C travels -720 .. 720
    names = ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1,
                                         "axes": {a: {"nc_name": a} for a in t.axis_names}})
    with pytest.raises(ControllerLimitError, match="C would run -720 .. 720 deg, more than a turn.*p.156"):
        heidenhain.check(t, names, heidenhain.LIMITS, [])
    heidenhain.check(t, names, heidenhain.LIMITS, ["C"])
    heidenhain.check(t, dataclasses.replace(names, options={"rotary_any_range": True}), heidenhain.LIMITS, [])
    wide = CompensationTable("C", "C", np.radians(-200.0), np.radians(5.0), np.zeros(81))
    with pytest.raises(ControllerLimitError, match="more than a turn"):
        write(TableSet(m.axis_names, [wide]), m, named_profile(), tmp_path)


def test_a_rotary_travel_outside_0_360_is_written_over_one_turn(tmp_path):
    """TNC 407 TM p.156: rotary entries run 0..360 only. Tables of C over -150 .. 150 deg are
    written with AXISPOS 0..360 (-150 deg at entry 210); a fixed-width reader and a control
    that looks a rotary position up modulo 360 (tests/controller_appliers.py) give the
    tables' corrections over the travel, and so does vecpin's reader (a modulo table)."""
    from controller_appliers import _tnc_table, heidenhain_corrections
    m = tiny_machine()
    c = np.radians(np.linspace(-150.0, 150.0, 121))
    ts = [CompensationTable("C", "C", c[0], c[1] - c[0], np.radians(0.01 * c / np.pi)),
          CompensationTable("C", "X", c[0], c[1] - c[0], 2e-5 * (c + 0.3) ** 2)]
    with OutputSet(tmp_path) as out:
        job = ExportJob(TableSet(m.axis_names, ts), m, named_profile(), heidenhain.LIMITS, out)
        heidenhain.write(job)
    assert any("0..360" in n and "p.156" in n for n in job.notes)
    pos = [float(r["AXISPOS"]) for r in _tnc_table(tmp_path / "C.COM")]
    assert pos[0] == 0.0 and pos[-1] == 360.0 and len(pos) == 145          # 2.5 deg, as the tables
    q_deg = np.linspace(-150.0, 150.0, 301)
    q_user = np.zeros((len(q_deg), 4))
    q_user[:, 3] = q_deg
    applied = heidenhain_corrections(tmp_path, ["X", "Y", "Z", "C"], q_user, {"C"})
    q = np.radians(q_deg)
    np.testing.assert_allclose(applied[:, 3], np.degrees(ts[0](q)), atol=1e-4)
    np.testing.assert_allclose(applied[:, 0], to_mm(ts[1](q)), atol=1e-4)
    back = heidenhain.read(tmp_path, m, named_profile())
    assert back.table("cc").modulo
    np.testing.assert_allclose(to_mm(back.table("xc")(q)), to_mm(ts[1](q)), atol=1e-4)


def test_bad_table_names_file_and_line(tmp_path):
    (tmp_path / "CONFIG.CMA").write_text((FIX / "CONFIG.CMA").read_text())
    (tmp_path / "X.COM").write_text((FIX / "X.COM").read_text().replace("-0.0010", "-0.00x0"))
    with pytest.raises(ControllerFileError, match="not a number") as exc:
        heidenhain.read(tmp_path, tiny_machine(), named_profile())
    assert exc.value.line == 4 and exc.value.path == str(tmp_path / "X.COM")
    (tmp_path / "X.COM").write_text((FIX / "X.COM").read_text().replace("[END]", ""))
    with pytest.raises(ControllerFileError, match=r"no \[END\]"):
        heidenhain.read(tmp_path, tiny_machine(), named_profile())


def fixed_width_table(path) -> list[dict]:
    """A TNC table read as fixed-width fields, independently of vecpin: a column runs from
    the first character of its name to the end of the blanks after it (line end
    included), as drunsinn/pyLSV2's table_reader takes it; rows are sliced there."""
    import re
    lines = path.read_text().split("\n")
    head = lines[1] + "\n"
    cols = [(mt.group(1), mt.start(), mt.end()) for mt in re.finditer(r"(\S+)\s+", head)]
    rows = []
    for ln in lines[2:]:
        if ln.startswith("[END]"):
            break
        rows.append({name: ln[a:b].strip() for name, a, b in cols})
    return rows


def test_a_fixed_width_reader_gets_every_digit_of_the_last_column(tmp_path):
    """The column line is padded to the last field's width: a reader that takes the last
    column to the end of the header's blanks reads '-0.0040', not '-0.'."""
    m = tiny_machine()
    write(fixture_tables(m), m, named_profile(), tmp_path)
    rows = fixed_width_table(tmp_path / "X.COM")
    np.testing.assert_allclose([float(r["Y"]) for r in rows], np.round(E_YX_MM, 4), atol=1e-12)
    np.testing.assert_allclose([float(r["AXISPOS"]) for r in rows], X_MM)
    assert [r["ACTIVE"] for r in fixed_width_table(tmp_path / "CONFIG.CMA")] == ["*"]
