"""vecpin's thermal HAL component on the real LinuxCNC (2.9, headless): built with
``halcompile``, loaded with vecpin's HAL file, its ``temperature`` pin set with ``halcmd
setp`` before each move; at rest the joint corrections the drives got (drive position
less ``motor-pos-cmd``) and the component's ``correction-N`` pins (``halcmd getp``) equal
vecpin's prediction of its thermal terms within 1e-6 mm, and motion's following error
stays 0 (the feedback path takes the correction off). Runs where LinuxCNC is installed
and the tests run as root (tests/linuxcnc_sim.py); skipped with the reason elsewhere."""
import numpy as np
import pytest

import linuxcnc_sim as lcnc
import vecpin
from vecpin.compensation.thermal import ThermalTerms
from vecpin.export import linuxcnc, thermal_linuxcnc
from vecpin.export.profile import ControllerProfile
from vecpin.fileio import OutputSet

WHY = lcnc.unavailable()
pytestmark = [pytest.mark.skipif(WHY is not None, reason=WHY or ""), pytest.mark.slow]
TOL_MM = 1e-6


def test_temperature_pin_moves_the_joints_as_vecpin_predicts(tmp_path):
    m = vecpin.Machine.load("trunnion_xyzac")
    terms = ThermalTerms(m.name, ["X", "Y", "Z"], 21.3, 0.0, {"X": 10.0, "Y": -40.0, "Z": -225.0},
                         {"X": 9.1, "Y": -6.7, "Z": 14.4}, {"X": 11.5, "Y": -8.2, "Z": 23.0}, None)
    joints = linuxcnc.joint_numbers(m, ControllerProfile())
    with OutputSet(tmp_path) as out:
        thermal_linuxcnc.write(terms, m, joints, len(joints), out, chained=False)
    lcnc.build_component(tmp_path / thermal_linuxcnc.COMP_FILE)
    order = sorted(m.axis_names, key=lambda a: joints[a])
    ax = [m.axis(a) for a in order]
    limits = [(float(a.to_user(a.lower - 0.1 * a.travel)), float(a.to_user(a.upper + 0.1 * a.travel))) for a in ax]
    commands = [[-300.0, 250.0, -440.0, 10.0, 0.0], [310.0, -250.0, -5.0, -100.0, 700.0],
                [0.0, 0.0, -200.0, 0.0, -30.0], [123.4, 56.7, -89.0, 12.0, 34.0]]
    temps = [14.9, 33.2, 21.3, 27.85]                 # degC: below, above and at T0
    hal = f"{thermal_linuxcnc.HAL_NAME}.0"
    res = lcnc.run(tmp_path, order, [a.kind for a in ax], limits, commands, {}, thermal_linuxcnc.HAL_FILE,
                   stall=True, component=thermal_linuxcnc.COMPONENT,
                   setp=[{f"{hal}.temperature": t} for t in temps],
                   getp=[f"{hal}.correction-{j}" for j in range(len(order))])
    for row, cmd, t in zip(res["rows"], commands, temps):
        for j, a in enumerate(order):
            pos = row[f"joint.{j}.pos-cmd"]
            assert pos == pytest.approx(cmd[j], abs=1e-6)
            want = terms.axis_correction_mm(a, pos, t) if a in terms.axes else 0.0
            got = row[f"drive-{j}.out"] - row[f"joint.{j}.motor-pos-cmd"]        # what the drive got
            assert got == pytest.approx(want, abs=TOL_MM), (a, t)
            assert row[f"{hal}.correction-{j}"] == pytest.approx(want, abs=TOL_MM), (a, t)
            assert abs(row["ferror"][j]) < TOL_MM                                 # the feedback takes it off
    moved = [row[f"drive-{j}.out"] - row[f"joint.{j}.motor-pos-cmd"] for row in res["rows"] for j in range(3)]
    assert np.abs(moved).max() > 0.05                                               # not trivially met
    assert any("following error" in e for e in res["stall"]["errors"])            # the drives' feedback is used
