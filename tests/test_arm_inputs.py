"""Arms as users bring them (issue 41): a URDF xacro generated (``<robot xmlns:xacro=...>``
and no ``xacro:`` element, as example-robot-data's ur5_robot.urdf) loads as the plain
URDF it is; a file with a real ``<xacro:macro>`` is still refused with the xacro message."""
from pathlib import Path

import numpy as np
import pytest

import vecpin
from vecpin.errors import MachineError

UR5 = Path(__file__).resolve().parents[1] / "robots" / "ur5.urdf"
XMLNS = '<robot xmlns:xacro="http://wiki.ros.org/xacro" name="ur5">'


def test_xacro_generated_urdf_loads_as_the_plain_one(tmp_path):
    text = UR5.read_text()
    assert '<robot name="ur5">' in text
    path = tmp_path / "ur5_robot.urdf"
    path.write_text(text.replace('<robot name="ur5">', XMLNS))
    m = vecpin.Machine.load(path, tool_link="tool0")
    plain = vecpin.Machine.load(UR5, tool_link="tool0")
    q = np.radians([[10.0, -80.0, 70.0, -30.0, 95.0, 20.0]])
    assert m.axis_names == plain.axis_names
    assert np.allclose(m.tool_tip(q, 0.2), plain.tool_tip(q, 0.2), atol=1e-12)


def test_urdf_with_a_xacro_macro_is_refused(tmp_path):
    macro = '<xacro:macro name="arm" params="prefix"><link name="${prefix}x"/></xacro:macro>'
    text = UR5.read_text().replace('<robot name="ur5">', XMLNS + macro)
    path = tmp_path / "ur5_macro.urdf"
    path.write_text(text)
    with pytest.raises(MachineError, match="a xacro macro file, not a URDF: expand the xacro first"):
        vecpin.Machine.load(path, tool_link="tool0")


# ---------------------------------------------------------------- names and advice that fit an arm
def test_arm_tables_read_as_joints_and_the_gauge_line_goes_to_the_tcp():
    from types import SimpleNamespace

    from vecpin.compensation.tables import CompensationTable, TableSet
    from vecpin.export import boundary
    from vecpin.workflows.tables import TableRun
    m = vecpin.Machine.load("ur5")
    j = m.axis_names
    ts = TableSet(j, [CompensationTable(j[0], j[1], -1.0, 0.5, np.zeros(5)),
                      CompensationTable(j[0], j[0], -1.0, 0.5, np.zeros(5))], gauge_offset_change=2e-5)
    run = SimpleNamespace(plan=SimpleNamespace(tables=ts, problem=SimpleNamespace(machine=m)))
    lines = TableRun._table_names(run, "5 points each")
    assert lines[0].startswith("  tables: J2(J1) J1(J1)  (2 tables") and "J1 shoulder_pan_joint" in lines[1]
    assert "shoulder_pan_joint_shoulder_lift_joint" not in lines[0]
    arm = boundary.gauge_text("siemens-840d", 2e-5, arm=True)
    assert "TCP" in arm and "pivot" not in arm and "transformation" not in arm and "flange" in arm
    assert "pivot" in boundary.gauge_text("siemens-840d", 2e-5)        # a machine tool's is unchanged
    cnc = TableRun._table_names(SimpleNamespace(plan=SimpleNamespace(
        tables=TableSet(["X", "Y"], [CompensationTable("X", "Y", 0.0, 0.1, np.zeros(3))]),
        problem=SimpleNamespace(machine=vecpin.Machine.load("flow_xyzcb")))), "3 points each")
    assert cnc == ["  tables: yx  (1 tables, 3 points each)"]


def test_diagnosis_advice_for_an_arm_names_robot_remedies():
    from vecpin.diagnosis.armadvice import BASE_REMEDY, arm_advice
    from vecpin.models.effects import REGISTRY
    arm, mill = vecpin.Machine.load("ur5"), vecpin.Machine.load("flow_xyzcb")
    j2 = arm.axis_names[1]
    back = REGISTRY["backlash"](arm, (j2,))
    cnc_lines = back.advice(np.array([1e-4]), np.array([1e-5]))
    assert "MD32450" in cnc_lines[0]                                    # the machine-tool text names a CNC parameter
    lines = arm_advice(arm, back, cnc_lines)
    assert "0.0115" in lines[0] and "MD32450" not in lines[0] and "DH or MDH" in lines[0]
    assert arm_advice(mill, back, cnc_lines) == cnc_lines               # unchanged on a machine tool
    coupled = REGISTRY["coupled_axes"](arm, (j2, arm.axis_names[2]))
    text = " ".join(arm_advice(arm, coupled, coupled.advice(np.zeros(4), np.zeros(4))))
    assert "table" not in text.replace("compensation table", "")
    assert "DH or MDH parameters in the robot controller" in text
    assert all(w in BASE_REMEDY for w in ("DH or MDH", "TCP", "payload"))


# ---------------------------------------------------------------- view: package:// meshes of a ROS package
def test_package_meshes_found_in_a_ros_package_layout(tmp_path):
    """ur_description/urdf/ur5.urdf naming package://ur_description/meshes/...: the package is
    the URDF folder's parent; the machine is drawn with the mesh, and a missing one is
    named in one note."""
    import shutil

    import meshcat

    from vecpin.viz.scene import RecordingWindow, _machine_geometry, resolve_meshes
    pkg = tmp_path / "ws" / "src" / "ur_description"
    (pkg / "urdf").mkdir(parents=True)
    (pkg / "meshes").mkdir()
    shutil.copy(Path(__file__).parent / "data" / "hostile" / "tet.stl", pkg / "meshes" / "base.stl")
    text = UR5.read_text().replace('<cylinder radius="0.075" length="0.06"/>',
                                   '<mesh filename="package://ur_description/meshes/base.stl"/>', 1)
    text = text.replace('<cylinder radius="0.06" length="0.08"/>',
                        '<mesh filename="package://ur_description/meshes/gone.stl"/>', 1)
    assert text.count("package://") == 2
    urdf = pkg / "urdf" / "ur5.urdf"
    urdf.write_text(text)
    xml, missing = resolve_meshes(text, [urdf.parent])
    assert missing == ["package://ur_description/meshes/gone.stl"]
    assert str((pkg / "meshes" / "base.stl").resolve()) in xml
    m = vecpin.Machine.load(urdf, tool_link="tool0")
    window = RecordingWindow()
    notes = _machine_geometry(meshcat.Visualizer(window=window), m, np.zeros(6), [urdf.parent])
    assert len(notes) == 1
    assert "drawn without 1 mesh file(s) not found (package://ur_description/meshes/gone.stl" in notes[0]
    assert any("base_link" in str(k) for k in window.commands)
