"""Issue 39: the table's face read as a commissioning engineer reads it, a dial test indicator swept across it.

The file (table_face.csv) round trips through the plan's template and refuses bad rows naming file, row and
column; the tilt a sweep gives on a tilted plane against its closed form (the face's height along each line of
motion, written here); the sweep weighed with the nests' face and the prior: read exactly it gives the sweep's
tilt, read with an unbounded standard deviation it gives the nests' face as before; through the model's lines
(a machine whose X and Y lines are tilted against the frame kept) the kept frame puts the face square to up.
"""
from __future__ import annotations

import numpy as np
import pytest

from vecpin.compensation.faceframe import face_axes, face_tilt
from vecpin.compensation.frame import ReferenceFrame, on_the_table_face, sweep_lines
from vecpin.errors import CampaignFileError, InputError, VecpinError
from vecpin.kinematics.so3 import exp3
from vecpin.measurement.setup import Setup
from vecpin.measurement.tableface import (SWEEP_SD_UM, check_table_face, read_table_face, swept_axes,
                                          table_face_csv)

UP = np.array([0.0, 0.0, 1.0])


def test_the_file_round_trips_and_bad_rows_name_file_row_and_column(machines, tmp_path):
    """The plan's template (X and Y, the default sd) filled in reads back; an axis not swept is skipped;
    an unknown axis, Z (along the spindle), a rotary axis, a repeated axis, a distance in metres, a missing
    change, a change no table has, a bad sd and a wrong header are each refused naming row and column; the
    fit's setting refuses alike naming the option."""
    m = machines["trunnion_xyzac"]
    assert list(swept_axes(m)) == ["X", "Y"] and swept_axes(machines["ur5"]) == {}
    rows = table_face_csv(swept_axes(m)).splitlines()
    assert rows == ["axis,distance_mm,change_um,sd_um", f"X,,,{SWEEP_SD_UM:g}", f"Y,,,{SWEEP_SD_UM:g}"]
    (tmp_path / "t.csv").write_text("\n".join([rows[0], "X,300,-4.5,1.5", "Y,,,2"]) + "\n")
    assert read_table_face(tmp_path / "t.csv", m) == {"X": (300.0, -4.5, 1.5)}
    (tmp_path / "t.csv").write_text("axis,distance_mm,change_um\nX,250,3\nY,200,-1\n")
    assert read_table_face(tmp_path / "t.csv", m) == {"X": (250.0, 3.0, SWEEP_SD_UM), "Y": (200.0, -1.0, SWEEP_SD_UM)}
    bad = {"W,300,2,2": ("axis", "has no axis 'W'"), "Z,100,2,2": ("axis", "along the spindle"),
           "A,30,2,2": ("axis", "a rotary axis"), "X,0.3,2,2": ("distance_mm", "metres"),
           "X,300,,2": ("change_um", "no change_um"), "X,300,4000,2": ("change_um", "µm"),
           "X,300,2,-1": ("sd_um", "standard deviation"), "X,9000,2,2": ("distance_mm", "travel"),
           "X,abc,2,2": ("distance_mm", "not a distance")}
    for row, (col, says) in bad.items():
        (tmp_path / "b.csv").write_text(f"{rows[0]}\nY,200,1,2\n{row}\n")
        with pytest.raises(CampaignFileError, match=rf"b.csv, row 3, column '{col}': .*{says}"):
            read_table_face(tmp_path / "b.csv", m)
    (tmp_path / "b.csv").write_text(f"{rows[0]}\nX,200,1,2\nX,100,1,2\n")
    with pytest.raises(CampaignFileError, match=r"row 3, column 'axis': axis X is given twice"):
        read_table_face(tmp_path / "b.csv", m)
    for text, says in (("nest,height_mm\n1,20\n", "header"), (f"{rows[0]}\nX,,,2\n", "no axis swept"),
                       ("axis,distance_mm,change_um,change_um\nX,200,1,2\n", "header names change_um twice")):
        (tmp_path / "b.csv").write_text(text)
        with pytest.raises(CampaignFileError, match=says):
            read_table_face(tmp_path / "b.csv", m)
    assert check_table_face({"X": (300, -4.5)}, m)["X"] == pytest.approx((0.3, -4.5e-6, SWEEP_SD_UM * 1e-6))
    with pytest.raises(InputError, match=r"`table_face` Z: Z is a linear axis along the spindle"):
        check_table_face({"Z": (100, 2)}, m)
    with pytest.raises(InputError, match=r"`table_face` X: give \(distance mm, change µm\)"):
        check_table_face({"X": 300}, m)


