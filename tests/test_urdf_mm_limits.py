"""Limits written in mm in a URDF (metres) are warned of when the machine loads: a linear
travel of 735 m is read as 735 mm written without the conversion. The bundled machines,
gantries of tens of metres included, load without it."""
import warnings

import pytest

import vecpin
from vecpin.errors import VecpinWarning
from vecpin.kinematics.axes import bundled_machines

URDF = """<?xml version="1.0"?>
<robot name="mm_limits">
  <link name="base"/>
  <joint name="X" type="prismatic"><parent link="base"/><child link="x"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="{upper}" effort="1" velocity="1"/></joint>
  <link name="x"/>
  <joint name="Z" type="prismatic"><parent link="x"/><child link="spindle"/><axis xyz="0 0 1"/>
    <limit lower="-0.5" upper="0" effort="1" velocity="1"/></joint>
  <link name="spindle"/>
</robot>
"""


def test_a_travel_in_mm_is_warned_of(tmp_path):
    path = tmp_path / "m.urdf"
    path.write_text(URDF.format(upper="735"))
    with pytest.warns(VecpinWarning, match=r"joint 'X'.*travel of 735 m.*735 mm is written 0\.735"):
        vecpin.Machine.load(str(path))
    path.write_text(URDF.format(upper="0.735"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", VecpinWarning)
        assert vecpin.Machine.load(str(path)).axes[0].travel == pytest.approx(0.735)


@pytest.mark.parametrize("name", bundled_machines())
def test_the_bundled_machines_load_without_it(name):
    with warnings.catch_warnings():
        warnings.simplefilter("error", VecpinWarning)
        vecpin.Machine.load(name)
