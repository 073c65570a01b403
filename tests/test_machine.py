"""Nominal kinematics of every bundled machine against independent truth: hand-derived
closed forms (tests/closed_forms.py), yourdfpy and Pinocchio as second and third URDF
readers, and finite differences for the Jacobians. Two-branch machines (a table branch
to 'workpiece') are checked in both frames; Spar Mill 23 on both spindles."""
import math

import numpy as np
import pinocchio as pin
import pytest
import yourdfpy

import vecpin
from closed_forms import MACHINES as CLOSED_FORMS
from closed_forms import homogeneous, rot, ur5_dh, ur5_planar
from vecpin.kinematics.axes import bundled_machines
from vecpin.simulation.truth import uniform_commands

TWO_BRANCH = ["trunnion_xyzac", "trunnion_xyzbc", "head_table_bc", "xyzac_trt"]
#: tool direction in the tool link frame, from each URDF's header (not from vecpin)
TOOL_AXIS = {name: np.array([0.0, 0.0, 1.0 if name in ("ur5", "ur10") else -1.0]) for name in CLOSED_FORMS}


def test_every_bundled_machine_has_a_closed_form():
    assert set(bundled_machines()) == set(CLOSED_FORMS)


@pytest.mark.parametrize("name", sorted(CLOSED_FORMS))
def test_tool_tip_matches_closed_form(machines, name, rng):
    """200 random configurations within the limits (table rotations over their full
    travel on the trunnions), every tool point, default frame (workpiece on two-branch machines)."""
    m = machines[name]
    q = uniform_commands(m, 200, rng)
    tool = rng.uniform(0.0, 0.4, 200)
    tips, _ = CLOSED_FORMS[name]
    assert len(tips) == len(m.tool_links)
    for point, f in tips.items():
        np.testing.assert_allclose(m.tool_tip(q, tool, point=point), f(q, tool), atol=1e-12)


@pytest.mark.parametrize("name", TWO_BRANCH)
def test_workpiece_pose_and_base_frame_tip_match_closed_form(machines, name, rng):
    m = machines[name]
    q = uniform_commands(m, 200, rng)
    tool = rng.uniform(0.0, 0.4, 200)
    T_bw = CLOSED_FORMS[name][1](q)
    np.testing.assert_allclose(m.workpiece_pose(q), T_bw, atol=1e-12)
    rel = CLOSED_FORMS[name][0][0](q, tool)
    base = np.einsum("pij,pj->pi", T_bw[:, :3, :3], rel) + T_bw[:, :3, 3]
    np.testing.assert_allclose(m.tool_tip(q, tool, frame="base"), base, atol=1e-12)
    np.testing.assert_allclose(m.tool_tip(q, tool, frame="workpiece"), rel, atol=1e-12)
    assert m.default_frame == "workpiece" and m.has_workpiece


def test_trunnion_table_rotation_moves_the_relative_tip_the_other_way(machines):
    """With the head still, turning the C table by +90 deg turns the tip, seen from the
    table, by -90 deg about the table's z; tilting A by +30 deg tilts it by -30 deg about x
    through the A axis (0.100 m above the face)."""
    m = machines["trunnion_xyzac"]
    q0 = np.array([[0.12, -0.05, -0.2, 0.0, 0.0]])
    p0 = m.tool_tip(q0, 0.1)[0]
    qc = q0.copy()
    qc[0, 4] = math.pi / 2
    np.testing.assert_allclose(m.tool_tip(qc, 0.1)[0], rot("z", -math.pi / 2) @ p0, atol=1e-14)
    qa = q0.copy()
    qa[0, 3] = math.radians(30)
    h = np.array([0, 0, 0.100])
    np.testing.assert_allclose(m.tool_tip(qa, 0.1)[0], rot("x", -math.radians(30)) @ (p0 - h) + h, atol=1e-14)
    # the floor tracker sees the head only: table axes do not move the base-frame tip
    np.testing.assert_allclose(m.tool_tip(qc, 0.1, frame="base"), m.tool_tip(q0, 0.1, frame="base"), atol=1e-15)


