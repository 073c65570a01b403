"""Issue 39: the nests' heights are read with a gauge error, and the table's face they give has an uncertainty.

The face's tilt covariance against a closed form and a Monte Carlo of the plane fit written here (numpy's
lstsq, not vecpin's); heights read badly give the frame without heights, heights read exactly give the face
today's exact plane fit gives; the file's standard-deviation column and the option's ``ID=MM:SD`` round trip.
"""
from __future__ import annotations

import numpy as np
import pytest

from vecpin.compensation.faceframe import FACE_TARGET, TABLE_FACE_PRIOR, face_tilt
from vecpin.compensation.frame import ReferenceFrame, on_the_table_face, read_face
from vecpin.errors import CampaignFileError, InputError
from vecpin.kinematics.so3 import log3
from vecpin.measurement.setup import Setup
from vecpin.measurement.nestheights import GAUGE_SD_MM, check_nest_heights, nest_heights_csv, read_nest_heights

UP = np.array([0.0, 0.0, 1.0])


class _Machine:
    """What on_the_table_face asks of a machine: its spindle's direction at home (-z: a vertical spindle)."""
    n_axes = 0
    lower = upper = np.zeros(0)

    def kinematics(self, q, tool, jacobian=False, frame="workpiece"):
        from types import SimpleNamespace
        return SimpleNamespace(tool_dir=np.array([[0.0, 0.0, -1.0]]))


def _nests(n=5, radius=0.18, seed=0):
    rng = np.random.default_rng(seed)
    a = np.sort(rng.uniform(0, 2 * np.pi, n))
    return np.column_stack([radius * np.cos(a) + 0.03, radius * np.sin(a) - 0.02, rng.uniform(0.02, 0.08, n)])


def test_the_tilt_covariance_is_the_plane_fits():
    """Nests evenly on a circle, one standard deviation: the slopes' covariance is sd^2 / (n r^2 / 2) per
    component (the closed form); uneven nests with uneven reading and fitted-position sds, and a shift common
    to every fitted nest (which tilts nothing): the covariance of a Monte Carlo of the plane fit, weighted by
    the readings' and the nests' own variances (numpy's lstsq on the readings drawn), within its sampling."""
    n, r, sd = 4, 0.15, 0.02e-3
    a = 2 * np.pi * np.arange(n) / n + 0.4
    P = np.column_stack([r * np.cos(a), r * np.sin(a), np.full(n, 0.03)])
    face = face_tilt(P, UP, P[:, 2], [sd] * n)
    np.testing.assert_allclose(face.cov, np.eye(2) * sd ** 2 / (n * r * r / 2), rtol=1e-9, atol=1e-20)
    np.testing.assert_allclose(face.tilt_cov, face.cov, rtol=1e-9, atol=1e-20)   # isotropic: the same
    P = _nests(5)
    reading = np.array([0.01, 0.03, 0.02, 0.005, 0.02]) * 1e-3
    fitted = np.array([0.004, 0.002, 0.0, 0.006, 0.003]) * 1e-3
    common = 0.06e-3 ** 2 * np.ones((5, 5))     # a shift of every fitted nest (the fit's gauge): no tilt
    face = face_tilt(P, UP, P[:, 2] - 0.001, reading, np.diag(fitted ** 2) + common)
    sd = np.hypot(reading, fitted)
    weight_sd = np.sqrt(sd ** 2 + 0.06e-3 ** 2)   # each nest weighted by its whole variance, as a metrologist would
    rng = np.random.default_rng(7)
    draws = 4000
    # the face's height at each nest, P_z - h, read with noise: z = c - a x1 - b x2, (x1, x2) = (y, -x)
    A = np.column_stack([-P[:, 1], P[:, 0], np.ones(5)]) / weight_sd[:, None]
    noise = rng.normal(size=(draws, 5)) * sd + rng.normal(size=(draws, 1)) * 0.06e-3
    slopes = np.linalg.lstsq(A, ((0.001 + noise) / weight_sd).T, rcond=None)[0][:2].T
    mc = np.cov(slopes.T)
    # sampling error of a covariance from 4000 draws: a few % of its scale
    np.testing.assert_allclose(face.cov, mc, atol=0.06 * np.abs(mc).max())
    assert face.slopes == pytest.approx([0.0, 0.0], abs=1e-12)


