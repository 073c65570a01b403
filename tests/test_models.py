"""Error models: analytic Jacobians against finite differences, bases, structure."""
import numpy as np
import pytest

from vecpin.models.basis import AxisBasis
from vecpin.models import APModel, SixDofModel, make_model
from vecpin.simulation.truth import uniform_commands

TOOLS = [0.21488, 0.31286]


def _fd_check(model, q, tool, b, h=1e-7, atol=3e-8):
    out = model.tool_tip(q, tool, b)
    for k in range(model.n_parameters):
        e = np.zeros_like(b)
        e[k] = h
        fd = (model.tool_tip(q, tool, b + e, False).tip - model.tool_tip(q, tool, b - e, False).tip) / (2 * h)
        np.testing.assert_allclose(out.J_b[:, :, k], fd, atol=atol, err_msg=model.parameter_names[k])
    for k in range(q.shape[1]):
        dq = np.zeros(q.shape[1])
        dq[k] = h
        fd = (model.tool_tip(q + dq, tool, b, False).tip - model.tool_tip(q - dq, tool, b, False).tip) / (2 * h)
        np.testing.assert_allclose(out.J_q[:, :, k], fd, atol=atol)


def _custom_bases(machine):
    return [AxisBasis(a.lower, a.upper, 2 + k % 2, harmonics=(0.7,) if k % 2 else (), rotary=a.kind == "rotary")
            for k, a in enumerate(machine.axes)]


@pytest.mark.parametrize("kind", ["6dof", "ap"])
@pytest.mark.parametrize("variant", ["chebyshev", "fourier", "custom"])
def test_parameter_and_axis_jacobians_match_finite_differences(flow, rng, kind, variant):
    kw = {"bases": _custom_bases(flow)} if variant == "custom" else {"basis": variant}
    model = make_model(kind, flow, 3, tool_lengths=TOOLS, **kw)
    q = uniform_commands(flow, 6, rng)
    tool = np.array(TOOLS)[rng.integers(0, 2, 6)]
    _fd_check(model, q, tool, rng.normal(size=model.n_parameters) * 1e-4)


@pytest.mark.parametrize("name", ["cincinnati_20v", "ingersoll_xyzca"])
def test_jacobians_on_other_machines(machines, rng, name):
    m = machines[name]
    for kind in ("6dof", "ap"):
        model = make_model(kind, m, 2)
        q = uniform_commands(m, 4, rng)
        _fd_check(model, q, np.full(4, 0.2), rng.normal(size=model.n_parameters) * 1e-4)


@pytest.mark.parametrize("basis", [AxisBasis(-0.5, 2.0, 7), AxisBasis(-4.7, 4.7, 6, "fourier", rotary=True),
                                   AxisBasis(0.0, 3.0, 3, harmonics=(0.6, 1.3)), AxisBasis(-2, 2, 2, harmonics=(1, 2), rotary=True)])
def test_basis_derivative_and_constant_column(basis):
    q = np.linspace(basis.lower, basis.upper, 43)[1:-1]   # the ends are kinks: held beyond (next test)
    h = 1e-6
    fd = (basis.values(q + h) - basis.values(q - h)) / (2 * h)
    np.testing.assert_allclose(basis.derivative(q), fd, atol=1e-6 * max(1, np.abs(fd).max()))
    np.testing.assert_allclose(basis.values(q)[:, 0], 1.0)
    assert basis.values(q).shape == (41, basis.size) == (41, len(basis.labels()))


def test_basis_beyond_its_span_carries_on_its_line_only():
    """Chebyshev polynomials over [-0.5, 2.0] (u = (2 q - 1.5) / 2.5) beyond it, closed
    form: c_k(+-1) = (+-1)^k plus the slope of c_k's least-squares line in u (Legendre:
    3/2 int c_k u du): 1 for c_1 (its own line), 0 for even k, 3/2 (8/5 - 2) = -0.6 for
    c_3 (4u^3 - 3u), 3/2 (16 * 2/7 - 20 * 2/5 + 5 * 2/3) = -1/7 for c_5."""
    cheb = AxisBasis(-0.5, 2.0, 5)
    k = np.arange(6)
    b = np.array([0.0, 1.0, 0.0, -0.6, 0.0, 1.5 * (32 / 7 - 8 + 10 / 3)])
    for q, end in ((2.7, 1.0), (9.0, 1.0), (-0.6, -1.0), (-3.0, -1.0)):
        du = (2 * q - 1.5) / 2.5 - end
        np.testing.assert_allclose(cheb.values(np.array([q]))[0], end ** k + b * du, atol=1e-12)
        np.testing.assert_allclose(cheb.derivative(np.array([q]))[0], b * 2 / 2.5, atol=1e-12)
    spline = AxisBasis(0.1, 2.2, 3, "bspline", knots=(0.8, 1.5))   # a straight line stays one beyond
    qs = np.linspace(0.1, 2.2, 50)
    coef = np.linalg.lstsq(spline.values(qs), 0.3 + 0.7 * qs, rcond=None)[0]
    np.testing.assert_allclose(spline.values(np.array([-0.5, 3.1])) @ coef, 0.3 + 0.7 * np.array([-0.5, 3.1]), atol=1e-9)
    per_turn = AxisBasis(-1.0, 1.5, 4, "fourier", rotary=True)   # periodic: repeats a turn on
    np.testing.assert_allclose(per_turn.values(np.array([1.5 + 2 * np.pi])), per_turn.values(np.array([1.5])), atol=1e-12)


