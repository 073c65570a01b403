"""Table names on machines whose joints carry vendor names (x_axis, c_axis): the two axis
names stay apart ('y_axis_x_axis', not 'y_axisx_axis') in every format's files, read
back by each format's reader, and the sign test's program names keep to each control's
rules; the bundled machines (one letter per axis) keep the seed's names ('yx')."""
import json
import re

import numpy as np
import pytest
from export_helpers import TINY_URDF

import vecpin
from vecpin.compensation.limits import ControllerLimits
from vecpin.compensation.selection import Constraints
from vecpin.compensation.tables import CompensationTable, TableSet, cross_table_axes, table_name, table_names
from vecpin.errors import MachineError
from vecpin.export.common import ExportJob
from vecpin.export.profile import ControllerProfile
from vecpin.export.registry import get_format
from vecpin.export.signtest import plan_sign_test, program
from vecpin.fileio import OutputSet
from vecpin.units import from_mm

CONTROLLERS = ("siemens-840d", "heidenhain", "fanuc-30i", "linuxcnc", "beckhoff", "generic")
# the file where a format writes table names
NAMED_IN = {"siemens-840d": "README_SIEMENS.md", "linuxcnc": "vecpin_vec.comp", "beckhoff": "README_BECKHOFF.md",
            "generic": "tables.json"}
PROGRAM_RULES = {  # the sign test's program file name (no extension) by dialect, from the vendors' manuals
    "siemens": r"[A-Za-z][A-Za-z_][A-Za-z0-9_]{0,22}",  # Siemens: letters, digits, '_', at most 24 characters
    "heidenhain": r"[A-Za-z0-9._-]{1,24}",                # Heidenhain: POSIX file names, 24 shown
    "fanuc": r"[A-Za-z0-9_]{1,32}",                       # Fanuc 30i data server: 32 characters
    "linuxcnc": r"[a-z0-9_]+", "din": r"[A-Za-z0-9_]+"}


def vendor_machine():
    urdf = TINY_URDF
    for a in "XYZC":
        urdf = urdf.replace(f'<joint name="{a}"', f'<joint name="{a.lower()}_axis"')
    return vecpin.Machine.from_urdf_string(urdf, source="vendor joint names (tests)")


def vendor_tables(m) -> TableSet:
    """A pitch table per axis and two cross tables (Y from X, X from C), SI."""
    x = np.linspace(-200.0, 0.0, 5)
    pitch = [CompensationTable(a.name, a.name, a.lower, a.travel / 4, from_mm(0.01 * np.sin(np.arange(5.0) + k)))
             for k, a in enumerate(m.axes)]
    return TableSet(m.axis_names, pitch + [CompensationTable("x_axis", "y_axis", -0.2, 0.05, from_mm(0.004 * np.sin(x / 50))),
                                           CompensationTable("c_axis", "x_axis", -np.pi, np.pi / 2,
                                                             from_mm(0.002 * np.arange(5.0)))])


def vendor_profile(first: int) -> ControllerProfile:
    axes = {f"{a.lower()}_axis": {"nc_name": f"{a}1", "general_name": f"AX{k + 1}", "number": k + first,
                                  "reference_position": 0.0, "detection_unit": 0.001, "program_name": a}
            for k, a in enumerate("XYZC")}
    return ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1, "axes": axes}, "test")


def test_bundled_machines_keep_the_seed_names(machines):
    """One letter per axis: output and input letters run together, as the seed and every
    existing file names them (and the twin drive's X2 as 'yx2')."""
    for name, m in machines.items():
        if all(len(a) == 1 for a in m.axis_names):
            assert table_names(m.axis_names) == [o.lower() + i.lower() for o in m.axis_names for i in m.axis_names], name
    assert (table_name("Y", "X2"), table_name("X2", "Y"), table_name("X2", "X2")) == ("yx2", "x2y", "x2x2")