@pytest.mark.parametrize("name", sorted(CLOSED_FORMS))
def test_tool_tip_matches_yourdfpy(machines, name, rng):
    """A second, independent URDF reader agrees on every tool point, in both frames,
    for 200 random configurations within the limits."""
    m = machines[name]
    urdf = yourdfpy.URDF.load(str(m.urdf_path), load_meshes=False, build_collision_scene_graph=False)
    assert list(urdf.actuated_joint_names) == m.axis_names  # URDF order is vecpin's order here
    q = uniform_commands(m, 200, rng)
    tool = rng.uniform(0.0, 0.4, 200)
    root = urdf.base_link
    for point, link in enumerate(m.tool_links):
        base = m.kinematics(q, tool, jacobian=False, frame="base", point=point)
        rel = m.kinematics(q, tool, jacobian=False, frame="workpiece", point=point)
        for i in range(len(q)):
            urdf.update_cfg(dict(zip(m.axis_names, q[i])))
            T = urdf.get_transform(link, root)
            tip = T[:3, 3] + tool[i] * T[:3, :3] @ TOOL_AXIS[name]
            np.testing.assert_allclose(base.tip[i], tip, atol=1e-12)
            np.testing.assert_allclose(base.rotation[i], T[:3, :3], atol=1e-12)
            if m.has_workpiece:
                W = urdf.get_transform("workpiece", root)
                T = np.linalg.inv(W) @ T
                tip = W[:3, :3].T @ (tip - W[:3, 3])
            np.testing.assert_allclose(rel.tip[i], tip, atol=1e-12)
            np.testing.assert_allclose(rel.rotation[i], T[:3, :3], atol=1e-12)
            np.testing.assert_allclose(rel.tool_dir[i], T[:3, :3] @ TOOL_AXIS[name], atol=1e-12)


@pytest.mark.parametrize("name", sorted(CLOSED_FORMS))
def test_tool_tip_matches_pinocchio(machines, name, rng):
    """Pinocchio's own URDF parser and forward kinematics (mimic joints honoured)."""
    m = machines[name]
    model = pin.buildModelFromUrdf(str(m.urdf_path), mimic=True)
    data = model.createData()
    q = uniform_commands(m, 20, rng)
    for point, link in enumerate(m.tool_links):
        fid = model.getFrameId(link)
        kin = m.kinematics(q, 0.0, jacobian=False, frame="base", point=point)
        for i in range(len(q)):
            qp = pin.neutral(model)
            for k, a in enumerate(m.axis_names):
                qp[model.joints[model.getJointId(a)].idx_q] = q[i, k]
            pin.framesForwardKinematics(model, data, qp)
            np.testing.assert_allclose(kin.spindle[i], data.oMf[fid].translation, atol=1e-12)
            np.testing.assert_allclose(kin.rotation[i], data.oMf[fid].rotation, atol=1e-12)


@pytest.mark.parametrize("name", sorted(CLOSED_FORMS))
def test_jacobians_match_pinocchio_frame_jacobians(machines, name, rng):
    """vecpin reads placements and Jacobian columns out of one computeJointJacobians call
    per pose (probe joints); Pinocchio's documented per-frame API, on a model loaded
    separately, must give the same tool-link and workpiece Jacobians (LOCAL_WORLD_ALIGNED:
    velocity of the frame origin, in base axes; mimic joints summed into their source)."""
    m = machines[name]
    model = pin.buildModelFromUrdf(str(m.urdf_path), mimic=True)
    data = model.createData()
    q = uniform_commands(m, 10, rng)
    cols = [model.joints[model.getJointId(a)].idx_v for a in m.axis_names]
    links = list(m.tool_links) + (["workpiece"] if m.has_workpiece else [])
    for k, link in enumerate(links):
        fid = model.getFrameId(link, pin.FrameType.BODY)
        if link == "workpiece":
            got = m.workpiece_points(q, np.zeros(3)).J_q
        else:
            got = m.kinematics(q, 0.0, frame="base", point=k).jacobian
        for i in range(len(q)):
            qp = pin.neutral(model)
            for j, a in enumerate(m.axis_names):
                qp[model.joints[model.getJointId(a)].idx_q] = q[i, j]
            Jf = pin.computeFrameJacobian(model, data, qp, fid, pin.LOCAL_WORLD_ALIGNED)
            np.testing.assert_allclose(got[i], Jf[:3, cols], atol=1e-12)


