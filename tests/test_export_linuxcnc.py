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
from vecpin.fileio import OutputSet

FIX = DATA / "linuxcnc"


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
    write(TableSet(m.axis_names, fixture_tables(m).tables[:1]), m, profile(options={"comp_file_type": kind}), tmp_path)
    ours = (tmp_path / "comp_X.txt").read_text().splitlines()
    fix = (FIX / name).read_text().splitlines()
    assert len(ours) == len(fix) and ours[-1].startswith("#") and fix[-1].startswith("#")
    np.testing.assert_allclose([[float(v) for v in ln.split()] for ln in ours[:-1]],
                               [[float(v) for v in ln.split()] for ln in fix[:-1]], atol=1e-9)
    readme = (tmp_path / "README_LINUXCNC.md").read_text()
    assert "[JOINT_1]" in readme and f"COMP_FILE_TYPE = {kind}" in readme and "Pitch (screw) compensation only" in readme


def test_round_trip(tmp_path):
    m = tiny_machine()
    x = np.linspace(-0.2, 0.0, 256)
    t = CompensationTable("X", "X", -0.2, x[1] - x[0], 1e-5 * np.sin(30 * x))
    write(TableSet(m.axis_names, [t]), m, profile(), tmp_path)
    back = linuxcnc.read(tmp_path, m, profile())
    q = np.linspace(-0.25, 0.05, 301)
    np.testing.assert_allclose(back.table("xx")(q), t(q), atol=1.01e-9)   # 1 nm: 6 decimals of mm, twice


def test_pitch_only_and_256_points():
    lim = linuxcnc.LIMITS
    assert not lim.cross_tables and lim.cross_limit(["X", "Y"]) == 0 and lim.default_points == 256
    with pytest.raises(ControllerLimitError, match="pitch tables only"):
        lim.check_tables(fixture_tables(tiny_machine()))
    with pytest.raises(ControllerLimitError, match="at most 256 points"):
        lim.points(257)
    with pytest.raises(InputError, match="no modulo"):
        linuxcnc.check(tiny_machine(), profile(), lim, ["C"])


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
        linuxcnc.read(tmp_path, tiny_machine(), profile(options={"comp_file_type": 1}))