def _reading(v, grad, D):
    """The indicator's change [m], + pushed in, over a move D v of the tip above the face z = grad . p:
    the tip's height above the face closes by D (grad . v - up . v)."""
    return D * (grad @ v - UP @ v)


def test_a_sweep_gives_the_tilt_of_a_tilted_plane():
    """A face z = gx x + gy y read along lines of motion that are themselves tilted and not square to each
    other: the face's slopes from two exact sweeps are the plane's (normal up - (gx, gy, 0)), in the face's
    axes; one sweep alone does not fix the face (None); its 1 sigma is the readings' sd over the distance."""
    grad = np.array([150e-6, -90e-6, 0.0])
    lines = {"X": np.array([1.0, 0.002, 40e-6]), "Y": np.array([0.01, 1.0, -25e-6])}
    D = 0.3
    sweep = {a: (v, D, _reading(v, grad, D), 0.0) for a, v in lines.items()}
    face = face_tilt(np.zeros((0, 3)), UP, [], [], prior=1.0, sweep=sweep)
    e1, e2 = face_axes(UP)
    normal = UP - grad
    assert face.slopes == pytest.approx([normal @ e1, normal @ e2], abs=1e-12)
    assert face.n == 0 and face.swept == ("X", "Y") and "swept along X and Y" in face.sources
    assert face_tilt(np.zeros((0, 3)), UP, [], [], sweep={"X": sweep["X"]}) is None
    sd = 2e-6
    noisy = face_tilt(np.zeros((0, 3)), UP, [], [], prior=1.0,
                      sweep={a: (np.eye(3)[i], D, 0.0, sd) for i, a in enumerate("XY")})
    np.testing.assert_allclose(noisy.cov, np.eye(2) * (sd / D) ** 2, rtol=1e-6)


def test_the_sweep_is_weighed_with_the_nests_and_the_prior():
    """Nests read with a gauge (their face 100 µrad off the true one) and sweeps of the true face: a sweep
    read exactly gives the sweep's tilt; a sweep read with an sd of 1 m gives today's face from the nests
    alone (slopes, covariance and the face kept); between, the face kept lies between, with a smaller sd
    than either; a sweep that contradicts the nests beyond chance is said so."""
    rng = np.random.default_rng(11)
    a = np.sort(rng.uniform(0, 2 * np.pi, 5))
    P = np.column_stack([0.15 * np.cos(a), 0.15 * np.sin(a), rng.uniform(0.02, 0.05, 5)])
    grad = np.array([60e-6, 40e-6, 0.0])
    off = np.array([100e-6, 0.0, 0.0])         # the nests' heights read as if the face were tilted 100 µrad more
    heights = P[:, 2] - P @ (grad + off)
    sds = [0.02e-3] * 5

    def sweep(sd):
        return {ax: (np.eye(3)[i], 0.3, _reading(np.eye(3)[i], grad, 0.3), sd) for i, ax in enumerate("XY")}
    nests = face_tilt(P, UP, heights, sds)
    e1, e2 = face_axes(UP)
    truth = [(UP - grad) @ e1, (UP - grad) @ e2]
    exact = face_tilt(P, UP, heights, sds, sweep=sweep(0.0))
    assert exact.slopes == pytest.approx(truth, abs=1e-8) and exact.kept == pytest.approx(truth, abs=1e-8)
    assert exact.decides and "the heights of 5 nests and an indicator swept along X and Y" in exact.known()
    vague = face_tilt(P, UP, heights, sds, sweep=sweep(1.0))
    np.testing.assert_allclose(vague.slopes, nests.slopes, atol=1e-9)
    np.testing.assert_allclose(vague.cov, nests.cov, rtol=1e-4)
    np.testing.assert_allclose(vague.kept, nests.kept, atol=1e-9)
    read = face_tilt(P, UP, heights, sds, sweep=sweep(2e-6))
    assert read.sd < min(nests.sd, np.sqrt(2) * 2e-6 / 0.3 * 1.01) and np.linalg.norm(read.kept - truth) < 20e-6
    assert read.agree and not face_tilt(P, UP, heights, [2e-6] * 5, sweep=sweep(2e-6)).agree


class _Machine:
    """What sweep_lines and on_the_table_face ask of a machine: X, Y, Z and a rotary C, a vertical spindle."""

    class _Axis:
        def __init__(self, name, kind):
            self.name, self.kind = name, kind

    axes = [_Axis("X", "linear"), _Axis("Y", "linear"), _Axis("Z", "linear"), _Axis("C", "rotary")]
    axis_names = ["X", "Y", "Z", "C"]
    n_axes = 4
    lower, upper = np.array([-0.3, -0.2, -0.3, -np.pi]), np.array([0.3, 0.2, 0.0, np.pi])

    def kinematics(self, q, tool, jacobian=False, frame="workpiece"):
        from types import SimpleNamespace
        return SimpleNamespace(tool_dir=np.array([[0.0, 0.0, -1.0]]))


