"""Shared by the controller-file tests: a small machine matching the hand-made fixtures
(tests/data/controllers/*, X and Y travel -200 .. 0 mm, reference point at 0) and the
fixtures' common truth (tests/data/controllers/README.md)."""
from pathlib import Path

import numpy as np

import vecpin
from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.export.profile import ControllerProfile
from vecpin.units import from_mm

DATA = Path(__file__).parent / "data" / "controllers"

# the fixtures' truth: errors (actual - nominal) at X = -200, -150, -100, -50, 0 mm
X_MM = np.array([-200.0, -150.0, -100.0, -50.0, 0.0])
E_XX_MM = np.array([0.012, 0.008, 0.005, 0.002, 0.0])
E_YX_MM = np.array([-0.004, -0.001, 0.003, 0.002, 0.0])

_LIMIT = '<limit lower="{lo}" upper="{hi}" effort="1" velocity="1"/>'
_PI = 3.14159265358979
TINY_URDF = f"""<?xml version="1.0"?>
<robot name="tiny_xyzc">
  <link name="base"/>
  <joint name="X" type="prismatic"><parent link="base"/><child link="x"/><axis xyz="1 0 0"/>
    {_LIMIT.format(lo=-0.2, hi=0.0)}</joint>
  <link name="x"/>
  <joint name="Y" type="prismatic"><parent link="x"/><child link="y"/><axis xyz="0 1 0"/>
    {_LIMIT.format(lo=-0.2, hi=0.0)}</joint>
  <link name="y"/>
  <joint name="Z" type="prismatic"><parent link="y"/><child link="z"/><axis xyz="0 0 1"/>
    {_LIMIT.format(lo=-0.2, hi=0.0)}</joint>
  <link name="z"/>
  <joint name="C" type="revolute"><parent link="z"/><child link="c"/><axis xyz="0 0 1"/>
    {_LIMIT.format(lo=-_PI, hi=_PI)}</joint>
  <link name="c"/>
  <joint name="tool_mount" type="fixed"><parent link="c"/><child link="spindle"/><origin xyz="0.05 0 0.1"/></joint>
  <link name="spindle"/>
</robot>
"""


def tiny_machine():
    return vecpin.Machine.from_urdf_string(TINY_URDF, source="tiny_xyzc (tests)")


def fixture_tables(machine) -> TableSet:
    """The fixtures' X pitch and Y-from-X tables as vecpin tables (corrections = -errors, SI)."""
    xx = CompensationTable("X", "X", -0.2, 0.05, from_mm(-E_XX_MM))
    yx = CompensationTable("X", "Y", -0.2, 0.05, from_mm(-E_YX_MM))
    return TableSet(machine.axis_names, [xx, yx])


def profile(**overrides) -> ControllerProfile:
    """Profile of the tiny machine: Siemens-style names, Fanuc/Beckhoff numbers, reference at 0."""
    axes = {"X": {"nc_name": "X1", "general_name": "AX1", "number": 1, "reference_position": 0.0,
                  "detection_unit": 0.001},
            "Y": {"nc_name": "Y1", "general_name": "AX2", "number": 2, "reference_position": 0.0,
                  "detection_unit": 0.001},
            "Z": {"nc_name": "Z1", "general_name": "AX3", "number": 3, "reference_position": 0.0,
                  "detection_unit": 0.001},
            "C": {"nc_name": "C1", "general_name": "AX4", "number": 4, "reference_position": 0.0,
                  "detection_unit": 0.001}}
    d = {"format": "vecpin-controller-profile", "version": 1, "axes": axes}
    for k, v in overrides.items():
        if k in ("limits", "options"):
            d[k] = v
        else:  # an axis: its facts, None removes one
            axes[k].update(v)
            for f in [f for f, x in axes[k].items() if x is None]:
                del axes[k][f]
    return ControllerProfile.from_dict(d, "test profile")


def statements(text: str, comment: str = ";") -> list[str]:
    """Non-empty lines without comments (for comparing forms)."""
    out = []
    for ln in text.splitlines():
        s = ln.split(comment, 1)[0].strip() if comment else ln.strip()
        if s:
            out.append(s)
    return out
