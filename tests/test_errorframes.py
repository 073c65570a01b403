"""6-DoF error transforms after every moving joint, on both branches: against a product
of 4x4 matrices built from yourdfpy's reading of the URDF (Paper I eq. 3 with exact
transforms, large errors on purpose) and against finite differences."""
import numpy as np
import pinocchio as pin
import pytest
import yourdfpy

from vecpin.kinematics import so3
from vecpin.kinematics.errorframes import ErrorFrames
from vecpin.models import APModel, SixDofModel
from vecpin.simulation.truth import uniform_commands


def se3(R, p):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


class Reference:
    """T_1(q_1) E_1 ... along the URDF path to a link, from yourdfpy's joint data."""

    def __init__(self, machine, slot_names):
        self.urdf = yourdfpy.URDF.load(str(machine.urdf_path), load_meshes=False, build_scene_graph=False,
                                       build_collision_scene_graph=False)
        self.parent_joint = {j.child: j for j in self.urdf.robot.joints}
        self.axes = machine.axis_names
        self.slot = {n: k for k, n in enumerate(slot_names)}

    def pose(self, link, q, delta, eps):
        chain = []
        while link in self.parent_joint:
            j = self.parent_joint[link]
            chain.append(j)
            link = j.parent
        T = np.eye(4)
        for j in reversed(chain):
            T = T @ j.origin
            if j.type == "fixed":
                continue
            if j.mimic is not None:
                v = j.mimic.multiplier * q[self.axes.index(j.mimic.joint)] + j.mimic.offset
            else:
                v = q[self.axes.index(j.name)]
            axis = np.asarray(j.axis, float)
            T = T @ (se3(np.eye(3), axis * v) if j.type == "prismatic" else se3(so3.exp3(axis * v), np.zeros(3)))
            k = self.slot.get(j.name)
            if k is not None and k < delta.shape[0]:
                T = T @ se3(so3.exp3(eps[k]), delta[k])
        return T

    def tip(self, link, q, delta, eps, tool, tool_axis, relative):
        T = self.pose(link, q, delta, eps)
        p = T[:3, 3] + tool * T[:3, :3] @ tool_axis
        if relative:
            W = self.pose("workpiece", q, delta, eps)
            p = W[:3, :3].T @ (p - W[:3, 3])
        return p


CASES = [("flow_xyzcb", "base"), ("ingersoll_xyzca", "base"), ("snk_120v", "base"), ("master_mill", "base"),
         ("production_xyzbaw", "base"), ("ur5", "base"), ("spar_mill_23", "base"),
         ("trunnion_xyzac", "workpiece"), ("trunnion_xyzac", "base"), ("trunnion_xyzbc", "workpiece"),
         ("head_table_bc", "workpiece")]


def _draw(m, N: int, slots: int, scale: float, rng):
    """N commands over the travel and random error transforms of ``slots`` slots: translations
    ~ ``scale`` [m], rotations ~ 10 ``scale`` [rad]."""
    q = uniform_commands(m, N, rng)
    return q, rng.normal(size=(N, slots, 3)) * scale, rng.normal(size=(N, slots, 3)) * 10 * scale


@pytest.mark.parametrize("name, frame", CASES)
def test_error_chain_matches_matrix_product(machines, name, frame, rng):
    m = machines[name]
    ef = ErrorFrames(m)
    ref = Reference(m, ef.slot_names)
    N, S = 10, ef.n_slots
    q, delta, eps = _draw(m, N, S, 1e-3, rng)  # large on purpose: exactness, not linearisation
    L = rng.uniform(0.1, 0.3, N)
    for point, link in enumerate(m.tool_links):
        for n_err in sorted({m.n_axes, S}):  # errors on the axes only, or on every slot
            out = ef.tool_tip(q, delta[:, :n_err], eps[:, :n_err], L, jacobian=False, frame=frame, point=point)
            expected = np.array([ref.tip(link, q[i], delta[i, :n_err], eps[i, :n_err], L[i], m.tool_axis,
                                         frame == "workpiece" and m.has_workpiece) for i in range(N)])
            np.testing.assert_allclose(out.tip, expected, atol=1e-12)
    if m.has_workpiece:
        p_wp = rng.uniform(-0.2, 0.2, (N, 3))
        xyz = ef.workpiece_points(q, delta, eps, p_wp, jacobian=False).xyz
        W = [ref.pose("workpiece", q[i], delta[i], eps[i]) for i in range(N)]
        np.testing.assert_allclose(xyz, [Wi[:3, :3] @ p + Wi[:3, 3] for Wi, p in zip(W, p_wp)], atol=1e-12)