MIMIC_LIMIT = "<limit lower='-1' upper='1' effort='1' velocity='1'/>"


def _mimic_joint(name, parent, child, jtype, axis, extra=""):
    return (f"<joint name='{name}' type='{jtype}'><parent link='{parent}'/><child link='{child}'/>"
            f"<axis xyz='{axis}'/>{MIMIC_LIMIT}{extra}</joint>")


def test_mimic_joint_follows_multiplier_and_offset(rng):
    """Z = 2 X + 0.1 (prismatic) and C = -3 X + 0.2 (revolute about z) follow the one axis X;
    the spindle sits 0.05 m along x of C's frame. Closed form:
    tip = (X + 0.05 cos C, 0.05 sin C, Z - tool), d tip / dX = (1 + 0.15 sin C, -0.15 cos C, 2)."""
    xml = ("<robot name='mimics'>" + "".join(f"<link name='{n}'/>" for n in ("base", "a", "b", "c", "spindle"))
           + _mimic_joint("X", "base", "a", "prismatic", "1 0 0")
           + _mimic_joint("Z", "a", "b", "prismatic", "0 0 1", "<mimic joint='X' multiplier='2' offset='0.1'/>")
           + _mimic_joint("C", "b", "c", "revolute", "0 0 1", "<mimic joint='X' multiplier='-3' offset='0.2'/>")
           + "<joint name='g' type='fixed'><parent link='c'/><child link='spindle'/><origin xyz='0.05 0 0'/></joint>"
           + "</robot>")
    m = vecpin.Machine.from_urdf_string(xml)
    assert m.axis_names == ["X"] and [(j.name, j.axis, j.multiplier, j.offset) for j in m.mimic_joints] == \
        [("Z", "X", 2.0, 0.1), ("C", "X", -3.0, 0.2)]
    assert [m.model.joints[m.model.getJointId(n)].shortname() for n in ("Z", "C")] == ["JointModelMimic"] * 2
    q = rng.uniform(-1, 1, (20, 1))
    tool = rng.uniform(0, 0.3, 20)
    X, Z, C = q[:, 0], 2 * q[:, 0] + 0.1, -3 * q[:, 0] + 0.2
    kin = m.kinematics(q, tool)
    np.testing.assert_allclose(kin.tip, np.stack([X + 0.05 * np.cos(C), 0.05 * np.sin(C), Z - tool], -1), atol=1e-15)
    np.testing.assert_allclose(kin.jacobian[:, :, 0],
                               np.stack([1 + 0.15 * np.sin(C), -0.15 * np.cos(C), np.full(20, 2.0)], -1), atol=1e-14)
    np.testing.assert_allclose(m.full_q(q), q)  # Pinocchio's mimic joints read X's entry