@pytest.mark.parametrize("degree", [1, 2, 3, 5])
def test_b_splines_are_scipys(rng, degree):
    """vecpin's Cox-de Boor B-splines (values and derivatives, at random points, on the
    knots and at both ends, a double knot above degree 1) are scipy's BSpline with
    identity coefficients (an independent implementation)."""
    from scipy.interpolate import BSpline

    from vecpin.models.basis import b_splines
    inner = np.sort(np.r_[rng.uniform(-2.0, 3.0, 6), [0.5, 0.5] if degree > 1 else 0.5])
    t = np.r_[[-2.0] * (degree + 1), inner, [3.0] * (degree + 1)]
    x = np.r_[rng.uniform(-2.0, 3.0, 40), -2.0, 3.0, inner]
    x = x[:len(x) // 2 * 2].reshape(2, -1)   # any shape of positions
    reference = BSpline(t, np.eye(len(t) - degree - 1), degree)
    np.testing.assert_allclose(b_splines(t, degree, x), reference(x), atol=1e-13)
    np.testing.assert_allclose(b_splines(t, degree, x, derivative=True), reference.derivative()(x), atol=1e-11)
    np.testing.assert_allclose(b_splines(t, degree, x).sum(axis=-1), 1.0, atol=1e-13)   # a partition of unity


def test_chebyshev_recursion_is_eq6():
    b = AxisBasis(-1.0, 1.0, 4)
    x = np.linspace(-1, 1, 9)
    np.testing.assert_allclose(b.values(x), np.stack([np.ones_like(x), x, 2 * x**2 - 1, 4 * x**3 - 3 * x,
                                                       8 * x**4 - 8 * x**2 + 1], -1), atol=1e-14)


def test_zero_parameters_are_the_nominal_machine(flow, rng):
    q = uniform_commands(flow, 10, rng)
    for model in (SixDofModel(flow, 4), APModel(flow, 4)):
        np.testing.assert_allclose(model.tool_tip(q, 0.3, np.zeros(model.n_parameters), False).tip,
                                   flow.tool_tip(q, 0.3), atol=1e-15)


def test_ap_model_is_nominal_kinematics_at_perturbed_commands(flow, rng):
    """eq. 7: F_AP(q) = F_n(q + q_hat(q))."""
    model = APModel(flow, 3)
    b = rng.normal(size=model.n_parameters) * 1e-3
    q = uniform_commands(flow, 10, rng)
    np.testing.assert_allclose(model.tool_tip(q, 0.2, b, False).tip,
                               flow.tool_tip(q + model.perturbation(q, b), 0.2 + b[0]), atol=1e-15)


def test_parameter_counts_and_priority_order(flow):
    six = SixDofModel(flow, 6)
    ap = APModel(flow, 6)
    assert six.n_parameters == 1 + 5 * 6 * 7
    assert ap.n_parameters == 1 + 5 + 6 * 5 * 5
    orders = [p.order for p in six.parameters]
    assert orders == sorted(orders)  # offsets, then all order-0 terms, then order 1, ...
    assert ap.parameter_names[:7] == ["T_offset", "X.offset", "Y.offset", "Z.offset", "C.offset", "B.offset", "X->X.1"]
    assert [B.kind for B in SixDofModel(flow, 2).bases] == ["chebyshev"] * 3 + ["fourier", "chebyshev"]
    assert [B.kind for B in SixDofModel(flow, 2, basis="chebyshev").bases] == ["chebyshev"] * 5