@pytest.mark.parametrize("name", ["flow_xyzcb", "trunnion_xyzac", "spar_mill_23", "ur5"])
def test_zero_errors_equal_nominal(machines, name, rng):
    m = machines[name]
    ef = ErrorFrames(m)
    q = uniform_commands(m, 30, rng)
    z = np.zeros((30, m.n_axes, 3))
    point = rng.integers(0, len(m.tool_links), 30)
    for frame in ("base", "workpiece"):
        out = ef.tool_tip(q, z, z, 0.2, frame=frame, point=point)
        nom = m.kinematics(q, 0.2, frame=frame, point=point)
        np.testing.assert_allclose(out.tip, nom.tip, atol=1e-14)
        np.testing.assert_allclose(out.J_q, nom.jacobian, atol=1e-14)
        np.testing.assert_allclose(out.tool_dir, nom.tool_dir, atol=1e-15)


def _fd_errors(f, delta, eps, h=1e-6):  # 1e-6: tips 30 m from the origin lose 1e-15 relative
    N, S, _ = delta.shape
    J_d = np.empty((N, 3, S, 3))
    J_e = np.empty((N, 3, S, 3))
    for k in range(S):
        for c in range(3):
            d = np.zeros((N, S, 3))
            d[:, k, c] = h
            J_d[:, :, k, c] = (f(delta + d, eps) - f(delta - d, eps)) / (2 * h)
            J_e[:, :, k, c] = (f(delta, eps + d) - f(delta, eps - d)) / (2 * h)
    return J_d, J_e


@pytest.mark.parametrize("name, frame", [("flow_xyzcb", "base"), ("trunnion_xyzac", "workpiece"),
                                         ("trunnion_xyzac", "base"), ("head_table_bc", "workpiece"),
                                         ("spar_mill_23", "base"), ("production_xyzbaw", "base")])
def test_error_jacobians_match_finite_differences(machines, name, frame, rng):
    m = machines[name]
    ef = ErrorFrames(m)
    N, S = 6, ef.n_slots
    q, delta, eps = _draw(m, N, S, 1e-4, rng)
    L = np.full(N, 0.25)
    point = np.arange(N) % len(m.tool_links)
    out = ef.tool_tip(q, delta, eps, L, frame=frame, point=point)
    assert out.J_delta.shape == (N, 3, S, 3)
    J_d, J_e = _fd_errors(lambda d, e: ef.tool_tip(q, d, e, L, False, frame=frame, point=point).tip, delta, eps)
    np.testing.assert_allclose(out.J_delta, J_d, atol=1e-8)
    np.testing.assert_allclose(out.J_eps, J_e, atol=1e-8)
    h = 1e-6
    for k in range(m.n_axes):
        dq = np.zeros(m.n_axes)
        dq[k] = h
        fd_q = (ef.tool_tip(q + dq, delta, eps, L, False, frame=frame, point=point).tip
                - ef.tool_tip(q - dq, delta, eps, L, False, frame=frame, point=point).tip) / (2 * h)
        np.testing.assert_allclose(out.J_q[:, :, k], fd_q, atol=1e-8)
    np.testing.assert_allclose(out.tool_dir, (out.tip - ef.tool_tip(q, delta, eps, 0.0, False, frame=frame,
                                                                     point=point).tip) / 0.25, atol=1e-12)
    if m.has_workpiece and frame == "workpiece":
        # head slots and table slots both move the relative tip; a table error moves it the other way
        table = [a.index for a in m.axes if a.side == "table"]
        assert np.abs(out.J_delta[:, :, table]).max() > 0.5