def test_mimic_joints_pinocchio_cannot_build_are_set_by_vecpin(rng):
    """A mimic joint met before its source (here on the tool branch, its source X on the
    table branch) is refused by Pinocchio's mimic support; the joint is then an ordinary
    joint of the model set to multiplier * X + offset, with a note. Closed form: the
    spindle at (0, 0.05 - X, 0.3), the workpiece at (X, 0, 0): relative tip
    (-X, 0.05 - X, 0.3 - tool), d/dX = (-1, -1, 0); the base-frame tip moves with (0, -1, 0)."""
    xml = ("<robot name='late_source'>"
           + "".join(f"<link name='{n}'/>" for n in ("base", "head", "spindle", "workpiece"))
           + _mimic_joint("M", "base", "head", "prismatic", "0 1 0", "<mimic joint='X' multiplier='-1' offset='0.05'/>")
           + "<joint name='g' type='fixed'><parent link='head'/><child link='spindle'/><origin xyz='0 0 0.3'/></joint>"
           + _mimic_joint("X", "base", "workpiece", "prismatic", "1 0 0") + "</robot>")
    m = vecpin.Machine.from_urdf_string(xml)
    assert any("Pinocchio could not build the <mimic> joints" in n for n in m.notes)
    assert m.axis_names == ["X"] and m.axis("X").side == "both" and m.model.nq == 2
    q = rng.uniform(-1, 1, (10, 1))
    X = q[:, 0]
    kin = m.kinematics(q, 0.1)
    np.testing.assert_allclose(kin.tip, np.stack([-X, 0.05 - X, np.full(10, 0.2)], -1), atol=1e-15)
    np.testing.assert_allclose(kin.jacobian[:, :, 0], np.broadcast_to([-1.0, -1.0, 0.0], (10, 3)), atol=1e-15)
    np.testing.assert_allclose(m.kinematics(q, 0.1, frame="base").jacobian[:, :, 0],
                               np.broadcast_to([0.0, -1.0, 0.0], (10, 3)), atol=1e-15)
    np.testing.assert_allclose(m.full_q(q)[:, [m.model.joints[m.model.getJointId(n)].idx_q for n in ("M", "X")]],
                               np.stack([0.05 - X, X], -1), atol=1e-15)


def _fd(f, x, h):
    """Central differences of f over the columns of x (N, n) -> (N, 3, n)."""
    cols = []
    for k in range(x.shape[1]):
        d = np.zeros(x.shape[1])
        d[k] = h
        cols.append((f(x + d) - f(x - d)) / (2 * h))
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("frame", ["base", "workpiece"])
@pytest.mark.parametrize("name", sorted(CLOSED_FORMS))
def test_jacobian_matches_finite_differences(machines, name, frame, rng):
    m = machines[name]
    q = uniform_commands(m, 20, rng)
    tool = rng.uniform(0.1, 0.4, 20)
    offset = rng.normal(size=(20, 3)) * 0.1  # an off-axis target, in the tool link frame
    for point in range(len(m.tool_links)):
        kin = m.kinematics(q, tool, frame=frame, point=point, offset=offset)
        fd = _fd(lambda x: m.tool_tip(x, tool, frame=frame, point=point, offset=offset), q, 1e-6)
        np.testing.assert_allclose(kin.jacobian, fd, atol=1e-8)
        # d tip / d tool length and d tip / d offset
        dt = (m.tool_tip(q, tool + 1e-6, frame=frame, point=point, offset=offset)
              - m.tool_tip(q, tool - 1e-6, frame=frame, point=point, offset=offset)) / 2e-6
        np.testing.assert_allclose(kin.tool_dir, dt, atol=1e-8)
        fd_off = np.stack([(m.tool_tip(q, tool, frame=frame, point=point, offset=offset + e * 1e-6)
                            - m.tool_tip(q, tool, frame=frame, point=point, offset=offset - e * 1e-6)) / 2e-6
                           for e in np.eye(3)], -1)
        np.testing.assert_allclose(kin.rotation, fd_off, atol=1e-8)


@pytest.mark.parametrize("name", TWO_BRANCH + ["flow_xyzcb"])
def test_workpiece_points(machines, name, rng):
    """Table nests fixed in the workpiece frame, in the base frame: closed-form pose, FD Jacobians."""
    m = machines[name]
    q = uniform_commands(m, 30, rng)
    p_wp = rng.uniform(-0.2, 0.2, (30, 3))
    out = m.workpiece_points(q, p_wp)
    T_bw = CLOSED_FORMS[name][1](q) if m.has_workpiece else np.broadcast_to(np.eye(4), (30, 4, 4))
    np.testing.assert_allclose(out.xyz, np.einsum("pij,pj->pi", T_bw[:, :3, :3], p_wp) + T_bw[:, :3, 3], atol=1e-12)
    np.testing.assert_allclose(out.J_q, _fd(lambda x: m.workpiece_points(x, p_wp, False).xyz, q, 1e-6), atol=1e-8)
    np.testing.assert_allclose(out.J_p, _fd(lambda p: m.workpiece_points(q, p, False).xyz, p_wp, 1e-6), atol=1e-8)
    if m.has_workpiece:  # only table axes move a nest
        head = [a.index for a in m.axes if a.side == "head"]
        assert np.all(out.J_q[:, :, head] == 0) and set(m.table_axes) == {a.name for a in m.axes if a.side == "table"}


