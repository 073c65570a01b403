"""LinuxCNC COMP_FILE: both types, the loader's rules (read from the LinuxCNC source,
usrmotintf.cc usrmotLoadComp, command.c EMCMOT_SET_JOINT_COMP), pitch only.
Fixtures: tests/data/controllers/linuxcnc (ini-config.adoc:1111-1145 form)."""
import numpy as np
import pytest
from export_helpers import DATA, E_XX_MM, X_MM, fixture_tables, profile, tiny_machine

from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.errors import ControllerFileError, ControllerLimitError, InputError
from vecpin.export import linuxcnc
from vecpin.export.common import ExportJob
from vecpin.export.profile import ControllerProfile
from vecpin.fileio import OutputSet

FIX = DATA / "linuxcnc"
JOINTS = {"X": {"number": 0}, "Y": {"number": 1}, "Z": {"number": 2}, "C": {"number": 3}}


def lprofile(**overrides):
    """The tiny machine's profile with LinuxCNC joint numbers (from 0)."""
    return profile(**{**JOINTS, **overrides})


def write(tables, machine, prof, out_dir):
    with OutputSet(out_dir) as out:
        linuxcnc.write(ExportJob(tables, machine, prof, linuxcnc.LIMITS, out))


@pytest.mark.parametrize("kind, name", [(0, "x_comp_type0.txt"), (1, "x_comp_type1.txt")])
def test_reader_parses_both_documented_types(kind, name):
    """type 0: trim = nominal - actual; type 1: trims as given; both = -e_XX."""
    nominal, fwd, rev = linuxcnc.read_comp_file(FIX / name, kind)
    np.testing.assert_allclose(nominal, X_MM)
    np.testing.assert_allclose(fwd, -E_XX_MM, atol=1e-9)
    np.testing.assert_allclose(rev, -E_XX_MM, atol=1e-9)


@pytest.mark.parametrize("kind, name", [(0, "x_comp_type0.txt"), (1, "x_comp_type1.txt")])
def test_writer_reproduces_the_form(tmp_path, kind, name):
    m = tiny_machine()
    write(TableSet(m.axis_names, fixture_tables(m).tables[:1]), m, lprofile(options={"comp_file_type": kind}), tmp_path)
    ours = (tmp_path / "comp_X.txt").read_text().splitlines()
    fix = (FIX / name).read_text().splitlines()
    assert len(ours) == len(fix) and ours[-1].startswith("#") and fix[-1].startswith("#")
    np.testing.assert_allclose([[float(v) for v in ln.split()] for ln in ours[:-1]],
                               [[float(v) for v in ln.split()] for ln in fix[:-1]], atol=1e-9)
    readme = (tmp_path / "README_LINUXCNC.md").read_text()
    assert "[JOINT_0]\nCOMP_FILE = comp_X.txt" in readme and f"COMP_FILE_TYPE = {kind}" in readme
    assert "No cross tables in this set" in readme and not (tmp_path / "vecpin_vec.comp").exists()


def test_round_trip(tmp_path):
    m = tiny_machine()
    x = np.linspace(-0.2, 0.0, 256)
    t = CompensationTable("X", "X", -0.2, x[1] - x[0], 1e-5 * np.sin(30 * x))
    write(TableSet(m.axis_names, [t]), m, lprofile(), tmp_path)
    back = linuxcnc.read(tmp_path, m, lprofile())
    q = np.linspace(-0.25, 0.05, 301)
    np.testing.assert_allclose(back.table("xx")(q), t(q), atol=1.01e-9)   # 1 nm: 6 decimals of mm, twice


def test_256_points_and_pitch_only_by_profile():
    lim = linuxcnc.LIMITS
    assert lim.cross_tables and lim.cross_limit(["X", "Y"]) is None and lim.default_points == 256
    lim.check_tables(fixture_tables(tiny_machine()))                  # cross tables: the HAL component
    with pytest.raises(ControllerLimitError, match="at most 256 points"):
        lim.points(257)
    pitch_only = linuxcnc.FORMAT.limits_for(lprofile(limits={"max_cross_tables": 0}))
    assert pitch_only.cross_limit(["X", "Y"]) == 0
    with pytest.raises(InputError, match="no modulo"):
        linuxcnc.check(tiny_machine(), lprofile(), lim, ["C"])


