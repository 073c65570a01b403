"""Axis bases beyond Chebyshev and Fourier (issue 11): periodic plus trend, B-splines,
Gaussian bumps; derivatives, closed forms, models built on them, model files."""
import math

import numpy as np
import pytest
from numpy.polynomial import chebyshev as npcheb

from vecpin.errors import InputError
from vecpin.measurement.noise import NoiseModel
from vecpin.models import ErrorModel, make_model
from vecpin.models.basis import AxisBasis
from vecpin.simulation.simulate import Design, simulate
from vecpin.simulation.truth import uniform_commands

NEW_BASES = [
    AxisBasis(-12.0, 12.0, 6, "fourier_trend", rotary=True, trend=3),
    AxisBasis(-4.7, 4.7, 4, "fourier_trend", (0.4,), True, trend=2),
    AxisBasis(-0.5, 2.0, 3, "bspline", knots=(-0.2, 0.3, 0.35, 1.1, 1.7)),
    AxisBasis(-6.0, 6.0, 2, "bspline", (1.0, 2.0), True, knots=(-3.0, 0.5, 4.0)),
    AxisBasis(0.0, 3.0, 2, bumps=((0.7, 0.2), (2.1, 0.15))),
    AxisBasis(-4.7, 4.7, 6, "fourier", rotary=True, bumps=((1.0, 0.5),)),
]


@pytest.mark.parametrize("basis", NEW_BASES)
def test_new_basis_derivative_and_constant_column(basis):
    q = np.linspace(basis.lower - 0.1, basis.upper + 0.1, 201)  # also a little outside the travel
    h = 1e-6
    fd = (basis.values(q + h) - basis.values(q - h)) / (2 * h)
    np.testing.assert_allclose(basis.derivative(q), fd, atol=1e-6 * max(1, np.abs(fd).max()))
    np.testing.assert_allclose(basis.values(q)[:, 0], 1.0)
    assert basis.values(q).shape == (201, basis.size) == (201, len(basis.labels()))
    assert len(set(basis.labels())) == basis.size
    assert np.linalg.matrix_rank(basis.values(q)) == basis.size  # no column repeats another


def test_fourier_trend_is_fourier_plus_chebyshev_trend():
    B = AxisBasis(-10.0, 14.0, 4, "fourier_trend", rotary=True, trend=2)
    q = np.linspace(-10, 14, 50)
    u = (2 * q - 4.0) / 24.0
    expected = np.c_[np.ones_like(q), np.cos(q), np.sin(q), np.cos(2 * q), np.sin(2 * q), u, 2 * u**2 - 1]
    np.testing.assert_allclose(B.values(q), expected, atol=1e-14)
    assert B.labels() == ["0", "1", "2", "3", "4", "t1", "t2"]


def test_uniform_cubic_bspline_closed_form():
    """Cubic B-splines on unit-spaced knots are 1/6, 2/3, 1/6 at the knots (de Boor,
    A Practical Guide to Splines, ch. IX); the constant plus the others span all cubics."""
    B = AxisBasis(0.0, 8.0, 3, "bspline", knots=tuple(range(1, 8)))
    vals = B.values(np.array([4.0]))[0]
    interior = vals[1:][vals[1:] > 1e-12]
    np.testing.assert_allclose(interior, [1 / 6, 2 / 3, 1 / 6], atol=1e-14)
    q = np.linspace(0, 8, 97)
    cubic = npcheb.chebval((q - 4) / 4, [0.3, -1.0, 0.5, 2.0])
    resid = cubic - B.values(q) @ np.linalg.lstsq(B.values(q), cubic, rcond=None)[0]
    assert np.abs(resid).max() < 1e-12


def test_gaussian_bump_column():
    B = AxisBasis(0.0, 3.0, 1, bumps=((1.2, 0.3),))
    q = np.array([1.2, 1.5, 0.6])
    np.testing.assert_allclose(B.values(q)[:, 2], np.exp(-0.5 * ((q - 1.2) / 0.3) ** 2), atol=1e-15)
    assert B.labels() == ["0", "1", "g1"]


