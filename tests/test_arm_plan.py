"""An arm's plan (issue 41): the URScript program and the joint list, read by a small
reader (tests/robot_programs.py) written from the URScript manual's movej(q, a, v) (q in radians) and the
joint list's columns, judged with Pinocchio's forward kinematics of the URDF directly
(not vecpin's planner): every approach pose lies the stated clearance back along the
tool axis from the measured tip with the same orientation, every visited pose inside
the URDF's joint limits, the measured poses are the template's commands."""
from __future__ import annotations

import csv
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from robot_programs import read_joint_list, read_urscript
from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.planning.plan import PlanSettings
from vecpin.planning.sightline import SightLine
from vecpin.workflows.planning import plan_to_dir

UR5 = Path(__file__).resolve().parents[1] / "robots" / "ur5.urdf"
CLEARANCE_MM = 20.0
SETTINGS = dict(n_commands=24, order=1, candidates=300, n_validation=4, repeat_points=2, repeat_times=2,
                approach_mm=CLEARANCE_MM, seed=3)


def urdf_limits(path: Path) -> tuple[np.ndarray, np.ndarray]:
    joints = [j for j in ET.parse(path).getroot().iter("joint") if j.get("type") == "revolute"]
    return (np.array([float(j.find("limit").get("lower")) for j in joints]),
            np.array([float(j.find("limit").get("upper")) for j in joints]))


def flange(model, data, q: np.ndarray) -> pin.SE3:
    pin.framesForwardKinematics(model, data, q)
    return data.oMf[model.getFrameId("tool0")]


@pytest.fixture(scope="module")
def arm_plan(tmp_path_factory):
    out = tmp_path_factory.mktemp("armplan") / "plan"
    run = plan_to_dir(Machine.load("ur5"), out, PlanSettings(**SETTINGS))
    return out, run


def test_arm_plan_writes_programs_that_back_off_along_the_tool_axis(arm_plan):
    out, run = arm_plan
    for name in ("plan.script", "plan_joints.csv", "validation.script", "validation_joints.csv", "plan.csv"):
        assert (out / name).is_file(), name
    moves = read_urscript((out / "plan.script").read_text())
    listed = read_joint_list(out / "plan_joints.csv")
    assert [(k, p) for k, p, _ in moves] == [(k, p) for k, p, _, _ in listed]
    for (_, _, q), (_, _, _, qd) in zip(moves, listed):
        assert np.allclose(np.degrees(q), qd, atol=2e-6)
    model = pin.buildModelFromUrdf(str(UR5))
    data = model.createData()
    lo, hi = urdf_limits(UR5)
    pairs = 0
    for i, (kind, point, holder, qd) in enumerate(listed):
        q = np.radians(qd)
        assert np.all(q >= lo - 1e-9) and np.all(q <= hi + 1e-9), (i, kind, point)
        if kind != "measure":
            continue
        m = flange(model, data, q)
        tip = m.translation + m.rotation @ np.array([0, 0, holder / 1000])
        for k in (i - 1, i + 1):   # its approach and retract pose
            kk, pp, hh, qa = listed[k]
            assert pp == point and kk == ("approach" if k < i else "retract")
            a = flange(model, data, np.radians(qa))
            tip_a = a.translation + a.rotation @ np.array([0, 0, holder / 1000])
            assert np.allclose(a.rotation, m.rotation, atol=1e-6)
            assert np.allclose(tip - tip_a, CLEARANCE_MM / 1000 * m.rotation[:, 2], atol=1e-6)
            pairs += 1
    assert pairs == 2 * len(run.plan.template)
    with open(out / "plan.csv", newline="") as f:
        rows = list(csv.reader(f))
    joints = [a.name for a in run.plan.machine.axes]
    q_plan = np.array([[float(r[rows[0].index(j)]) for j in joints] for r in rows[1:]])
    q_meas = np.array([qd for kind, _, _, qd in listed if kind == "measure"])
    assert np.allclose(q_meas, q_plan, atol=1e-6)


def test_every_visited_pose_is_free(arm_plan):
    out, run = arm_plan
    p = run.plan
    sl = SightLine(p.machine, p.tracker, geometry=p.settings.geometry)
    for name in ("plan_joints.csv", "validation_joints.csv"):
        listed = read_joint_list(out / name)
        q = np.radians(np.array([qd for *_, qd in listed]))
        holders = np.array([h for _, _, h, _ in listed]) / 1000
        assert np.all(sl.collisions(q, holders) == ""), name
    assert run.plan.counts()["approach"] > 0  # the screen removed some
    assert any("arm programs" in line for line in run.lines())


def test_cnc_dialect_refused_for_an_arm(tmp_path):
    with pytest.raises(InputError, match="urscript or joint-list"):
        plan_to_dir(Machine.load("ur5"), tmp_path / "p", PlanSettings(**SETTINGS), dialects=("fanuc",))
    with pytest.raises(InputError, match="`approach` above: an arm approaches"):
        plan_to_dir(Machine.load("ur5"), tmp_path / "q", PlanSettings(**SETTINGS | {"approach": "above"}))
