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