@pytest.mark.parametrize("bad, match", [
    (dict(kind="spline"), "unknown kind"),
    (dict(kind="bspline", knots=(0.5, 0.4)), "knots must increase"),
    (dict(kind="bspline", knots=(2.5,)), "knots must increase"),
    (dict(knots=(0.5,)), "spline kinds only"),
    (dict(trend=2), "'fourier_trend' kind only"),
    (dict(bumps=((1.0, 0.0),)), "widths must be > 0"),
])
def test_invalid_bases_are_refused(bad, match):
    with pytest.raises(InputError, match=match):
        AxisBasis(0.0, 2.0, 3, **bad)


def _fd_jacobians(model, q, tool, b, h=1e-7):
    out = model.tool_tip(q, tool, b)
    for k in range(model.n_parameters):
        e = np.zeros_like(b)
        e[k] = h
        fd = (model.tool_tip(q, tool, b + e, False).tip - model.tool_tip(q, tool, b - e, False).tip) / (2 * h)
        np.testing.assert_allclose(out.J_b[:, :, k], fd, atol=3e-8, err_msg=model.parameter_names[k])
    for k in range(q.shape[1]):
        dq = np.zeros(q.shape[1])
        dq[k] = h
        fd = (model.tool_tip(q + dq, tool, b, False).tip - model.tool_tip(q - dq, tool, b, False).tip) / (2 * h)
        np.testing.assert_allclose(out.J_q[:, :, k], fd, atol=3e-8)


def _mixed_bases(m):
    out = []
    for a in m.axes:
        if a.name == "C":
            out.append(AxisBasis(a.lower, a.upper, 2, "fourier_trend", rotary=True, trend=2))
        elif a.name == "X":
            inner = tuple(a.lower + a.travel * np.array([0.3, 0.6]))
            out.append(AxisBasis(a.lower, a.upper, 3, "bspline", knots=inner))
        elif a.name == "B":
            out.append(AxisBasis(a.lower, a.upper, 1, rotary=True, bumps=((0.2, 0.3),)))
        else:
            out.append(AxisBasis(a.lower, a.upper, 2))
    return out


@pytest.mark.parametrize("kind", ["6dof", "ap"])
def test_models_on_new_bases_have_exact_jacobians(flow, rng, kind):
    model = make_model(kind, flow, 2, bases=_mixed_bases(flow))
    q = uniform_commands(flow, 4, rng)
    _fd_jacobians(model, q, np.array([0.21, 0.31, 0.21, 0.31]), rng.normal(size=model.n_parameters) * 1e-4)


def test_model_file_round_trip_with_new_bases(flow, tmp_path):
    sim = simulate(flow, seed=5, design=Design(n_commands=80, n_validation=5))
    model = make_model("6dof", flow, 2, bases=_mixed_bases(flow)).fit(sim.campaign, NoiseModel.default(flow, "spherical"))
    path = tmp_path / "m.json"
    model.save(path)
    back = ErrorModel.load(path)
    for B1, B2 in zip(back.bases, model.bases):
        assert (B1.kind, B1.order, B1.trend, B1.size, B1.rotary) == (B2.kind, B2.order, B2.trend, B2.size, B2.rotary)
        np.testing.assert_allclose(B1.knots, B2.knots, rtol=1e-12)
        np.testing.assert_allclose(np.ravel(B1.bumps), np.ravel(B2.bumps), rtol=1e-12)
    q = uniform_commands(flow, 20, np.random.default_rng(1))
    np.testing.assert_allclose(back.predict_tip(q, 0.25), model.predict_tip(q, 0.25), atol=1e-9)
    text = path.read_text()
    assert '"kind": "bspline"' in text and '"trend": 2' in text and '"bumps"' in text
    assert math.isclose(back.bases[4].bumps[0][0], 0.2, rel_tol=1e-12)