def test_cross_tables_round_trip_through_the_component(tmp_path):
    """The component's C arrays hold the cross tables to the last bit; its table comments
    name the joints, and a file whose joints are not the profile's is refused."""
    m = tiny_machine()
    tables = fixture_tables(m)
    write(tables, m, lprofile(), tmp_path)
    src = (tmp_path / "vecpin_vec.comp").read_text()
    assert "/* table yx: joint 1 (Y) from joint 0 (X)" in src and "pin in float pos_cmd_#[4]" in src
    hal = (tmp_path / "vecpin_vec.hal").read_text()
    assert "net vecpin-j0-pos-cmd joint.0.pos-cmd => vecpin-vec.0.pos-cmd-0" in hal
    # the feedback function first in the servo thread (before motion), the command function last (after it)
    addf = [ln.split() for ln in hal.splitlines() if ln.startswith("addf")]
    assert addf == [["addf", "vecpin-vec.0.feedback", "servo-thread", "1"],
                    ["addf", "vecpin-vec.0.command", "servo-thread"]]
    back = linuxcnc.read(tmp_path, m, lprofile())
    assert sorted(back.names()) == ["xx", "yx"]
    np.testing.assert_array_equal(back.table("yx").values, tables.table("yx").values)
    with pytest.raises(ControllerFileError, match="joint 1 is Y in the file but Z in the profile"):
        linuxcnc.read(tmp_path, m, profile(X={"number": 0}, Y={"number": 2}, Z={"number": 1}, C={"number": 3}))


def test_joint_numbers_count_from_zero(tmp_path):
    m = tiny_machine()
    assert linuxcnc.joint_numbers(m, ControllerProfile()) == {"X": 0, "Y": 1, "Z": 2, "C": 3}
    with pytest.raises(InputError, match="no axis is joint 0 .X is joint 1.: LinuxCNC counts joints from 0"):
        linuxcnc.check(m, profile(), linuxcnc.LIMITS)                # the Fanuc-style 1..4
    with pytest.raises(InputError, match="axes X and Y both have number 0"):                 # refused on load
        linuxcnc.joint_numbers(m, lprofile(Y={"number": 0}))
    with pytest.raises(InputError, match="C has no joint number while other axes have one"):
        linuxcnc.joint_numbers(m, profile(X={"number": 0}, Y={"number": 1}, Z={"number": 2}, C={"number": None}))


def test_joint_numbers_checked_against_the_ini(tmp_path):
    m = tiny_machine()
    ini = tmp_path / "machine.ini"
    ini.write_text("[KINS]\nKINEMATICS = trivkins coordinates=XYZC\nJOINTS = 4\n[TRAJ]\nLINEAR_UNITS = mm\n"
                   "ANGULAR_UNITS = degree\n[JOINT_3]\nTYPE = ANGULAR\n")
    linuxcnc.check(m, lprofile(options={"ini": str(ini)}), linuxcnc.LIMITS)
    one_based = profile(options={"ini": str(ini)})                   # X=1..C=4 against a 4-joint INI
    with pytest.raises(InputError, match=r"JOINTS = 4, but the profile puts C on joint 4"):
        linuxcnc.check(m, one_based, linuxcnc.LIMITS)
    swapped = lprofile(X={"number": 1}, Y={"number": 0}, options={"ini": str(ini)})
    with pytest.raises(InputError, match="coordinates=XYZC make joint 1 axis Y, but the profile puts X"):
        linuxcnc.check(m, swapped, linuxcnc.LIMITS)
    ini.write_text(ini.read_text().replace("LINEAR_UNITS = mm", "LINEAR_UNITS = inch"))
    with pytest.raises(InputError, match="LINEAR_UNITS = inch; vecpin's files are in mm"):
        linuxcnc.check(m, lprofile(options={"ini": str(ini)}), linuxcnc.LIMITS)
    with pytest.raises(InputError, match="cannot read"):
        linuxcnc.check(m, lprofile(options={"ini": str(tmp_path / "none.ini")}), linuxcnc.LIMITS)


def test_loader_rules_are_enforced(tmp_path):
    p = tmp_path / "comp_X.txt"
    p.write_text("0 0 0\n1 0 0\n1 0 0\n")
    with pytest.raises(ControllerFileError, match="does not increase") as exc:
        linuxcnc.read_comp_file(p, 1)
    assert exc.value.line == 3
    p.write_text("# header\n0 0 0\n1 0 0\n")                      # LinuxCNC reads nothing here
    with pytest.raises(ControllerFileError, match="stops reading at line 1") as exc:
        linuxcnc.read_comp_file(p, 1)
    assert exc.value.line == 2
    p.write_text("".join(f"{k} 0 0\n" for k in range(257)))
    with pytest.raises(ControllerFileError, match="holds 256"):
        linuxcnc.read_comp_file(p, 1)
    p.write_text("0,0,0\n")
    with pytest.raises(ControllerFileError, match="no entry"):
        linuxcnc.read_comp_file(p, 1)
    p.write_text("0 0.001 0\n1 0 0\n")
    with pytest.raises(ControllerFileError, match="direction"):
        linuxcnc.read(tmp_path, tiny_machine(), lprofile(options={"comp_file_type": 1}))
