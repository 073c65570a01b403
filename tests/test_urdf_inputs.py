"""URDFs as users bring them: every bad file gives one clear message (MachineError from
the API, one line and status 2 from `vecpin info`, never a traceback or a crash); tool
links, tool axes, side branches and missing axes are handled with notes."""
import subprocess
import sys

import numpy as np
import pytest

import vecpin
from vecpin.cli import main
from vecpin.errors import InputError, MachineError
from vecpin.simulation.truth import uniform_commands

LIMIT = "<limit lower='-1' upper='1' effort='1' velocity='1'/>"


def robot(*joints: str, links=("base", "spindle")) -> str:
    """A URDF text from joint snippets; links are declared from ``links``."""
    return ("<robot name='r'>" + "".join(f"<link name='{n}'/>" for n in links) + "".join(joints) + "</robot>")


def joint(name, parent, child, jtype="prismatic", axis="<axis xyz='1 0 0'/>", limit=LIMIT, extra=""):
    return (f"<joint name='{name}' type='{jtype}'><parent link='{parent}'/><child link='{child}'/>"
            f"{axis}{limit}{extra}</joint>")


def deep_chain(n: int) -> str:
    links = ["base"] + [f"l{i}" for i in range(1, n)] + ["spindle"]
    joints = [joint(f"j{i}", links[i], links[i + 1]) for i in range(n)]
    return robot(*joints, links=links)


BAD = {  # file name -> (content, message)
    "not_xml.urdf": ("this is not xml <", "not XML"),
    "sdf.urdf": ("<sdf version='1.6'><model name='m'/></sdf>", "root element is <sdf>"),
    "macro.urdf": ("<robot name='r' xmlns:xacro='http://www.ros.org/wiki/xacro'><xacro:include filename='a.xacro'/></robot>",
                   "expand the xacro first (xacro {path} > {stem}_expanded.urdf)"),
    "no_limit.urdf": (robot(joint("X", "base", "spindle", limit="")), "joint 'X' has no <limit>"),
    "zero_axis.urdf": (robot(joint("X", "base", "spindle", axis="<axis xyz='0 0 0'/>")), "joint 'X' has a zero <axis"),
    "continuous.urdf": (robot(joint("C", "base", "spindle", "continuous", limit="")), "continuous"),
    "reserved_x.urdf": (robot(joint("x", "base", "spindle")), "named like the campaign column 'x'"),
    "reserved_tool.urdf": (robot(joint("tool", "base", "spindle")), "named like the campaign column 'tool'"),
    "reserved_temperature.urdf": (robot(joint("temperature", "base", "spindle")), "column 'temperature'"),
    "space.urdf": (robot(joint("X axis", "base", "spindle")), "space, comma or quote"),
    "comma.urdf": (robot(joint("X,1", "base", "spindle")), "space, comma or quote"),
    "quote.urdf": (robot(joint('X"', "base", "spindle").replace("name='X\"'", "name='X&quot;'")), "space, comma or quote"),
    "no_spindle.urdf": (robot(joint("X", "base", "flange_link"), links=("base", "flange_link")),
                        "no link named 'spindle' (the default tool link, on the gauge line); candidate end links: flange_link"),
    "two_parents.urdf": (robot(joint("X", "base", "spindle"), joint("Y", "base", "spindle")), "child of two joints"),
    "two_roots.urdf": (robot(joint("X", "base", "spindle"), links=("base", "spindle", "loose")), "several root links (base, loose)"),
    "bad_mimic.urdf": (robot(joint("X", "base", "spindle", extra="<mimic joint='Q'/>")), "mimics 'Q', which is not a joint"),
    "undeclared_link.urdf": (robot(joint("X", "base", "spindel")), "child link 'spindel' is not declared"),
    "bad_origin.urdf": (robot(joint("X", "base", "spindle", extra="").replace("<axis", "<origin xyz='1 2'/><axis")),
                        "<origin xyz> is '1 2', not 3 numbers"),
    "deep.urdf": (deep_chain(5000), "more than 256 joints"),
}