def test_single_chain_frames_are_one(flow, rng):
    """Without a workpiece, 'workpiece' is the base frame and today's default is unchanged."""
    q = uniform_commands(flow, 10, rng)
    assert flow.default_frame == "base" and not flow.has_workpiece
    a = flow.kinematics(q, 0.2)
    b = flow.kinematics(q, 0.2, frame="workpiece")
    np.testing.assert_array_equal(a.tip, b.tip)
    np.testing.assert_array_equal(a.jacobian, b.jacobian)
    np.testing.assert_allclose(a.tool_dir, -a.rotation[:, :, 2], atol=0)
    np.testing.assert_allclose(flow.workpiece_pose(q), np.broadcast_to(np.eye(4), (10, 4, 4)))


def test_spar_mill_two_mirrored_spindles(machines, rng):
    """Four axes (the mirror joints follow Y, Z, A); spindle_2 is the mirror image of
    spindle in y = 0; a per-row point array picks the spindle of each row."""
    m = machines["spar_mill_23"]
    assert m.axis_names == ["X", "Y", "Z", "A"] and m.tool_links == ("spindle", "spindle_2")
    assert [(j.name, j.axis, j.multiplier) for j in m.mimic_joints] == [("Y_2", "Y", -1.0), ("Z_2", "Z", 1.0),
                                                                         ("A_2", "A", -1.0)]
    q = uniform_commands(m, 40, rng)
    p1, p2 = m.tool_tip(q, 0.2, point=0), m.tool_tip(q, 0.2, point=1)
    np.testing.assert_allclose(p2, p1 * [1, -1, 1], atol=1e-14)
    point = rng.integers(0, 2, 40)
    kin = m.kinematics(q, 0.2, point=point)
    np.testing.assert_allclose(kin.tip, np.where(point[:, None] == 0, p1, p2), atol=1e-15)
    J1, J2 = m.kinematics(q, 0.2, point=0).jacobian, m.kinematics(q, 0.2, point=1).jacobian
    np.testing.assert_allclose(kin.jacobian, np.where(point[:, None, None] == 0, J1, J2), atol=1e-15)
    np.testing.assert_allclose(J2[:, 1], -J1[:, 1], atol=1e-14)  # mirrored in y
    np.testing.assert_allclose(m.full_q(q), q)  # Pinocchio with mimic support: nq = 4


def test_ur5_as_published_loads_with_tool_link(machines, rng):
    """The arm's URDF (no 'spindle') loads with tool_link='tool0'; the tool is along +z
    of the flange; two independent closed forms (DH product, planar) agree with it."""
    path = machines["ur5"].urdf_path
    m = vecpin.Machine.load(path, tool_link="tool0")
    assert m.tool_links == ("tool0",) and m.tool_axis_name == "+z" and m.n_axes == 6
    q = uniform_commands(m, 100, rng)
    t = rng.uniform(0, 0.2, 100)
    np.testing.assert_allclose(m.tool_tip(q, t), ur5_dh(q, t), atol=1e-12)
    np.testing.assert_allclose(ur5_planar(q, t), ur5_dh(q, t), atol=1e-12)
    # the zero pose of the UR5 flange in the controller base frame
    np.testing.assert_allclose(m.tool_tip(np.zeros((1, 6)))[0], [-0.81725, -0.19145, -0.005491], atol=1e-9)
    assert m.layout.startswith("6-axis arm") and m.derived_layout() == "6-axis arm"