def test_heights_read_badly_give_the_frame_without_heights_and_exact_ones_todays_face():
    """A face tilted 120 µrad against the frame without heights: read with 5 mm standard deviations the
    frame kept is that frame (within 0.1 µrad); read exactly (sd 0) it is the face today's exact least-squares
    plane gives (within 1e-9 rad); with the default gauge between them, and its 1 sigma printed. Read badly,
    the tables keep the frame as they keep the frame without heights (its turn held); read exactly, as a read
    face (product terms offered)."""
    P = _nests(6, 0.2, seed=3)
    tilt = np.array([80e-6, -90e-6])               # slopes a, b: the face's normal up + a e1 + b e2
    frame = ReferenceFrame(np.eye(3), np.zeros(3), "test frame")
    nests = {str(k): p for k, p in enumerate(P)}
    heights = {str(k): P[k, 2] - _slope_height(P[k], tilt) for k in range(len(P))}

    def kept(sd):
        return on_the_table_face(frame, _Machine(), Setup(np.eye(3), np.zeros(3), nests=nests, nest_heights=heights,
                                                          nest_height_sd={k: sd for k in nests}))

    bad = kept(5e-3)
    assert np.linalg.norm(log3(bad.R)) < 1e-7 and bad.face.weight < 1e-3
    assert bad.hold_turn and not read_face(bad)   # kept as the frame without heights is: its turn held
    exact = kept(0.0)
    ref = _todays_face(P, heights)
    assert np.linalg.norm(log3(exact.R @ ref.T)) < 1e-9
    assert np.linalg.norm(log3(exact.R)) == pytest.approx(np.hypot(*tilt), rel=1e-3)
    assert read_face(exact) and not exact.hold_turn   # a read face: as before the heights had a deviation
    gauge = kept(GAUGE_SD_MM * 1e-3)
    assert 0 < np.linalg.norm(log3(gauge.R)) < np.linalg.norm(log3(exact.R))
    assert "known to ±" in gauge.face.known() and gauge.face.kept_sd < np.sqrt(2) * TABLE_FACE_PRIOR   # the prior's


def test_a_face_beyond_the_prior_is_kept_as_read_and_poor_layouts_get_advice():
    """A face tilted 600 µrad, read well: the heights contradict the prior (a table outside the acceptance
    tolerance): the face is kept as read and the printout says so. Nests near the axis read with a gauge: the
    uncertainty is above the target and the advice names a radius that meets it (the closed form's)."""
    P = _nests(4, 0.2, seed=5)
    tilt = np.array([400e-6, 450e-6])
    h = np.array([_slope_height(p, tilt) for p in P])
    face = face_tilt(P, UP, P[:, 2] - h, [2e-6] * 4)
    assert not face.consistent and face.kept == pytest.approx(face.slopes) and "check the heights" in face.how
    n, r, sd = 3, 0.06, 0.02e-3
    a = 2 * np.pi * np.arange(n) / n
    near = face_tilt(np.column_stack([r * np.cos(a), r * np.sin(a), np.full(n, 0.03)]), UP, [0.03] * 3, [sd] * 3)
    assert near.sd > FACE_TARGET and near.needs_advice and "farther from the table's axis" in near.advice()
    radius_mm = sd * np.sqrt(4 / n) / FACE_TARGET * 1e3   # the tilt error's RMS length: trace 4 sd^2 / (n r^2)
    assert f"evenly at {radius_mm:.0f} mm" in near.advice()