@pytest.mark.parametrize("fname", sorted(BAD))
def test_bad_urdf_gives_its_message(tmp_path, fname, capsys):
    text, message = BAD[fname]
    path = tmp_path / fname
    path.write_text(text)
    message = message.format(path=path, stem=path.with_suffix(""))
    with pytest.raises(MachineError) as exc:
        vecpin.Machine.load(path)
    assert message in str(exc.value) and str(path) in str(exc.value)
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and err.count("\n") == 1


def test_binary_and_xacro_files(tmp_path, capsys):
    b = tmp_path / "robot.urdf"
    b.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR")
    x = tmp_path / "robot.urdf.xacro"
    x.write_text("<robot/>")
    for path, message in [(b, "binary content"), (x, f"expand the xacro first (xacro {x} > {tmp_path / 'robot.urdf'})")]:
        with pytest.raises(MachineError, match=message.replace("(", r"\(").replace(")", r"\)")):
            vecpin.Machine.load(path)
        assert main(["info", str(path)]) == 2
        assert message in capsys.readouterr().err


def test_deep_chain_does_not_crash_the_interpreter(tmp_path):
    """Pinocchio's recursive parser would overflow the C stack: the depth is checked first."""
    path = tmp_path / "deep.urdf"
    path.write_text(deep_chain(5000))
    r = subprocess.run([sys.executable, "-m", "vecpin", "info", str(path)], capture_output=True, text=True)
    assert r.returncode == 2 and "more than 256 joints" in r.stderr and "Traceback" not in r.stderr
    assert vecpin.Machine.from_urdf_string(deep_chain(200)).n_axes == 200  # a long but sane chain loads


def test_missing_axis_is_the_urdf_default_with_a_note(rng):
    xml = robot(joint("X", "base", "mid", axis=""), joint("Z", "mid", "spindle", axis="<axis xyz='0 0 2'/>"),
                links=("base", "mid", "spindle"))
    m = vecpin.Machine.from_urdf_string(xml)
    assert any("joint 'X' has no <axis>: the URDF default x (1 0 0)" in n for n in m.notes)
    assert any("joint 'Z': <axis xyz> of length 2 normalised" in n for n in m.notes)
    q = np.array([[0.3, 0.4]])
    np.testing.assert_allclose(m.tool_tip(q, 0.1), [[0.3, 0.0, 0.4 - 0.1]], atol=1e-15)
    assert "note: joint 'X' has no <axis>" in m.describe()


def _ur5_with_gripper() -> str:
    xml = vecpin.Machine.load("ur5").urdf_xml
    gripper = ("<link name='gripper'/><link name='finger_l'/><link name='finger_r'/>"
               "<joint name='mount' type='fixed'><parent link='tool0'/><child link='gripper'/>"
               "<origin xyz='0 0 0.05'/></joint>"
               + joint("finger_l_joint", "gripper", "finger_l", axis="<axis xyz='0 1 0'/>",
                       limit="<limit lower='0' upper='0.04' effort='1' velocity='1'/>")
               + joint("finger_r_joint", "gripper", "finger_r", axis="<axis xyz='0 -1 0'/>",
                       limit="<limit lower='0' upper='0.04' effort='1' velocity='1'/>",
                       extra="<mimic joint='finger_l_joint'/>"))
    return xml.replace("</robot>", gripper + "</robot>")


def test_side_branches_are_fixed_with_a_note(machines, rng):
    """A published arm with a gripper: the fingers are off the tool branch."""
    m = vecpin.Machine.from_urdf_string(_ur5_with_gripper(), tool_link="tool0")
    assert m.axis_names == machines["ur5"].axis_names
    assert any("treated as fixed at 0: finger_l_joint, finger_r_joint" in n for n in m.notes)
    q = uniform_commands(m, 10, rng)
    np.testing.assert_allclose(m.tool_tip(q, 0.1), machines["ur5"].tool_tip(q, 0.1), atol=1e-15)
    # the gripper link as tool link: its fixed offset 0.05 m along tool0's z is part of the chain
    g = vecpin.Machine.from_urdf_string(_ur5_with_gripper(), tool_link="gripper", tool_axis="+z")
    np.testing.assert_allclose(g.tool_tip(q, 0.1), machines["ur5"].tool_tip(q, 0.15), atol=1e-14)
    with pytest.raises(MachineError, match="candidate end links: finger_l, finger_r"):
        vecpin.Machine.from_urdf_string(_ur5_with_gripper(), tool_link="tcp")