def test_ur10_as_published_matches_the_dataset_variant(machines):
    """The bundled UR10 is the CB3 arm: the zero pose from its DH table, and the commanded
    flange of the public tracker dataset (joints (-90, -90, 0, -90, 0, 0) deg, T-Mac centre
    109 mm out of the flange) 1.4273 m high and 0.365141 m off joint 1 (the dataset writes
    x = +0.365141 in ROS's base_link, yawed by pi against the controller base)."""
    m = machines["ur10"]
    assert m.tool_links == ("tool0",) and m.tool_axis_name == "+z"
    assert m.axis_names == ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
                            "wrist_2_joint", "wrist_3_joint"]
    np.testing.assert_allclose(m.tool_tip(np.zeros((1, 6)))[0], [-1.1843, -0.256141, 0.0116], atol=1e-12)
    home = np.radians([[-90.0, -90.0, 0.0, -90.0, 0.0, 0.0]])
    np.testing.assert_allclose(m.tool_tip(home, 0.109)[0], [-0.365141, 0.0, 1.4273], atol=1e-12)


def test_tool_axis_option(flow, rng):
    m = vecpin.Machine.load("flow_xyzcb", tool_axis="+x")
    q = uniform_commands(m, 5, rng)
    kin = m.kinematics(q, 0.3)
    np.testing.assert_allclose(kin.tip, kin.spindle + 0.3 * kin.rotation[:, :, 0], atol=1e-15)
    np.testing.assert_allclose(flow.tool_tip(q, 0.3), kin.spindle - 0.3 * kin.rotation[:, :, 2], atol=1e-15)
    assert m.load_options == {"tool_link": "spindle", "tool_axis": "+x"}


def test_axes_limits_units(flow):
    assert flow.axis_names == ["X", "Y", "Z", "C", "B"]
    assert [a.kind for a in flow.axes] == ["linear"] * 3 + ["rotary"] * 2
    x, c = flow.axis("X"), flow.axis("C")
    assert x.unit == "mm" and c.unit == "deg"
    assert x.lower_user == pytest.approx(-8.1) and x.upper_user == pytest.approx(6101.0)
    assert c.lower_user == pytest.approx(-272.0) and c.upper_user == pytest.approx(272.0)
    assert flow.gauge_offset() == pytest.approx(0.098)
    q_user = np.array([[100.0, 200.0, 300.0, 90.0, -45.0]])
    np.testing.assert_allclose(flow.to_user(flow.to_si(q_user)), q_user)
    np.testing.assert_allclose(flow.to_si(q_user)[0, 3], math.pi / 2)


def test_seed_limits_of_the_new_machines(machines):
    """Seed Table 2.7 (Master Mill) and Table 2.11 (XYZBAW), inches and degrees."""
    inch = 25.4
    seed = {"master_mill": [("X", -325 * inch, 325 * inch), ("Y", -80 * inch, 80 * inch),
                            ("Z", 30 * inch, 110 * inch), ("C", -200, 200), ("A", -110, 110)],
            "production_xyzbaw": [("X", 450 * inch, 1000 * inch), ("Y", 0, 30 * inch), ("Z", 0, 130 * inch),
                                  ("B", -5, 5), ("A", -200, 17), ("W", -15 * inch, 0)]}
    for name, rows in seed.items():
        m = machines[name]
        assert m.axis_names == [r[0] for r in rows]
        np.testing.assert_allclose([(a.lower_user, a.upper_user) for a in m.axes], [r[1:] for r in rows],
                                   rtol=0, atol=1e-6)  # mm or deg


def test_axis_order_rule(machines):
    """Head branch first, then table branch; sides recorded."""
    m = machines["head_table_bc"]
    assert m.axis_names == ["X", "Y", "Z", "B", "C"]
    assert m.head_axes == ["X", "Y", "Z", "B"] and m.table_axes == ["C"]
    assert machines["trunnion_xyzac"].table_axes == ["A", "C"]


def test_pinocchio_order_differs_from_declaration_order_is_handled():
    """Axes come in chain order even when the URDF declares joints in another order."""
    xml = vecpin.Machine.load("flow_xyzcb").urdf_xml
    start = xml.index('  <joint name="B"')
    end = xml.index("</joint>", start) + len("</joint>\n")
    b = xml[start:end]
    xml2 = xml[:start] + xml[end:]
    i = xml2.index('  <joint name="X"')
    xml2 = xml2[:i] + b + xml2[i:]
    m2 = vecpin.Machine.from_urdf_string(xml2)
    m1 = vecpin.Machine.load("flow_xyzcb")
    assert m2.axis_names == ["X", "Y", "Z", "C", "B"]
    q = np.array([[1.0, 0.5, 0.3, 0.7, -0.4]])
    np.testing.assert_allclose(m2.tool_tip(q, 0.2), m1.tool_tip(q, 0.2), atol=1e-14)
    np.testing.assert_allclose(m2.full_q(q)[0, [m2.axis(a).idx_q for a in m2.axis_names]], q[0])


