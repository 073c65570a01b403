"""Siemens 840D sl / 828D: the documented example form, sign, zero at the reference point,
modulo, limits. Fixtures: tests/data/controllers/siemens (K3 03/2013 p.242, 802D sl p.222)."""
import math

import numpy as np
import pytest
from export_helpers import DATA, E_XX_MM, E_YX_MM, X_MM, fixture_tables, profile, statements, tiny_machine

from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.errors import ControllerFileError, ControllerLimitError, InputError
from vecpin.export import siemens
from vecpin.export.common import ExportJob
from vecpin.fileio import OutputSet
from vecpin.units import from_mm, to_mm

FIX = DATA / "siemens"


def write(tables, machine, prof, out_dir, limits=siemens.LIMITS_840D):
    with OutputSet(out_dir) as out:
        job = ExportJob(tables, machine, prof, limits, out)
        names = siemens.write(job)
    return names, job.notes


def test_reader_parses_the_documented_example():
    """K3 examples: EEC values are errors (zero at X = 0, the reference), CEC values errors of the output axis."""
    m = tiny_machine()
    back = siemens.read(FIX, m, profile())
    assert sorted(back.names()) == ["xx", "yx"]
    xx, yx = back.table("xx"), back.table("yx")
    np.testing.assert_allclose(to_mm(xx.positions), X_MM)
    np.testing.assert_allclose(to_mm(xx.values), -E_XX_MM, atol=1e-12)   # correction = -error
    np.testing.assert_allclose(to_mm(yx.values), -E_YX_MM, atol=1e-12)
    assert (yx.input_axis, yx.output_axis) == ("X", "Y")                # (AX1) -> (AX2)


def test_writer_reproduces_the_documented_form(tmp_path):
    """Same statements as the hand-made example, comments aside: header, CHANDATA(1),
    (AXn) names in parentheses, values, STEP/MIN/MAX, DIRECTION, MULT_BY_TABLE, M17."""
    m = tiny_machine()
    write(fixture_tables(m), m, profile(), tmp_path)
    for name in ("NC_CEC.INI", "AX_EEC.INI"):
        assert statements((tmp_path / name).read_text()) == statements((FIX / name).read_text())
    assert (tmp_path / "NC_CEC.INI").read_text().splitlines()[1] == "CHANDATA(1)"


def test_eec_is_zero_at_the_reference_point_and_the_constant_goes_into_md34100(tmp_path):
    """The EEC table is zero at the reference point (K3 p.238); the correction there
    lowers the reference point value MD34100 (the machine coordinate the control gives the
    reference point: lower by c, and every command goes c further), so the files as a
    whole carry the full table."""
    m = tiny_machine()
    t = CompensationTable("X", "X", -0.2, 0.05, from_mm(np.array([0.30, 0.32, 0.33, 0.34, 0.35])))
    names, notes = write(TableSet(m.axis_names, [t]), m, profile(X={"reference_position": -100.0}), tmp_path)
    text = (tmp_path / "AX_EEC.INI").read_text()
    assert "$AA_ENC_COMP[0,2,X1]=0.0 ;" in text                       # X = -100: the reference point
    assert "$AA_ENC_COMP[0,0,X1]=0.03 ;" in text                      # error = -(0.30 - 0.33)
    refp = statements((tmp_path / "MD_REFP.INI").read_text())
    assert refp[0] == "%_N_MD_REFP_INI" and "$MA_REFP_SET_POS[0,X1]=-100.33" in refp and refp[-1] == "M17"
    assert any("+0.3300 mm" in n and "MD34100" in n and "MD_REFP.INI" in n for n in notes)
    assert "X: +0.3300 mm (MD34100 -100.0 -> -100.33)" in (tmp_path / "README_SIEMENS.md").read_text()
    back = siemens.read(tmp_path, m, profile(X={"reference_position": -100.0}))
    np.testing.assert_allclose(to_mm(back.table("xx").values), [0.30, 0.32, 0.33, 0.34, 0.35], atol=1e-9)
    (tmp_path / "MD_REFP.INI").unlink()                               # the tables alone: zero at the reference
    back = siemens.read(tmp_path, m, profile(X={"reference_position": -100.0}))
    np.testing.assert_allclose(to_mm(back.table("xx").values), [-0.03, -0.01, 0.0, 0.01, 0.02], atol=1e-9)


def test_cec_sign_is_the_error_of_the_compensation_axis(tmp_path):
    """K3 sag section: a positive value moves the axis negative, so the file holds minus
    the correction. (The old writer wrote the correction itself: the opposite sign.)"""
    m = tiny_machine()
    write(fixture_tables(m), m, profile(), tmp_path)
    text = (tmp_path / "NC_CEC.INI").read_text()
    assert "$AN_CEC[0,0]=-0.004 ;" in text and "$AN_CEC_OUTPUT_AXIS[0]=(AX2)" in text