def test_the_kept_frame_puts_the_swept_face_square_to_up_through_the_models_lines():
    """A model whose tips are the nominal ones turned 200 µrad about x and -120 µrad about y over a true face
    z = 0, its frame without heights the one that undoes the turn (its X and Y lines nominal there, the face
    tilted 233 µrad in it); exact sweeps read on the true face: the frame kept makes the face level again (its
    normal taken to up within 1e-9 rad), with no nest heights at all; a sweep along X alone is refused."""
    R = exp3(np.array([200e-6, -120e-6, 0.0]))

    def actual(q, tool, jacobian=False, point=0):
        nominal = np.column_stack([q[:, 0], q[:, 1], q[:, 2] - tool])
        return nominal @ R.T, None
    m = _Machine()
    frame = ReferenceFrame(R.T, np.zeros(3), "test frame")
    readings = {ax: (0.3, -0.3 * (R[:, i] @ UP), 0.0) for i, ax in enumerate("XY")}   # the gap closes by -D v.z
    lines = sweep_lines(actual, m, frame, readings, (m.lower, m.upper), 0.2)
    np.testing.assert_allclose(lines["X"][0], [1.0, 0.0, 0.0], atol=1e-12)   # nominal in the frame without heights
    assert lines["X"][1] == 0.0   # no fitted model: no covariance of the line
    setup = Setup(np.eye(3), np.zeros(3), face_sweep=readings)
    kept = on_the_table_face(frame, m, setup, prior=1.0, lines=lines)
    assert kept.kind == "face" and kept.face.swept == ("X", "Y") and "indicator swept along X and Y" in kept.how
    assert np.linalg.norm(frame.R @ UP - UP) > 200e-6
    np.testing.assert_allclose(kept.R @ UP, UP, atol=1e-9)
    with pytest.raises(VecpinError, match="sweeps along two axes that cross"):
        on_the_table_face(frame, m, Setup(np.eye(3), np.zeros(3), face_sweep={"X": readings["X"]}), lines=lines)
    upper = np.array(m.upper, float)
    upper[0] = m.lower[0]   # a box that never moved X: no line to read the sweep against
    with pytest.raises(VecpinError, match="the sweep along X: the measured box spans 0 mm of X"):
        sweep_lines(actual, m, frame, readings, (np.array(m.lower, float), upper), 0.2)


def test_the_model_file_keeps_the_sweeps_and_refuses_bad_ones(machines, tmp_path):
    """The model file's tracker section carries the sweeps in mm and µm and reads them back in metres; a
    sweep along Z read from a file is refused naming the file and the field."""
    from vecpin.errors import ModelFileError
    from vecpin.models.modelfile import _points_to_dict, _table_face_from
    m = machines["trunnion_xyzac"]
    setup = Setup(np.eye(3), np.zeros(3), face_sweep=check_table_face({"X": (300, -4.5, 1.5), "Y": (250, 2)}, m))
    tr = _points_to_dict(setup)
    assert tr["table_face"]["X"] == pytest.approx({"distance_mm": 300.0, "change_um": -4.5, "sd_um": 1.5})
    back = Setup(np.eye(3), np.zeros(3))
    _table_face_from(tmp_path / "m.json", tr, back, m)
    for axis in "XY":
        assert back.face_sweep[axis] == pytest.approx(setup.face_sweep[axis])
    tr["table_face"]["Z"] = {"distance_mm": 100.0, "change_um": 1.0, "sd_um": 2.0}
    with pytest.raises(ModelFileError, match=r"m.json.*tracker.table_face.*along the spindle"):
        _table_face_from(tmp_path / "m.json", tr, Setup(np.eye(3), np.zeros(3)), m)


