"""Loading a machine: a URDF tree -> its Pinocchio model, tool links, workpiece and axes.

What :class:`~vecpin.kinematics.machine.Machine` is built from, found once when it is
loaded (its kinematics are :mod:`vecpin.kinematics.machine`'s):

* the **tool links**: ``spindle`` by default (plus ``spindle_2``, ``spindle_3``, ... when
  present) or the links named, with the **tool axis** of the first one (-z by default;
  +z of ``tool0`` and +x of ``flange``, the ROS-Industrial convention);
* the **workpiece** link, when the tree has one (the table branch);
* the **Pinocchio model** of the checked URDF text, ``<mimic>`` joints as Pinocchio's
  mimic joints when it can build them;
* the **axes**: the independent prismatic and revolute joints on the branches to the
  tool links and the workpiece, in path order, each with its side (head, table or both),
  and the ``<mimic>`` joints that follow them;
* the **notes** on what was assumed (the tool axis, joints off the branches fixed at 0,
  mimic joints Pinocchio could not build), for :attr:`Machine.notes`.

Everything is checked here: a bad URDF, an unknown tool link or an axis without finite
limits raises a :class:`~vecpin.errors.MachineError` naming the file and the joint or link.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
import pinocchio as pin

from vecpin.errors import InputError, MachineError
from vecpin.kinematics.axes import (BUNDLED_OPTIONS, ROS_FLANGE_LINKS, SPINDLE_LINK, WORKPIECE_LINK, Axis,
                                    MimicJoint, _axis_name, _bundled_path, _check_axis_name, bundled_machines,
                                    check_cell_names, parse_tool_axis)
from vecpin.kinematics.urdf import MOVABLE, UrdfTree, check_text, read_urdf


@dataclass
class MachineParts:
    """A loaded URDF: what :class:`~vecpin.kinematics.machine.Machine` is made of.

    ``tool_axis``: (3,) unit vector in the tool link frame; ``mimic_in_model``: the
    ``<mimic>`` joints are Pinocchio mimic joints of ``model`` (else ordinary joints that
    vecpin sets from their source axis); ``notes``: what was assumed, in order."""

    tree: UrdfTree
    notes: list[str]
    tool_links: tuple[str, ...]
    tool_axis: np.ndarray
    tool_axis_name: str
    workpiece_link: str | None
    model: pin.Model
    mimic_in_model: bool
    axes: tuple[Axis, ...]
    mimic_joints: tuple[MimicJoint, ...]


def machine_parts(urdf_xml: str, source: str, tool_link: str | Sequence[str] | None = None,
                  tool_axis: str | None = None) -> MachineParts:
    """The parts of the machine in ``urdf_xml`` (``source`` names it in messages)."""
    tree = read_urdf(urdf_xml, source)  # checks everything before Pinocchio's parser sees it
    notes: list[str] = list(tree.notes)
    tool_links = check_cell_names(_tool_links(tree, source, tool_link), "tool link", source)
    axis = _tool_axis(tool_links[0], tool_axis, notes)
    workpiece_link = WORKPIECE_LINK if WORKPIECE_LINK in tree.links else None
    if workpiece_link in tool_links:
        raise MachineError(f"{source}: '{WORKPIECE_LINK}' is the table frame, it cannot be a tool link")
    model, mimic_in_model = _pinocchio_model(urdf_xml, source, tree, notes)
    axes, mimic_joints = _axes(tree, source, model, tool_links, workpiece_link, notes)
    return MachineParts(tree, notes, tool_links, axis, _axis_name(axis), workpiece_link, model, mimic_in_model,
                        axes, mimic_joints)


def urdf_file_text(path: Path) -> str:
    """The checked text of a URDF file (a xacro file, a missing or unreadable file: a message)."""
    if path.suffix.lower() == ".xacro":
        check_text(b"", str(path))  # raises the xacro message
    if not path.is_file():
        raise MachineError(f"{path}: no such URDF file")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise MachineError(f"{path}: cannot read the file ({exc.strerror})") from None
    return check_text(data, str(path))


def bundled_file(name: str, tool_link, tool_axis) -> tuple[Path, str | None, str | None, str | None]:
    """(URDF path, tool link, tool axis, note) of a bundled machine: its own defaults where
    ``tool_link`` / ``tool_axis`` are not given, and a note when the tool link is its default."""
    bundled = _bundled_path(name)
    if bundled is None:
        raise MachineError(f"'{name}' is neither a URDF file nor a bundled machine "
                           f"(bundled: {', '.join(bundled_machines())})")
    defaults = BUNDLED_OPTIONS.get(name, {})
    note = None
    if tool_link is None and "tool_link" in defaults:
        note = f"tool link '{defaults['tool_link']}': the bundled default for this machine (its URDF has no 'spindle')"
    return bundled, tool_link or defaults.get("tool_link"), tool_axis or defaults.get("tool_axis"), note


def _tool_links(tree: UrdfTree, source: str, tool_link) -> tuple[str, ...]:
    """The tool links: the ones named (a comma-separated string or a sequence), else ``spindle``, ``spindle_2``, ..."""
    if tool_link is None:
        names = [SPINDLE_LINK]
        k = 2
        while f"{SPINDLE_LINK}_{k}" in tree.links:
            names.append(f"{SPINDLE_LINK}_{k}")
            k += 1
    elif isinstance(tool_link, str):
        names = [s.strip() for s in tool_link.split(",")]
    else:
        names = [str(s).strip() for s in tool_link]
    if not names or any(not n for n in names):
        raise InputError(f"`tool_link` '{tool_link}': give a link name (or several, comma-separated)")
    if len(set(names)) != len(names):
        raise InputError(f"`tool_link` '{tool_link}': a link is named twice")
    for n in names:
        if n not in tree.links:
            leaves = [lk for lk in tree.leaves() if lk != WORKPIECE_LINK]
            default = " (the default tool link, on the gauge line)" if tool_link is None else ""
            raise MachineError(
                f"{source}: no link named '{n}'{default}; candidate end links: {', '.join(leaves)}; "
                "name the tool link with `tool_link` NAME")
    return tuple(names)


def _tool_axis(link: str, tool_axis: str | None, notes: list[str]) -> np.ndarray:
    """(3,) tool direction in the frame of the tool link ``link``: the one given, else its default (a note)."""
    if tool_axis is None:
        if link in ROS_FLANGE_LINKS:  # ROS-Industrial: tool0's +z and flange's +x point out of the flange
            tool_axis = "+x" if link == "flange" else "+z"
            notes.append(f"tool along {tool_axis} of '{link}' (ROS tool-flange convention of ROS-Industrial: "
                         f"{tool_axis} out of the flange; `tool_axis` to change)")
        else:
            tool_axis = "-z"
            if not link.startswith(SPINDLE_LINK):
                notes.append(f"tool along -z of '{link}' (the default; `tool_axis` if it points elsewhere)")
    return parse_tool_axis(tool_axis)


def _pinocchio_model(urdf_xml: str, source: str, tree: UrdfTree, notes: list[str]) -> tuple[pin.Model, bool]:
    """(the URDF as a Pinocchio model, its ``<mimic>`` joints are Pinocchio mimic joints):
    mimic joints as Pinocchio's when it can build them, else as ordinary joints that
    vecpin sets from their source (a note)."""
    mimic_in_model = any(j.mimic is not None for j in tree.joints.values())
    try:
        model = pin.buildModelFromXML(urdf_xml, mimic=True) if mimic_in_model else pin.buildModelFromXML(urdf_xml)
        return model, mimic_in_model
    except Exception as exc:  # pinocchio raises RuntimeError/ValueError with its own text
        if not mimic_in_model:
            raise MachineError(f"{source}: not a readable URDF ({exc})") from None
        reason = str(exc)
    try:
        model = pin.buildModelFromXML(urdf_xml)
    except Exception as exc:
        raise MachineError(f"{source}: not a readable URDF ({exc})") from None
    notes.append(f"Pinocchio could not build the <mimic> joints ({reason}); they are ordinary joints "
                 "of its model that vecpin sets from their source axis (multiplier * source + offset)")
    return model, False


def _branches(tree: UrdfTree, source: str, tool_links: tuple[str, ...],
              workpiece_link: str | None) -> tuple[list[str], set[str], set[str]]:
    """(the joints on the paths to the tool links and the workpiece, in path order; those on a
    tool link's path; those on the workpiece's path), each checked to be an axis or fixed."""
    targets = list(tool_links) + ([workpiece_link] if workpiece_link else [])
    on_branch: list[str] = []
    head: set[str] = set()
    for t in targets:
        for jn in tree.path(t):
            if t != workpiece_link:
                head.add(jn)
            if jn not in on_branch:
                on_branch.append(jn)
    table = set(tree.path(workpiece_link)) if workpiece_link else set()
    for jn in on_branch:
        j = tree.joints[jn]
        if j.type == "continuous":
            raise MachineError(f"{source}: joint '{jn}' is continuous, not a 1-DoF axis with limits "
                               "(a URDF 'continuous' joint: declare it 'revolute' with wide limits)")
        if j.type not in MOVABLE + ("fixed",):
            raise MachineError(f"{source}: joint '{jn}' is a {j.type} joint; a machine axis is "
                               "prismatic or revolute (or fixed)")
    if not any(tree.joints[jn].type in MOVABLE for jn in on_branch):
        raise MachineError(f"{source}: no actuated joint between the base and "
                           f"{' / '.join(repr(t) for t in targets)}")
    return on_branch, head, table


def _axes(tree: UrdfTree, source: str, model: pin.Model, tool_links: tuple[str, ...], workpiece_link: str | None,
          notes: list[str]) -> tuple[tuple[Axis, ...], tuple[MimicJoint, ...]]:
    """Axes in vecpin's order (with their sides), mimic joints; a note on joints off the branches."""
    on_branch, head, table = _branches(tree, source, tool_links, workpiece_link)
    # axes: independent movable joints in path order; a mimic joint brings in its source axis
    axis_joints: list[str] = []
    for jn in on_branch:
        j = tree.joints[jn]
        if j.type in MOVABLE:
            a = jn if j.mimic is None else j.mimic[0]
            if a not in axis_joints:
                axis_joints.append(a)
            if jn in head:
                head.add(a)
            if jn in table:
                table.add(a)
    axes = []
    for k, jn in enumerate(axis_joints):
        j = tree.joints[jn]
        _check_axis_name(jn, source)
        if j.lower is None or j.upper is None or not j.upper > j.lower:
            raise MachineError(f"{source}: joint '{jn}' needs finite limits with lower < upper "
                               f"(<limit lower=\"{j.lower}\" upper=\"{j.upper}\">)")
        jid = model.getJointId(jn) if model.existJointName(jn) else -1
        idx_q = model.joints[jid].idx_q if jid >= 0 else -1
        side = "both" if (jn in head and jn in table) else ("table" if jn in table else "head")
        axes.append(Axis(jn, "linear" if j.type == "prismatic" else "rotary", float(j.lower), float(j.upper),
                         tuple(float(v) for v in j.axis), k, idx_q, jid, side))
    mimics = [MimicJoint(jn, tree.joints[jn].mimic[0], tree.joints[jn].mimic[1], tree.joints[jn].mimic[2])
              for jn in on_branch if tree.joints[jn].type in MOVABLE and tree.joints[jn].mimic is not None]
    off_branch = [jn for jn, j in tree.joints.items() if jn not in on_branch + axis_joints and j.type != "fixed"]
    if off_branch:
        notes.append(f"joints off the tool and workpiece branches are treated as fixed at 0: {', '.join(off_branch)}")
    return tuple(axes), tuple(mimics)