def test_modulo_rotary_axis(tmp_path):
    m = tiny_machine()
    vals = from_mm(0.01 * np.sin(np.linspace(0, 2 * math.pi, 37)))
    t = CompensationTable("C", "X", 0.0, math.radians(10.0), vals, modulo=True)
    write(TableSet(m.axis_names, [t]), m, profile(C={"modulo": True}), tmp_path)
    text = (tmp_path / "NC_CEC.INI").read_text()
    assert "$AN_CEC_MIN[0]=0.0" in text and "$AN_CEC_MAX[0]=360.0" in text and "$AN_CEC_IS_MODULO[0]=1" in text
    # a modulo axis whose table covers the travel instead is refused
    plain = CompensationTable("C", "X", -math.pi, math.radians(10.0), vals)
    with pytest.raises(InputError, match="`modulo_axes` C"):
        write(TableSet(m.axis_names, [plain]), m, profile(C={"modulo": True}), tmp_path / "x")


def test_rotary_axis_past_a_turn_without_modulo_warns(flow, tmp_path):
    t = CompensationTable("C", "X", flow.axis("C").lower, math.radians(1.0), np.zeros(545))
    prof = profile_for(flow)
    _, notes = write(TableSet(flow.axis_names, [t]), flow, prof, tmp_path)
    assert any("C travels 544 deg" in n and "modulo" in n for n in notes)


def profile_for(machine):
    from vecpin.export.profile import ControllerProfile
    axes = {a.name: {"nc_name": a.name + "1", "reference_position": 0.0} for a in machine.axes}
    return ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1, "axes": axes})


def test_828d_limits_are_fixed_and_checked_first():
    lim = siemens.LIMITS_828D
    assert lim.max_cross_tables == 8 and lim.max_cross_points == 200 and lim.default_points == 200
    with pytest.raises(ControllerLimitError, match="at most 200 points"):
        lim.points(201)
    with pytest.raises(ControllerLimitError, match="at most 8 cross tables"):
        lim.constraints(9)
    with pytest.raises(ControllerLimitError, match="fixed"):
        siemens.FORMAT_828D.limits_for(profile(limits={"max_cross_points": 500}))
    assert siemens.FORMAT_828D.limits_for(profile(limits={"max_cross_points": 100})).max_cross_points == 100


def test_readme_lists_machine_data_and_monitoring(tmp_path):
    m = tiny_machine()
    write(fixture_tables(m), m, profile(), tmp_path)
    readme = (tmp_path / "README_SIEMENS.md").read_text()
    for md in ("MD18342", "MD38000", "MD32700", "MD32710", "SD41300", "MD32720", "MD32730"):
        assert md in readme
    assert "total CEC value at most 0.0040 mm" in readme            # max |e_YX|


def test_missing_facts_are_named():
    m = tiny_machine()
    bare = profile(X={"nc_name": None})
    with pytest.raises(InputError, match=r"machine axis name \(e.g. X1\) of axis X.*`axis_map` X=NAME"):
        siemens.check(m, bare, siemens.LIMITS_840D)
    with pytest.raises(InputError, match=r"reference point position in mm \(the EEC table must be zero there\) of axis Y"):
        siemens.check(m, profile(Y={"reference_position": None}), siemens.LIMITS_840D)


@pytest.mark.parametrize("name, bad, message, line", [
    ("AX_EEC.INI", ("$AA_ENC_COMP[0,2,X1]=0.005", "$AA_ENC_COMP[0,2,X1]=abc"), "not a number", 6),
    ("AX_EEC.INI", ("$AA_ENC_COMP_STEP[0,X1]=50.0", "$AA_ENC_COMP_STEP[0,X1]=40.0"), "points", None),
    ("NC_CEC.INI", ("$AN_CEC_INPUT_AXIS[0]=(AX1)", "$AN_CEC_INPUT_AXIS[0]=(AX9)"), "AX9", 9),
    ("NC_CEC.INI", ("M17", ""), "no M17", None),
    ("NC_CEC.INI", ("%_N_NC_CEC_INI", "%_N_XYZ_INI"), "first line", 1),
    ("NC_CEC.INI", ("$AN_CEC[0,3]=0.002 ; Y1 at X1 = -50 mm\n", ""), "value 3 is missing", None),
    ("NC_CEC.INI", ("$AN_CEC_DIRECTION[0]=0", "$AN_CEC_DIRECTION[0]=1"), "direction", 14),
])
def test_bad_files_name_file_and_line(tmp_path, name, bad, message, line):
    for f in ("AX_EEC.INI", "NC_CEC.INI"):
        (tmp_path / f).write_text((FIX / f).read_text())
    p = tmp_path / name
    p.write_text(p.read_text().replace(*bad))
    with pytest.raises(ControllerFileError, match=message) as exc:
        siemens.read(tmp_path, tiny_machine(), profile())
    assert exc.value.path == str(p)
    if line is not None:
        assert exc.value.line == line
