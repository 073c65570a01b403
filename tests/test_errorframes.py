"""6-DoF error transforms in the Pinocchio chain: against a numpy product of 4x4
matrices (Paper I eq. 3 with exact transforms) and finite differences."""
import numpy as np
import pinocchio as pin
import pytest

from vecpin.kinematics import so3
from vecpin.kinematics.errorframes import ErrorFrames
from vecpin.simulation.truth import uniform_commands


def se3(R, p):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def reference_tip(machine, q, delta, eps, L):
    """T_1(q_1) E_1 ... T_n(q_n) E_n T_tool, built from the URDF placements by hand."""
    model = machine.model
    T = np.eye(4)
    for k, a in enumerate(machine.axes):
        placement = model.jointPlacements[a.joint_id].homogeneous
        d = np.array(a.direction)
        if a.kind == "linear":
            M = se3(np.eye(3), d * q[k])
        else:
            M = se3(so3.exp3(d * q[k]), np.zeros(3))
        T = T @ placement @ M @ se3(so3.exp3(eps[k]), delta[k])
    f = model.frames[machine.spindle_frame_id]
    T = T @ f.placement.homogeneous
    return (T @ np.array([0, 0, -L, 1]))[:3]


@pytest.mark.parametrize("name", ["flow_xyzcb", "ingersoll_xyzca", "snk_120v"])
def test_error_chain_matches_matrix_product(machines, name, rng):
    m = machines[name]
    ef = ErrorFrames(m)
    q = uniform_commands(m, 10, rng)
    delta = rng.normal(size=(10, m.n_axes, 3)) * 1e-3
    eps = rng.normal(size=(10, m.n_axes, 3)) * 1e-2  # large on purpose: exactness, not linearisation
    L = rng.uniform(0.1, 0.3, 10)
    tip = ef.tool_tip(q, delta, eps, L, jacobian=False).tip
    ref = np.array([reference_tip(m, q[i], delta[i], eps[i], L[i]) for i in range(10)])
    np.testing.assert_allclose(tip, ref, atol=1e-12)


def test_zero_errors_equal_nominal(flow, rng):
    ef = ErrorFrames(flow)
    q = uniform_commands(flow, 30, rng)
    z = np.zeros((30, 5, 3))
    np.testing.assert_allclose(ef.tool_tip(q, z, z, 0.2).tip, flow.tool_tip(q, 0.2), atol=1e-14)


def test_error_jacobians_match_finite_differences(flow, rng):
    ef = ErrorFrames(flow)
    N = 6
    q = uniform_commands(flow, N, rng)
    delta = rng.normal(size=(N, 5, 3)) * 1e-4
    eps = rng.normal(size=(N, 5, 3)) * 1e-3
    L = np.full(N, 0.25)
    out = ef.tool_tip(q, delta, eps, L)
    h = 1e-7
    for k in range(5):
        for c in range(3):
            d = np.zeros((N, 5, 3))
            d[:, k, c] = h
            fd_delta = (ef.tool_tip(q, delta + d, eps, L, False).tip - ef.tool_tip(q, delta - d, eps, L, False).tip) / (2 * h)
            fd_eps = (ef.tool_tip(q, delta, eps + d, L, False).tip - ef.tool_tip(q, delta, eps - d, L, False).tip) / (2 * h)
            np.testing.assert_allclose(out.J_delta[:, :, k, c], fd_delta, atol=1e-8)
            np.testing.assert_allclose(out.J_eps[:, :, k, c], fd_eps, atol=1e-8)
        dq = np.zeros(5)
        dq[k] = h
        fd_q = (ef.tool_tip(q + dq, delta, eps, L, False).tip - ef.tool_tip(q - dq, delta, eps, L, False).tip) / (2 * h)
        np.testing.assert_allclose(out.J_q[:, :, k], fd_q, atol=1e-8)
    np.testing.assert_allclose(out.tool_dir, (out.tip - ef.tool_tip(q, delta, eps, 0.0, False).tip) / 0.25, atol=1e-12)


def test_so3_helpers_match_pinocchio(rng):
    w = rng.normal(size=(20, 3)) * np.r_[1e-9, 1e-5, 0.3, 2.0][rng.integers(0, 4, 20)][:, None]
    R = so3.exp3(w)
    Jr = so3.right_jacobian(w)
    qt = so3.quaternion_xyzw(w)
    for i in range(20):
        np.testing.assert_allclose(R[i], pin.exp3(w[i]), atol=1e-13)
        np.testing.assert_allclose(Jr[i], pin.Jexp3(w[i]), atol=1e-12)
        np.testing.assert_allclose(pin.Quaternion(qt[i][3], *qt[i][:3]).toRotationMatrix(), R[i], atol=1e-13)
    np.testing.assert_allclose(so3.log3(R), w * (np.linalg.norm(w, axis=1) < np.pi)[:, None], atol=1e-9)