def test_tool_link_and_axis_options(tmp_path, capsys, machines):
    ur5 = machines["ur5"]
    with pytest.raises(MachineError, match="no link named 'spindle'.*candidate end links: tool0"):
        vecpin.Machine.load(ur5.urdf_path)
    assert main(["info", str(ur5.urdf_path), "--tool-link", "tool0"]) == 0
    out = capsys.readouterr().out
    assert "tool along +z" in out and "82.300 mm" in out and "ROS tool-flange" in out
    assert main(["info", str(ur5.urdf_path), "--tool-link", "tool0", "--tool-axis=-z"]) == 0
    assert "tool along -z" in capsys.readouterr().out
    with pytest.raises(InputError, match="`tool_axis` 'w'"):
        vecpin.Machine.load("flow_xyzcb", tool_axis="w")
    assert main(["info", "flow_xyzcb", "--tool-axis", "w"]) == 2
    assert "--tool-axis 'w'" in capsys.readouterr().err
    with pytest.raises(MachineError, match="'workpiece' is the table frame"):
        vecpin.Machine.load("trunnion_xyzac", tool_link="workpiece")
    # a non-ROS link named as tool link gets the -z default, with a note
    m = vecpin.Machine.load("flow_xyzcb", tool_link="spindle")
    assert m.tool_axis_name == "-z" and not m.notes
    a = vecpin.Machine.load("trunnion_xyzac", tool_link="z_head")
    assert any("tool along -z of 'z_head' (the default" in n for n in a.notes)


def test_spar_mill_tool_points_by_option(machines):
    one = vecpin.Machine.load("spar_mill_23", tool_link="spindle_2")
    assert one.tool_links == ("spindle_2",) and one.axis_names == ["X", "Y", "Z", "A"]  # the sources of Y_2, Z_2, A_2
    q = uniform_commands(one, 20, np.random.default_rng(1))
    np.testing.assert_allclose(one.tool_tip(q, 0.1), machines["spar_mill_23"].tool_tip(q, 0.1, point=1), atol=1e-15)
    np.testing.assert_allclose(one.kinematics(q, 0.1).jacobian, machines["spar_mill_23"].kinematics(q, 0.1, point=1).jacobian,
                               atol=1e-15)
    both = vecpin.Machine.load("spar_mill_23", tool_link="spindle_2,spindle")
    assert both.tool_links == ("spindle_2", "spindle")
    with pytest.raises(InputError, match="tool point"):
        both.tool_tip(np.zeros((2, 4)), point=np.array([0, 2]))


def test_info_lists_bundled_machines_with_layouts(capsys):
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    for name, layout in [("trunnion_xyzac", "XYZAC trunnion (table A carrying C)"),
                         ("flow_xyzcb", "XYZCB gantry, head rotaries C, B"), ("ur5", "6-axis arm"),
                         ("spar_mill_23", "two mirrored spindles"), ("master_mill", "twin-drive X")]:
        line = next(ln for ln in out.splitlines() if ln.split()[:1] == [name])
        assert layout in line
    assert len([ln for ln in out.splitlines() if " axes  " in ln]) == len(vecpin.bundled_machines())


def test_derived_layout_without_a_tag(machines):
    assert machines["trunnion_xyzac"].derived_layout() == "XYZAC, table rotaries A, C"
    assert machines["head_table_bc"].derived_layout() == "XYZBC, table rotaries C, head rotaries B"
    assert machines["spar_mill_23"].derived_layout() == "XYZA, head rotaries A, 2 tool points (spindle, spindle_2)"