def test_vendor_axis_names_stay_apart_in_every_format(tmp_path):
    m = vendor_machine()
    tables = vendor_tables(m)
    assert sorted(t.name for t in tables.tables if not t.is_pitch) == ["x_axis_c_axis", "y_axis_x_axis"]
    for ctl in CONTROLLERS:
        fmt = get_format(ctl)
        prof = vendor_profile(0 if ctl == "linuxcnc" else 1)
        with OutputSet(tmp_path / ctl) as out:
            files = fmt.write(ExportJob(tables, m, prof, fmt.limits, out))
        text = "\n".join((tmp_path / ctl / f).read_text() for f in files).lower()
        assert "y_axisx_axis" not in text and "x_axisc_axis" not in text, ctl
        if ctl in NAMED_IN:
            assert "y_axis_x_axis" in (tmp_path / ctl / NAMED_IN[ctl]).read_text(), ctl
        back = fmt.read(tmp_path / ctl, m, prof)
        cross = sorted(t.name for t in back.tables if not t.is_pitch)
        assert set(cross) <= {"x_axis_c_axis", "y_axis_x_axis"} and "y_axis_x_axis" in cross, (ctl, cross)
    generic = json.loads((tmp_path / "generic" / "tables.json").read_text())
    assert {t["name"]: (t["output_axis"], t["input_axis"]) for t in generic["tables"]}["x_axis_c_axis"] == ("x_axis",
                                                                                                        "c_axis")


@pytest.mark.parametrize("dialect", sorted(PROGRAM_RULES))
def test_sign_test_program_names_keep_each_controls_rules(dialect):
    """The sign test's program is named after its table: within each control's characters
    and length, also for long joint names (cut; the program's comment names the table)."""
    m = vendor_machine()
    robot = vecpin.Machine.load("ur10")
    long = CompensationTable("shoulder_lift_joint", "shoulder_pan_joint", -np.pi, np.pi / 4, np.linspace(0, 1e-4, 9))
    for machine, table in ((m, vendor_tables(m).table("y_axis_x_axis")), (robot, long)):
        st = plan_sign_test(table, machine, "test", [], "value = correction")
        name, text = program(st, dialect, "X")
        assert re.fullmatch(PROGRAM_RULES[dialect], name.rsplit(".", 1)[0]), name
        assert f"table {table.name}" in text.lower()  # Fanuc comments are in capitals
    assert name.upper().startswith("SIGNTEST_SHOULDER_PAN") or name.startswith("signtest_shoulder_pan")


def test_selection_rules_read_vendor_names_by_their_axes():
    """No circular pair (Y from X with X from Y) and one cross table per output axis
    (Beckhoff) hold for vendor names and for NC names with digits (X1, X2)."""
    c = Constraints(2, no_circular=True)
    vendor, nc = cross_table_axes(["x_axis", "y_axis", "c_axis"]), cross_table_axes(["X1", "X2", "Y"])
    assert not c.compatible("y_axis_x_axis", "x_axis_y_axis", vendor) and c.compatible("y_axis_x_axis", "y_axis_c_axis", vendor)
    assert not c.compatible("yx1", "x1y", nc) and not c.compatible("x2y", "yx2", nc) and c.compatible("x1x2", "x2y", nc)
    one = ControllerLimits("one per output", one_cross_table_per_output=True)
    pairs = set(one.constraints(2, axis_names=["X1", "X2", "Y"]).forbidden_pairs)
    assert pairs == {("x1x2", "x1y"), ("x2x1", "x2y"), ("yx1", "yx2")}
    pairs = set(one.constraints(2, axis_names=["x_axis", "y_axis", "c_axis"]).forbidden_pairs)
    assert ("x_axis_c_axis", "x_axis_y_axis") in pairs and len(pairs) == 3


def test_axes_whose_tables_would_share_a_name_are_refused():
    with pytest.raises(MachineError, match="would both be named 'a_b_c'.*rename an axis joint"):
        table_names(["a_b", "c", "a", "b_c"])


def test_iso230_q_columns_keep_vendor_axis_names_apart(tmp_path):
    """An AP model's error of a rotary axis' angle as a function of another axis is the
    ISO 230 file's column Q<J><I>: 'Qc_axis_x_axis' (in degrees), read back by its reader."""
    from vecpin.export import iso230
    from vecpin.models import make_model
    m = vendor_machine()
    model = make_model("ap", m, 2)
    model.b_ = np.random.default_rng(0).normal(size=model.n_parameters) * 1e-5
    fmt = get_format("iso230")
    with OutputSet(tmp_path) as out:
        fmt.write(ExportJob(vendor_tables(m), m, vendor_profile(1), fmt.limits, out, model))
    header = [ln for ln in (tmp_path / "ISO230_x_axis.csv").read_text().splitlines() if not ln.startswith("#")][0]
    assert "Qc_axis_x_axis_deg" in header.split(",") and "Qc_axisx_axis" not in header
    back = iso230.read_neutral(tmp_path / "ISO230_x_axis.csv", m)
    assert back.axis == "x_axis" and "Qc_axis_x_axis" in back.errors
    from vecpin.compensation.tables import joined_axes
    assert joined_axes("C", "X") == "CX"  # the bundled machines' columns: QCX as before