def test_joint_frames_are_the_axis_frames(machines, rng):
    m = machines["trunnion_xyzbc"]
    q = uniform_commands(m, 5, rng)
    F = m.joint_frames(q, "B")
    T = homogeneous(rot("y", q[:, 3]), np.array([0, 0, 0.080]))
    np.testing.assert_allclose(F, T, atol=1e-15)


def test_unknown_machine_name():
    with pytest.raises(vecpin.MachineError, match="bundled"):
        vecpin.Machine.load("no_such_machine")


def test_a_mimicked_drive_off_the_branch_is_an_axis_not_a_fixed_joint():
    """Twin drive: the tool branch runs through Y1, which mimics Y2 on a side branch. Y2 is an
    axis (a campaign column), so no note calls it fixed at 0."""
    lim = "<limit lower='-1' upper='1' effort='1' velocity='1'/>"
    xml = ("<robot name='twin'><link name='base'/><link name='y1'/><link name='y2'/><link name='spindle'/>"
           f"<joint name='Y2' type='prismatic'><parent link='base'/><child link='y2'/><axis xyz='0 1 0'/>{lim}</joint>"
           f"<joint name='Y1' type='prismatic'><parent link='base'/><child link='y1'/><axis xyz='0 1 0'/>{lim}"
           "<mimic joint='Y2'/></joint>"
           f"<joint name='Z' type='prismatic'><parent link='y1'/><child link='spindle'/><axis xyz='0 0 1'/>{lim}</joint>"
           "</robot>")
    m = vecpin.Machine.from_urdf_string(xml)
    assert "Y2" in m.axis_names
    assert not any("fixed at 0" in n and "Y2" in n for n in m.notes)
    assert "fixed at 0" not in m.describe()


def test_tips_of_a_large_campaign_from_kept_placements(machines, monkeypatch):
    """A campaign above KINEMATICS_ROWS: its tips come from the tool link placements kept for
    it (tool_placements), to the last digit of the one-piece kinematics, in the base frame
    with and without a target offset, and relative to the workpiece; a kept answer is a copy."""
    import vecpin.kinematics.axes as axes_module
    import vecpin.kinematics.machine as machine_module
    m = machines["flow_xyzcb"]
    rng = np.random.default_rng(4)
    q = m.lower + rng.random((300, m.n_axes)) * (m.upper - m.lower)
    tool = rng.choice([0.2, 0.3], 300)
    offset = np.array([0.01, -0.02, 0.003])
    whole = m.kinematics(q, tool, jacobian=False, frame="base")
    shifted = m.kinematics(q, tool, jacobian=False, frame="base", offset=offset).tip
    relative = m.kinematics(q, tool, jacobian=False, frame="workpiece").tip
    placed = m.kinematics(q, 0.0, jacobian=False, frame="base")
    for module in (axes_module, machine_module):   # kinematics in pieces of 100 rows
        monkeypatch.setattr(module, "KINEMATICS_ROWS", 100)
    np.testing.assert_array_equal(m.tool_tip(q, tool, frame="base"), whole.tip)
    np.testing.assert_array_equal(m.tool_tip(q, tool, frame="base", offset=offset), shifted)
    np.testing.assert_array_equal(m.tool_tip(q, tool, frame="workpiece"), relative)
    R, o = m.tool_placements(q)
    np.testing.assert_array_equal(R, placed.rotation)
    np.testing.assert_array_equal(o, placed.spindle)
    R[:] = 0.0   # the caller's copy: the kept placements stay
    np.testing.assert_array_equal(m.tool_placements(q)[0], placed.rotation)