def test_the_printed_sigma_is_the_rms_length_of_the_tilts_error_monte_carlo():
    """Two sweeps along lines not square to each other, each read with an sd and converted through a line
    whose slope along up is itself uncertain (the model's, a variance added to the reading's): over 800
    draws of the true face from the prior, the readings' noise and the lines' errors (drawn here, the readings
    written here), the RMS length of the error of the readings' face is its printed sd (sqrt of the
    covariance's trace), and that of the face kept its kept_sd, within the draws' sampling (8 %)."""
    from vecpin.compensation.faceframe import setup_face
    rng = np.random.default_rng(5)
    lines = {"X": np.array([1.0, 0.002, 40e-6]), "Y": np.array([0.3, 1.0, -25e-6])}
    var = {"X": 9e-6 ** 2, "Y": 16e-6 ** 2}      # rad^2: each line's slope along up, as the model knows it
    D, sd, prior = 0.3, 2e-6, 30e-6
    e1, e2 = face_axes(UP)
    err, err_kept = [], []
    for _ in range(800):
        slopes = rng.normal(0.0, prior, 2)
        grad = -(slopes[0] * e1 + slopes[1] * e2)          # the face z = grad . p: normal up - grad
        sweep = {a: (D, _reading(v + rng.normal(0.0, np.sqrt(var[a])) * UP, grad, D) + rng.normal(0.0, sd), sd)
                 for a, v in lines.items()}
        face = setup_face(Setup(np.eye(3), np.zeros(3), face_sweep=sweep), UP, prior=prior,
                          lines={a: (v, var[a]) for a, v in lines.items()})[1]
        err.append(face.slopes - slopes)
        err_kept.append(face.kept - slopes)
    rms = np.sqrt(np.mean(np.sum(np.square(err), axis=1)))
    rms_kept = np.sqrt(np.mean(np.sum(np.square(err_kept), axis=1)))
    assert face.sd == pytest.approx(rms, rel=0.08) and face.kept_sd == pytest.approx(rms_kept, rel=0.08)
    assert face.sd > np.sqrt(np.linalg.eigvalsh(face.cov).max()) * 1.1     # more than the largest direction's


class _LinearModel:
    """A fitted model whose tips are the nominal ones plus B(q) b: b[0:3] a rotation of the whole volume
    about its centroid (no line tilts against a frame that is the volume's own), b[3] a slope of X's line
    along the spindle, b[4] a bow of Y along up; covariance s^2 I."""
    row_dependent = False

    def __init__(self, machine, b, s=10e-6):
        self.machine, self.b_ = machine, np.asarray(b, float)
        self.cov_ = np.eye(6 + 5) * s ** 2
        self.centre = np.array([0.0, 0.0, -0.1])

    def _check_fitted(self):
        return None

    def tool_tip(self, q, tool, b, jacobian=False, frame="workpiece", point=0):
        from types import SimpleNamespace
        tip = self.machine.tool_tip(q, tool, frame="workpiece")
        x, y = q[:, 0], q[:, 1]
        J = np.zeros((len(q), 3, 5))
        J[:, :, :3] = -np.cross((tip - self.centre)[:, :, None], np.eye(3)[None], axis=1)   # w -> w x r
        J[:, 2, 3], J[:, 2, 4] = x, y ** 2
        return SimpleNamespace(tip=tip + J @ b, J_b=J, J_q=None)


def test_a_lines_variance_holds_the_frames_turn_with_the_model(machines, monkeypatch):
    """The variance of a swept line's slope along up against the frame kept (the volume's mean orientation, on
    a turning table), as sweep_lines gives it for a model with covariance s^2 I, is s^2 |g|^2 with g the slope's
    change per parameter measured by finite differences through the whole nonlinear path (the model's tips
    moved, its reference frame found again by rigid registration, the line measured in it): a rotation of the
    whole volume tilts no line against the frame (g = 0 there, where the line alone would read it fully)."""
    from vecpin.compensation import frame as fr
    m = machines["trunnion_xyzac"]
    monkeypatch.setattr(fr, "misfit_variance", lambda model: 0.0)
    box = (m.lower, m.upper)
    sweep = {"X": (0.3,), "Y": (0.3,)}
    up = np.array([0.0, 0.0, 1.0])

    def slopes(b):
        model = _LinearModel(m, b)
        actual = fr._as_fitted(model)
        frame = fr.reference_frame(actual, m, fr.fit_tools(model), *box)
        return frame, fr.sweep_lines(actual, m, frame, sweep, box, 0.2, model), actual
    b0 = np.array([30e-6, -20e-6, 5e-6, 40e-6, 60e-6])
    frame, lines, actual = slopes(b0)
    eps = 1e-6
    g = {a: [] for a in sweep}
    for p in range(5):
        moved = slopes(b0 + eps * np.eye(5)[p])[1]
        for a in sweep:
            g[a].append((moved[a][0] - lines[a][0]) @ up / eps)
    for a in sweep:
        assert lines[a][1] == pytest.approx(10e-6 ** 2 * np.sum(np.square(g[a])), rel=2e-3)
        assert np.abs(g[a][:3]).max() < 1e-4     # per rad of the volume's turn: the line alone would read ~1
    held = fr.sweep_lines(actual, m, frame, sweep, box, 0.2, None)   # no model: no variance
    assert held["X"][1] == 0.0
