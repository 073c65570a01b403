"""The unseen-machine generator's own truths (issue 40): its forward kinematics against pinocchio
on the URDF it writes, its error fields smooth and of the requested size, its tracker noise as
stated, its campaign file as vecpin's format describes it. Imports pinocchio, not vecpin.
"""
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from generator import draw_campaign  # noqa: E402
from generator.fields import gp_1d, gp_2d  # noqa: E402
from generator.kinematics import table_points, tool_points  # noqa: E402
from generator.layouts import KINDS, draw_layout, to_urdf  # noqa: E402


def _pin_points(layout, qs: dict, frame: str, local: np.ndarray) -> np.ndarray:
    model = pin.buildModelFromXML(to_urdf(layout))
    data = model.createData()
    fid = model.getFrameId(frame)
    n = len(next(iter(qs.values())))
    out = np.empty((n, 3))
    for i in range(n):
        q = pin.neutral(model)
        for j in layout.axes:
            q[model.joints[model.getJointId(j.name)].idx_q] = qs[j.name][i]
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        m = data.oMf[fid]
        out[i] = m.rotation @ local[i] + m.translation
    return out


@pytest.mark.parametrize("kind", KINDS)
def test_error_free_kinematics_is_pinocchios_on_the_written_urdf(kind):
    rng = np.random.default_rng(7)
    layout = draw_layout(rng, kind)
    n = 12
    qs = {j.name: rng.uniform(j.lower, j.upper, n) for j in layout.axes}
    tool = rng.uniform(0.05, 0.3, n)
    mine = tool_points(layout, qs, tool)
    ref = _pin_points(layout, qs, layout.tool_link, np.asarray(layout.tool_axis)[None, :] * tool[:, None])
    assert np.abs(mine - ref).max() < 1e-9
    if layout.table_chain:
        local = rng.uniform(-0.2, 0.2, (n, 3))
        assert np.abs(table_points(layout, qs, local) - _pin_points(layout, qs, "workpiece", local)).max() < 1e-9


def test_error_fields_are_smooth_and_of_the_requested_size():
    """Over many draws the slope's RMS is the squared-exponential kernel's rms / length (smooth, with the
    requested length scale, not white noise) and the RMS is the requested one; a per-turn draw closes.
    Length scales of 0.1-0.25 of the span, so that one draw holds enough of them for its own statistics."""
    rng = np.random.default_rng(3)
    x = np.linspace(0.0, 2.0, 2001)
    ratios = []
    for _ in range(40):
        f = gp_1d(rng, 0.0, 2.0, 2e-5, rng.uniform(0.1, 0.25))
        assert np.sqrt(np.mean(f(x) ** 2)) == pytest.approx(2e-5, rel=0.05)
        ratios.append(np.sqrt(np.mean(f.derivative(x) ** 2)) / (f.rms / f.length))
    assert 0.8 < np.mean(ratios) < 1.3 and max(ratios) < 4.0   # white noise on this grid: about 15
    p = gp_1d(rng, -4 * np.pi, 4 * np.pi, 1e-5, 0.3, periodic=True)
    assert p(np.array([0.1])) == pytest.approx(p(np.array([0.1 + 2 * np.pi])), abs=1e-15)
    g = gp_2d(rng, (0.0, 1.0, -1.0, 1.0), 1e-5, (0.5, 0.5))
    a, b = np.meshgrid(np.linspace(0, 1, 200), np.linspace(-1, 1, 200), indexing="ij")
    v = g(a.ravel(), b.ravel()).reshape(a.shape)
    separable = np.mean(v.mean(axis=0) ** 2) + np.mean(v.mean(axis=1) ** 2)   # the part of a or b alone
    assert separable < 0.05 * np.mean(v ** 2)


def test_tracker_noise_is_the_stated_spherical_noise_and_the_file_is_vecpins_format(tmp_path):
    camp = draw_campaign(11, kind="head", family=None, n_commands=150)
    truth = camp.to_tracker(camp.base_points())
    r_true, r_meas = np.linalg.norm(truth, axis=1), np.linalg.norm(camp.measured, axis=1)
    sigma_r = camp.noise["range_m"] + 1e-6 * r_true
    assert np.std((r_meas - r_true) / sigma_r) == pytest.approx(1.0, abs=0.12)
    cross = np.linalg.norm(np.cross(camp.measured - truth, truth / r_true[:, None]), axis=1)
    # transverse: two angles of sigma_a each -> RMS sqrt(2) sigma_a r (elevation near 0)
    assert np.sqrt(np.mean((cross / (camp.noise["angle_rad"] * r_true)) ** 2)) == pytest.approx(np.sqrt(2), rel=0.15)
    path = camp.write(tmp_path)["csv"]
    head, *rows = path.read_text().splitlines()
    assert head.split(",") == [j.name for j in camp.layout.axes] + ["tool", "x", "y", "z", "time", "temperature"]
    cells = np.array([[float(c) for c in r.split(",")] for r in rows])
    for k, j in enumerate(camp.layout.axes):
        lo, hi = (j.lower * 1e3, j.upper * 1e3) if j.kind == "prismatic" else np.degrees([j.lower, j.upper])
        assert lo <= cells[:, k].min() and cells[:, k].max() <= hi
    assert np.all(np.diff(cells[:, -2]) > 0)


def test_a_backlash_is_sized_as_its_closed_form():
    """Lost motion b on a linear axis moves every tool row by b/2 along that axis (its small errors aside), so
    the effect's drawn RMS size is b/2 and the move flips with the approach direction of the rows' visits."""
    camp = draw_campaign(5, kind="head", family="backlash", n_commands=40)
    eff = camp.effect
    axis = np.asarray(camp.layout.joint(eff.axes[0]).axis)
    d = camp.base_points() - camp.base_points(with_effect=False)
    along = d @ axis
    assert eff.size_mm == pytest.approx(eff.amplitude / 2 * 1e3, rel=1e-3)
    sign = -camp.noise["direction"][camp.rows.visit]
    assert np.abs(along - sign * eff.amplitude / 2).max() < 0.01 * eff.amplitude
    assert {-1.0, 1.0} <= set(np.unique(sign))