def _slope_height(p, slopes):
    """The face's height at nest p for slopes (a, b) along the frame's (e1, e2) = (up x x, up x e1) = (y, -x)
    axes: z = -a x1 - b x2 at x1 = p.y, x2 = -p.x (through the origin)."""
    return -(slopes[0] * p[1] - slopes[1] * p[0])


def _todays_face(P, heights):
    """The rotation the exact face gives, as the fit took it before the heights had a standard deviation:
    an unweighted least-squares plane, written here."""
    ids = sorted(heights)
    e1 = np.cross(UP, [1.0, 0, 0])
    e2 = np.cross(UP, e1)
    Q = P[[int(k) for k in ids]]
    A = np.column_stack([Q @ e1, Q @ e2, -np.ones(len(Q))])
    a, b, _ = np.linalg.lstsq(A, np.array([heights[k] for k in ids]) - Q @ UP, rcond=None)[0]
    n = UP + a * e1 + b * e2
    axis = np.cross(n / np.linalg.norm(n), UP)
    s = np.linalg.norm(axis)
    from scipy.spatial.transform import Rotation
    return Rotation.from_rotvec(axis * np.arcsin(s) / s).as_matrix()


def test_the_files_sd_column_round_trips_and_older_files_still_read(tmp_path):
    """The plan writes height_sd_mm with the gauge's default beside each empty height; filled, it reads back;
    a file without the column (written before it) reads with the default; a bad sd names its row and column;
    the options take (height, sd) and refuse a bad sd naming the option."""
    nests = {"1": np.array([0.1, 0, 0.02]), "2": np.array([0, 0.1, 0.03]), "3": np.array([-0.1, 0, 0.04])}
    rows = nest_heights_csv(nests).splitlines()
    assert rows[0] == "nest,planned_mm,height_mm,height_sd_mm" and rows[1] == f"1,20.00,,{GAUGE_SD_MM:g}"
    filled = [rows[0]] + [r.replace(",,", f",{20.5 + i},") for i, r in enumerate(rows[1:])]
    filled[2] = filled[2].rsplit(",", 1)[0] + ",0.005"
    (tmp_path / "h.csv").write_text("\n".join(filled) + "\n")
    assert read_nest_heights(tmp_path / "h.csv") == {"1": (20.5, GAUGE_SD_MM), "2": (21.5, 0.005),
                                                     "3": (22.5, GAUGE_SD_MM)}
    (tmp_path / "old.csv").write_text("nest,planned_mm,height_mm\n1,,20\n2,,21\n3,,22\n")
    assert read_nest_heights(tmp_path / "old.csv")["2"] == (21.0, GAUGE_SD_MM)
    for sd, why in (("-1", r"-1 mm: the standard deviation of nest 2's height reading is 0 \.\. 5 mm"),
                    ("x", "'x' is not a standard deviation in mm"), ("0.00001", r"0.00001: .* metres\?")):
        (tmp_path / "bad.csv").write_text(f"nest,height_mm,height_sd_mm\n1,20,\n2,21,{sd}\n3,22,0\n")
        with pytest.raises(CampaignFileError, match=f"bad.csv, row 3, column 'height_sd_mm': {why}"):
            read_nest_heights(tmp_path / "bad.csv")
    exact = nest_heights_csv(nests, measured=True).splitlines()
    assert exact[1] == "1,20.00,20.0000,0"
    assert check_nest_heights({"1": (20, 0.01), "2": 21, "3": 22}, nests) == pytest.approx(
        {"1": 0.02, "2": 0.021, "3": 0.022})
    with pytest.raises(InputError, match=r"`nest_heights` 1: 9 mm: the standard deviation of nest 1's"):
        check_nest_heights({"1": (20, 9), "2": 21, "3": 22}, nests)
    with pytest.raises(InputError, match=r"`nest_heights` 1: '0.03m' is not a height in mm"):
        check_nest_heights({"1": "0.03m", "2": 21, "3": 22}, nests)
