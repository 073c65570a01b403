"""A machine whose joints carry vendor names (X_axis, ...): the profile's ``program_name``
(the axis letter of part programs) is what the INI's trivkins coordinates are checked
against, so joint numbers that swap two axes are refused as with lettered axes."""
import pytest
from export_helpers import TINY_URDF

import vecpin
from vecpin.errors import InputError
from vecpin.export import linuxcnc
from vecpin.export.profile import ControllerProfile


def _profile(numbers, ini):
    axes = {f"{a}_axis": {"number": n, "program_name": a} for a, n in numbers.items()}
    return ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1, "axes": axes,
                                        "options": {"ini": str(ini)}})


def test_program_names_are_checked_against_trivkins(tmp_path):
    urdf = TINY_URDF
    for a in "XYZC":
        urdf = urdf.replace(f'<joint name="{a}"', f'<joint name="{a}_axis"')
    m = vecpin.Machine.from_urdf_string(urdf, source="vendor names (tests)")
    ini = tmp_path / "machine.ini"
    ini.write_text("[KINS]\nKINEMATICS = trivkins coordinates=XYZC\nJOINTS = 4\n[TRAJ]\nLINEAR_UNITS = mm\n"
                   "ANGULAR_UNITS = degree\n[JOINT_3]\nTYPE = ANGULAR\n")
    linuxcnc.check(m, _profile({"X": 0, "Y": 1, "Z": 2, "C": 3}, ini), linuxcnc.LIMITS)
    with pytest.raises(InputError, match="coordinates=XYZC make joint 1 axis Y, but the profile puts X_axis "
                                         r"\(axis letter X\) on joint 1"):
        linuxcnc.check(m, _profile({"X": 1, "Y": 0, "Z": 2, "C": 3}, ini), linuxcnc.LIMITS)