@pytest.mark.parametrize("name", ["trunnion_xyzbc", "head_table_bc"])
def test_workpiece_point_error_jacobians(machines, name, rng):
    m = machines[name]
    ef = ErrorFrames(m)
    N, n = 5, m.n_axes
    q, delta, eps = _draw(m, N, n, 1e-4, rng)
    p = rng.uniform(-0.2, 0.2, (N, 3))
    out = ef.workpiece_points(q, delta, eps, p)
    J_d, J_e = _fd_errors(lambda d, e: ef.workpiece_points(q, d, e, p, False).xyz, delta, eps)
    np.testing.assert_allclose(out.J_delta, J_d, atol=1e-8)
    np.testing.assert_allclose(out.J_eps, J_e, atol=1e-8)
    head = [a.index for a in m.axes if a.side == "head"]
    assert np.all(out.J_delta[:, :, head] == 0) and np.all(out.J_eps[:, :, head] == 0)
    h = 1e-7
    for k in range(n):
        dq = np.zeros(n)
        dq[k] = h
        fd = (ef.workpiece_points(q + dq, delta, eps, p, False).xyz - ef.workpiece_points(q - dq, delta, eps, p, False).xyz) / (2 * h)
        np.testing.assert_allclose(out.J_q[:, :, k], fd, atol=1e-8)
    for c in range(3):
        e = np.zeros(3)
        e[c] = h
        fd = (ef.workpiece_points(q, delta, eps, p + e, False).xyz - ef.workpiece_points(q, delta, eps, p - e, False).xyz) / (2 * h)
        np.testing.assert_allclose(out.J_p[:, :, c], fd, atol=1e-8)


def test_models_with_zero_parameters_give_the_nominal_relative_tip(machines, rng):
    """APModel (through Machine.kinematics) and SixDofModel (through ErrorFrames) work on a
    two-branch machine: asked for the tip relative to the workpiece (models default to
    the base frame, what a tracker sees), with zero parameters both give the nominal
    tool tip relative to the workpiece, and their Jacobians match finite differences."""
    from closed_forms import trunnion_xyzac
    m = machines["trunnion_xyzac"]
    q = uniform_commands(m, 12, rng)
    for model in (SixDofModel(m, 3), APModel(m, 3)):
        b = np.zeros(model.n_parameters)
        out = model.tool_tip(q, 0.2, b, frame="workpiece")
        np.testing.assert_allclose(out.tip, trunnion_xyzac(q, np.full(12, 0.2)), atol=1e-12)
        np.testing.assert_allclose(out.tool_dir, m.kinematics(q, 0.2).tool_dir, atol=1e-15)
        b = rng.normal(size=model.n_parameters) * 1e-4
        out = model.tool_tip(q, 0.2, b, frame="workpiece")
        h = 1e-7
        for k in rng.choice(model.n_parameters, 12, replace=False):
            e = np.zeros_like(b)
            e[k] = h
            fd = (model.tool_tip(q, 0.2, b + e, False, frame="workpiece").tip
                  - model.tool_tip(q, 0.2, b - e, False, frame="workpiece").tip) / (2 * h)
            np.testing.assert_allclose(out.J_b[:, :, k], fd, atol=3e-8)


def test_so3_helpers_match_pinocchio(rng):
    w = rng.normal(size=(20, 3)) * np.r_[1e-9, 1e-5, 0.3, 2.0][rng.integers(0, 4, 20)][:, None]
    R = so3.exp3(w)
    Jr = so3.right_jacobian(w)
    R2, Jr2 = so3.exp3_and_right_jacobian(w)
    np.testing.assert_array_equal(R, R2)
    np.testing.assert_array_equal(Jr, Jr2)
    qt = so3.quaternion_xyzw(w)
    for i in range(20):
        np.testing.assert_allclose(R[i], pin.exp3(w[i]), atol=1e-13)
        np.testing.assert_allclose(Jr[i], pin.Jexp3(w[i]), atol=1e-12)
        np.testing.assert_allclose(pin.Quaternion(qt[i][3], *qt[i][:3]).toRotationMatrix(), R[i], atol=1e-13)
    np.testing.assert_allclose(so3.log3(R), w * (np.linalg.norm(w, axis=1) < np.pi)[:, None], atol=1e-9)


