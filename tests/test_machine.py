"""Nominal kinematics of every bundled machine against independent closed forms
and finite differences."""
import math

import numpy as np
import pytest
import yourdfpy

import vecpin
from vecpin.errors import MachineError
from vecpin.kinematics.machine import bundled_machines
from vecpin.simulation.truth import uniform_commands


def trans(x, y, z):
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def rot(axis, a):
    c, s = math.cos(a), math.sin(a)
    T = np.eye(4)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    T[i, i], T[i, j], T[j, i], T[j, j] = c, -s, s, c
    return T


def flow_closed_form(q, L):
    """Paper I eq. 20-21: F = T_X T_Y T_Z T_C T_B, T_B carrying T_offset = 98 mm;
    the tool tip is a further L along -z."""
    x, y, z, c, b = q
    T_B = np.array([[math.cos(b), 0, math.sin(b), -0.098 * math.sin(b)],
                    [0, 1, 0, 0],
                    [-math.sin(b), 0, math.cos(b), -0.098 * math.cos(b)],
                    [0, 0, 0, 1]])
    F = trans(x, 0, 0) @ trans(0, y, 0) @ trans(0, 0, z) @ rot("z", c) @ T_B
    return (F @ np.array([0, 0, -L, 1]))[:3]


CLOSED_FORMS = {
    "flow_xyzcb": flow_closed_form,
    "cincinnati_20v": lambda q, L: (trans(*q[:3]) @ rot("x", q[3]) @ rot("y", q[4]) @ np.array([0, 0, -0.250 - L, 1]))[:3],
    "snk_120v": lambda q, L: (trans(*q[:3]) @ rot("x", q[3]) @ rot("y", q[4]) @ np.array([0, 0, -0.300 - L, 1]))[:3],
    "ingersoll_xyzca": lambda q, L: (trans(*q[:3]) @ rot("z", q[3]) @ rot("x", q[4]) @ np.array([0, 0, -0.450 - L, 1]))[:3],
}


def test_every_bundled_machine_has_a_closed_form():
    assert set(bundled_machines()) == set(CLOSED_FORMS)


@pytest.mark.parametrize("name", sorted(CLOSED_FORMS))
def test_tool_tip_matches_closed_form(machines, name, rng):
    m = machines[name]
    q = uniform_commands(m, 50, rng)
    tool = rng.uniform(0.0, 0.4, 50)
    tip = m.tool_tip(q, tool)
    expected = np.array([CLOSED_FORMS[name](qi, Li) for qi, Li in zip(q, tool)])
    np.testing.assert_allclose(tip, expected, atol=1e-12)


@pytest.mark.parametrize("name", sorted(CLOSED_FORMS))
def test_tool_tip_matches_yourdfpy(machines, name, rng):
    """A second, independent URDF reader agrees on the spindle pose."""
    m = machines[name]
    urdf = yourdfpy.URDF.load(str(m.urdf_path), load_meshes=False, build_collision_scene_graph=False)
    q = uniform_commands(m, 5, rng)
    kin = m.kinematics(q, 0.0, jacobian=False)
    for qi, p, R in zip(q, kin.tip, kin.rotation):
        urdf.update_cfg(dict(zip(m.axis_names, qi)))
        T = urdf.get_transform("spindle", "base")
        np.testing.assert_allclose(T[:3, 3], p, atol=1e-12)
        np.testing.assert_allclose(T[:3, :3], R, atol=1e-12)


@pytest.mark.parametrize("name", sorted(CLOSED_FORMS))
def test_jacobian_matches_finite_differences(machines, name, rng):
    m = machines[name]
    q = uniform_commands(m, 20, rng)
    tool = rng.uniform(0.1, 0.4, 20)
    J = m.kinematics(q, tool).jacobian
    h = 1e-6
    for k in range(m.n_axes):
        dq = np.zeros(m.n_axes)
        dq[k] = h
        fd = (m.tool_tip(q + dq, tool) - m.tool_tip(q - dq, tool)) / (2 * h)
        np.testing.assert_allclose(J[:, :, k], fd, atol=1e-8)


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


def test_pinocchio_order_differs_from_declaration_order_is_handled():
    """Axes come in chain order even when the URDF declares joints in another order."""
    xml = vecpin.Machine.load("flow_xyzcb").urdf_xml
    # move the B joint declaration before X: chain order must stay X Y Z C B
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


@pytest.mark.parametrize("xml, message", [
    ("<robot name='r'><link name='base'/></robot>", "no link named 'spindle'"),
    ("not xml at all", "not a readable URDF"),
    ("""<robot name='r'><link name='base'/><link name='spindle'/>
        <joint name='c' type='continuous'><parent link='base'/><child link='spindle'/><axis xyz='0 0 1'/></joint></robot>""",
     "continuous"),
    ("""<robot name='r'><link name='base'/><link name='spindle'/><link name='arm'/>
        <joint name='x' type='prismatic'><parent link='base'/><child link='spindle'/><axis xyz='1 0 0'/>
          <limit lower='0' upper='1' effort='1' velocity='1'/></joint>
        <joint name='y' type='prismatic'><parent link='base'/><child link='arm'/><axis xyz='0 1 0'/>
          <limit lower='0' upper='1' effort='1' velocity='1'/></joint></robot>""", "not on the chain"),
])
def test_bad_urdf_is_rejected_with_a_clear_message(xml, message):
    with pytest.raises(MachineError, match=message):
        vecpin.Machine.from_urdf_string(xml)


def test_unknown_machine_name():
    with pytest.raises(MachineError, match="bundled"):
        vecpin.Machine.load("no_such_machine")
