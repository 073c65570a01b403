"""vecpin's thermal HAL component on the real LinuxCNC (2.9, headless), chained after the
cross-table component as its HAL file says: both built with ``halcompile`` and loaded
with vecpin's HAL files, the ``temperature`` pin set with ``halcmd setp`` before each
move; at rest the drive got motion's command plus the cross tables (the cross
component's correction pin equals vecpin's tables) plus the thermal correction, which
equals vecpin's prediction of its thermal terms within 1e-6 mm, as do the thermal
component's ``correction-N`` pins (``halcmd getp``); motion's following error stays 0
(both feedback functions take their corrections off, in the chain's order), and a
stalled drive trips it. Runs where LinuxCNC is installed and the tests run as root
(tests/linuxcnc_sim.py); skipped with the reason elsewhere."""
import numpy as np
import pytest

import linuxcnc_sim as lcnc
import vecpin
from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.compensation.thermal import ThermalTerms
from vecpin.export import linuxcnc, thermal_linuxcnc
from vecpin.export.common import ExportJob
from vecpin.export.profile import ControllerProfile
from vecpin.fileio import OutputSet

WHY = lcnc.unavailable()
pytestmark = [pytest.mark.skipif(WHY is not None, reason=WHY or ""), pytest.mark.slow]
TOL_MM = 1e-6


def test_temperature_pin_moves_the_joints_as_vecpin_predicts(tmp_path):
    m = vecpin.Machine.load("trunnion_xyzac")
    terms = ThermalTerms(m.name, ["X", "Y", "Z"], 21.3, 0.0, {"X": 10.0, "Y": -40.0, "Z": -225.0},
                         {"X": 9.1, "Y": -6.7, "Z": 14.4}, {"X": 11.5, "Y": -8.2, "Z": 23.0}, None)
    prof = ControllerProfile()
    joints = linuxcnc.joint_numbers(m, prof)
    x, y = m.axis("X"), m.axis("Y")
    cross = TableSet(m.axis_names, [CompensationTable("X", "Y", x.lower, x.travel / 20, 3e-5 * np.sin(np.arange(21))),
                                    CompensationTable("Y", "Z", y.lower, y.travel / 10, -2e-5 * np.cos(np.arange(11)))])
    with OutputSet(tmp_path) as out:
        linuxcnc.write(ExportJob(cross, m, prof, linuxcnc.LIMITS, out))
        thermal_linuxcnc.write(terms, m, joints, len(joints), out, chained=True)
    lcnc.build_component(tmp_path / "vecpin_vec.comp")
    lcnc.build_component(tmp_path / thermal_linuxcnc.COMP_FILE)
    order = sorted(m.axis_names, key=lambda a: joints[a])
    ax = [m.axis(a) for a in order]
    limits = [(float(a.to_user(a.lower - 0.1 * a.travel)), float(a.to_user(a.upper + 0.1 * a.travel))) for a in ax]
    commands = [[-300.0, 250.0, -440.0, 10.0, 0.0], [310.0, -250.0, -5.0, -100.0, 700.0],
                [0.0, 0.0, -200.0, 0.0, -30.0], [123.4, 56.7, -89.0, 12.0, 34.0]]
    temps = [14.9, 33.2, 21.3, 27.85]                 # degC: below, above and at T0
    hal = f"{thermal_linuxcnc.HAL_NAME}.0"
    res = lcnc.run(tmp_path, order, [a.kind for a in ax], limits, commands, {},
                   ["vecpin_vec.hal", thermal_linuxcnc.HAL_FILE], stall=True,
                   component=["vecpin_vec", thermal_linuxcnc.COMPONENT],
                   setp=[{f"{hal}.temperature": t} for t in temps],
                   getp=[f"{hal}.correction-{j}" for j in range(len(order))])
    for row, cmd, t in zip(res["rows"], commands, temps):
        pos_si = np.array([[m.axis(a).to_si(row[f"joint.{joints[a]}.pos-cmd"]) for a in m.axis_names]])
        tables = {a: float(m.axis(a).to_user(v)) for a, v in zip(m.axis_names, cross.increments(pos_si)[0])}
        for j, a in enumerate(order):
            pos = row[f"joint.{j}.pos-cmd"]
            assert pos == pytest.approx(cmd[j], abs=1e-6)
            want = terms.axis_correction_mm(a, pos, t) if a in terms.axes else 0.0
            vec = row[f"vecpin-vec.0.correction-{j}"]
            assert vec == pytest.approx(tables[a], abs=TOL_MM), a                # the cross tables, first
            got = row[f"drive-{j}.out"] - row[f"joint.{j}.motor-pos-cmd"] - vec  # what the drive got beyond them
            assert got == pytest.approx(want, abs=TOL_MM), (a, t)
            assert row[f"{hal}.correction-{j}"] == pytest.approx(want, abs=TOL_MM), (a, t)
            assert abs(row["ferror"][j]) < TOL_MM                                 # the feedback takes it off
    moved = [row[f"drive-{j}.out"] - row[f"joint.{j}.motor-pos-cmd"] for row in res["rows"] for j in range(3)]
    assert np.abs(moved).max() > 0.05                                               # not trivially met
    assert any("following error" in e for e in res["stall"]["errors"])            # the drives' feedback is used