def test_error_joints_are_pinocchio_free_flyers_after_every_slot(machines):
    """The error transforms live in Pinocchio: one free-flyer joint right after every slot
    joint (axes, then mimic joints), carrying the slot joint's children."""
    for name in ("trunnion_xyzac", "spar_mill_23"):
        m = machines[name]
        ef = ErrorFrames(m)
        model = ef.model
        for s in ef.slot_names:
            assert model.existJointName(s + "__error")
            j, e = model.getJointId(s), model.getJointId(s + "__error")
            assert model.joints[e].shortname() == "JointModelFreeFlyer" and model.parents[e] == j
            assert [c for c in range(1, model.njoints) if model.parents[c] == j] == [e]
        assert model.nv == ef.n_slots * 7  # 1-DoF slot joints (mimic joints too) + 6 per error joint


LIMIT = "<limit lower='-1' upper='1' effort='1' velocity='1'/>"
LATE_SOURCE = ("<robot name='late_source'><link name='base'/><link name='head'/><link name='spindle'/>"
               "<link name='workpiece'/>"
               "<joint name='M' type='prismatic'><parent link='base'/><child link='head'/><axis xyz='0 1 0'/>"
               f"{LIMIT}<mimic joint='X' multiplier='-1' offset='0.05'/></joint>"
               "<joint name='g' type='fixed'><parent link='head'/><child link='spindle'/>"
               "<origin xyz='0 0 0.3'/></joint>"
               "<joint name='X' type='prismatic'><parent link='base'/><child link='workpiece'/><axis xyz='1 0 0'/>"
               f"{LIMIT}</joint></robot>")


def test_error_slots_when_pinocchio_cannot_build_the_mimic_joint(rng):
    """Mimic joint M (head, along y) met before its source X (table, along x): Pinocchio
    refuses the mimic, vecpin sets M itself. Without rotation errors a translation error
    on the head slot moves the relative tip by +delta, one on the table slot by -delta
    (both slot frames are aligned with the base); Jacobians against finite differences."""
    from vecpin import Machine
    m = Machine.from_urdf_string(LATE_SOURCE)
    ef = ErrorFrames(m)
    assert ef.slot_names == ["X", "M"] and list(ef.slot_axis) == [0, 0]
    N = 6
    q = rng.uniform(-1, 1, (N, 1))
    delta = rng.normal(size=(N, 2, 3)) * 1e-3
    zero = np.zeros((N, 2, 3))
    out = ef.tool_tip(q, delta, zero, 0.1, jacobian=False)
    np.testing.assert_allclose(out.tip, m.tool_tip(q, 0.1) + delta[:, 1] - delta[:, 0], atol=1e-15)
    eps = rng.normal(size=(N, 2, 3)) * 1e-2
    for frame in ("workpiece", "base"):
        out = ef.tool_tip(q, delta, eps, 0.1, frame=frame)
        J_d, J_e = _fd_errors(lambda d, e: ef.tool_tip(q, d, e, 0.1, False, frame=frame).tip, delta, eps)
        np.testing.assert_allclose(out.J_delta, J_d, atol=1e-8)
        np.testing.assert_allclose(out.J_eps, J_e, atol=1e-8)
        fd_q = (ef.tool_tip(q + 1e-6, delta, eps, 0.1, False, frame=frame).tip
                - ef.tool_tip(q - 1e-6, delta, eps, 0.1, False, frame=frame).tip) / 2e-6
        np.testing.assert_allclose(out.J_q[:, :, 0], fd_q, atol=1e-8)
