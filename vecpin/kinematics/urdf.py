"""Reading a URDF into a checked kinematic tree, before any C++ parser sees it.

vecpin reads the XML itself (Python's ElementTree) so that every problem a user can
have with a URDF from the internet gets a message that names the joint and says what
to do, instead of a raw parser error or a crash: a ``.xacro`` macro file, a binary
file, a joint without ``<limit>``, a zero ``<axis>``, a missing ``<axis>`` (the URDF
default x is used, with a note), a chain deeper than Pinocchio's recursive parser
survives, links with two parents or no common root.

The result, :class:`UrdfTree`, is a plain description of links and joints in SI
(m, rad): joint origins as 4x4 homogeneous matrices from the parent link frame to the
joint frame, unit joint axes in the joint frame, limits, and ``<mimic>`` rules
(``q_joint = multiplier * q_source + offset``).
"""
from __future__ import annotations

import math
import re
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from vecpin.errors import MachineError, VecpinWarning

#: deepest chain (joints from the root to a link) vecpin accepts; Pinocchio's URDF
#: parser recurses once per link and crashes the interpreter on chains of thousands.
MAX_CHAIN_DEPTH = 256

MOVABLE = ("prismatic", "revolute")
KNOWN_TYPES = ("fixed", "prismatic", "revolute", "continuous", "floating", "planar")


@dataclass(frozen=True)
class UrdfJoint:
    """One URDF joint in SI.

    origin: (4,4) parent link frame -> joint frame (before motion); axis: (3,) unit
    axis in the joint frame; lower/upper: limits [m or rad] (None when the joint has
    none); mimic: (source joint, multiplier, offset [m or rad]) or None.
    """

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    lower: float | None
    upper: float | None
    mimic: tuple[str, float, float] | None
    has_limit: bool


@dataclass
class UrdfTree:
    """Links and joints of a URDF, checked to form one tree.

    ``joints`` keeps the file's declaration order; ``parent_joint[link]`` is the joint
    whose child the link is (absent for the root); ``notes`` collects what was read
    with a default (missing axes, normalised axes) for the user to see.
    """

    name: str
    root: str
    links: list[str]
    joints: dict[str, UrdfJoint]
    parent_joint: dict[str, str]
    notes: list[str]
    layout_tag: str | None

    def path(self, link: str) -> list[str]:
        """Joint names from the root to ``link`` (root first)."""
        out = []
        while link in self.parent_joint:
            j = self.parent_joint[link]
            out.append(j)
            link = self.joints[j].parent
        out.reverse()
        return out

    def leaves(self) -> list[str]:
        """Links that are no joint's parent (the candidate end links), in file order."""
        parents = {j.parent for j in self.joints.values()}
        return [link for link in self.links if link not in parents]


def check_text(data: bytes, source: str) -> str:
    """The URDF text of a file's bytes, or a MachineError for a binary or xacro file."""
    if source.lower().endswith(".xacro"):
        raise MachineError(_xacro_message(source))
    head = data[:65536]
    if b"\x00" in head:
        raise MachineError(f"{source}: not a readable URDF: binary content (a URDF is an XML text file)")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise MachineError(f"{source}: not a readable URDF: not UTF-8 text (byte {exc.start}); "
                           "a URDF is an XML text file") from None
    return text


def _xacro_message(source: str) -> str:
    if source.lower().endswith(".xacro"):
        stem = source[:-len(".xacro")]
        stem = stem if stem.lower().endswith(".urdf") else stem + ".urdf"
    else:  # xacro content in a file named like a URDF
        stem = re.sub(r"\.(urdf|xml)$", "", source, flags=re.IGNORECASE) + "_expanded.urdf"
    return (f"{source}: a xacro macro file, not a URDF: expand the xacro first "
            f"(xacro {source} > {stem})")


def read_urdf(text: str, source: str = "<string>") -> UrdfTree:
    """Parse and check URDF XML text; raise :class:`MachineError` naming the problem."""
    if re.search(r"<xacro:", text[:200000]):  # a macro; ``xmlns:xacro`` alone is left by xacro's own output
        raise MachineError(_xacro_message(source))
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise MachineError(f"{source}: not a readable URDF: not XML ({exc})") from None
    if root.tag != "robot":
        raise MachineError(f"{source}: not a readable URDF: the root element is <{root.tag}>, a URDF's is <robot>")
    notes: list[str] = []
    links: list[str] = []
    for el in root.findall("link"):
        name = el.get("name")
        if not name:
            raise MachineError(f"{source}: a <link> has no name")
        if name in links:
            raise MachineError(f"{source}: link '{name}' is declared twice")
        links.append(name)
    if not links:
        raise MachineError(f"{source}: the URDF has no <link>")
    joints: dict[str, UrdfJoint] = {}
    parent_joint: dict[str, str] = {}
    for el in root.findall("joint"):
        j = _read_joint(el, source, notes)
        if j.name in joints:
            raise MachineError(f"{source}: joint '{j.name}' is declared twice")
        for role, link in (("parent", j.parent), ("child", j.child)):
            if link not in links:
                raise MachineError(f"{source}: joint '{j.name}': {role} link '{link}' is not declared as a <link>")
        if j.child in parent_joint:
            raise MachineError(f"{source}: link '{j.child}' is the child of two joints "
                               f"('{parent_joint[j.child]}' and '{j.name}'); a URDF is a tree")
        joints[j.name] = j
        parent_joint[j.child] = j.name
    roots = [link for link in links if link not in parent_joint]
    if len(roots) != 1:
        what = "no root link (the joints form a loop)" if not roots else f"several root links ({', '.join(roots)})"
        raise MachineError(f"{source}: {what}; a URDF is one tree with one root link")
    _check_depth(links, joints, parent_joint, source)
    for j in joints.values():
        if j.mimic is not None:
            src = j.mimic[0]
            if src not in joints:
                raise MachineError(f"{source}: joint '{j.name}' mimics '{src}', which is not a joint of this URDF")
            if joints[src].type not in MOVABLE:
                raise MachineError(f"{source}: joint '{j.name}' mimics '{src}', which is a {joints[src].type} joint")
            if joints[src].mimic is not None:
                raise MachineError(f"{source}: joint '{j.name}' mimics '{src}', which itself mimics "
                                   f"'{joints[src].mimic[0]}'; let it mimic that joint directly")
    return UrdfTree(root.get("name") or "robot", roots[0], links, joints, parent_joint, notes, _layout_tag(text))


def _check_depth(links, joints, parent_joint, source) -> None:
    """Longest root-to-link chain, iteratively (no recursion), against MAX_CHAIN_DEPTH."""
    depth: dict[str, int] = {}
    for link in links:
        chain = []
        cur = link
        while cur not in depth and cur in parent_joint:
            chain.append(cur)
            cur = joints[parent_joint[cur]].parent
            if len(chain) > len(links):
                raise MachineError(f"{source}: the joints form a loop through link '{link}'; a URDF is a tree")
        d = depth.get(cur, 0)
        for c in reversed(chain):
            d += 1
            depth[c] = d
            if d > MAX_CHAIN_DEPTH:
                raise MachineError(f"{source}: a chain of more than {MAX_CHAIN_DEPTH} joints from the root "
                                   f"(at link '{c}'); vecpin handles machines with up to {MAX_CHAIN_DEPTH}")


def _floats(text: str | None, n: int, what: str, default: tuple[float, ...]) -> np.ndarray:
    if text is None:
        return np.array(default, float)
    parts = text.split()
    try:
        vals = [float(v) for v in parts]
    except ValueError:
        raise MachineError(f"{what} is '{text}', not {n} numbers") from None
    if len(vals) != n:
        raise MachineError(f"{what} is '{text}', not {n} numbers")
    if not all(math.isfinite(v) for v in vals):
        raise MachineError(f"{what} is '{text}', not {n} finite numbers")
    return np.array(vals)


def _number(el, attr: str, what: str) -> float | None:
    v = el.get(attr)
    if v is None:
        return None
    try:
        x = float(v)
    except ValueError:
        raise MachineError(f"{what} {attr}='{v}' is not a number") from None
    if not math.isfinite(x):
        raise MachineError(f"{what} {attr}='{v}' is not finite")
    return x


def rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """URDF fixed-axis roll, pitch, yaw -> rotation Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


MAX_TRAVEL_M = 100.0   # a linear travel beyond this is read as limits written in mm (URDF: m), and warned of


def _read_joint(el, source: str, notes: list[str]) -> UrdfJoint:
    name = el.get("name")
    if not name:
        raise MachineError(f"{source}: a <joint> has no name")
    where = f"{source}: joint '{name}'"
    jtype = el.get("type")
    if jtype not in KNOWN_TYPES:
        raise MachineError(f"{where} has type '{jtype}' (URDF types: {', '.join(KNOWN_TYPES)})")
    parent, child = el.find("parent"), el.find("child")
    if parent is None or child is None or not parent.get("link") or not child.get("link"):
        raise MachineError(f"{where} needs <parent link=.../> and <child link=.../>")
    try:
        o = el.find("origin")
        xyz = _floats(None if o is None else o.get("xyz"), 3, "<origin xyz>", (0.0, 0.0, 0.0))
        rpy = _floats(None if o is None else o.get("rpy"), 3, "<origin rpy>", (0.0, 0.0, 0.0))
        a = el.find("axis")
        axis = _floats(None if a is None else a.get("xyz"), 3, "<axis xyz>", (1.0, 0.0, 0.0))
    except MachineError as exc:
        raise MachineError(f"{where}: {exc}") from None
    origin = np.eye(4)
    origin[:3, :3], origin[:3, 3] = rpy_matrix(rpy), xyz
    lower = upper = None
    limit = el.find("limit")
    if jtype in MOVABLE or jtype == "continuous":
        if el.find("axis") is None:
            notes.append(f"joint '{name}' has no <axis>: the URDF default x (1 0 0) is used "
                         "(write <axis xyz=\"1 0 0\"/> to make it explicit)")
        norm = float(np.linalg.norm(axis))
        if norm < 1e-9:
            raise MachineError(f"{where} has a zero <axis xyz>; give the direction of motion, e.g. <axis xyz=\"0 0 1\"/>")
        if abs(norm - 1.0) > 1e-9:
            notes.append(f"joint '{name}': <axis xyz> of length {norm:g} normalised to a unit vector")
        axis = axis / norm
        if jtype in MOVABLE:
            if limit is None:
                raise MachineError(f"{where} has no <limit>: a {jtype} joint needs "
                                   f"<limit lower=\"..\" upper=\"..\" effort=\"..\" velocity=\"..\"/> "
                                   f"({'m' if jtype == 'prismatic' else 'rad'})")
            lower = _number(limit, "lower", f"{where}: <limit>")
            upper = _number(limit, "upper", f"{where}: <limit>")
            if jtype == "prismatic" and lower is not None and upper is not None and upper - lower > MAX_TRAVEL_M:
                warnings.warn(VecpinWarning(
                    f"{where}: <limit> lower {lower:g} upper {upper:g} is a travel of {upper - lower:g} m; URDF "
                    f"limits are metres: a travel of {upper - lower:g} mm is written {(upper - lower) / 1000:g}"),
                    stacklevel=2)
    mimic = None
    m = el.find("mimic")
    if m is not None and jtype in MOVABLE:
        if not m.get("joint"):
            raise MachineError(f"{where}: <mimic> needs joint=\"...\"")
        mult = _number(m, "multiplier", f"{where}: <mimic>")
        off = _number(m, "offset", f"{where}: <mimic>")
        mimic = (m.get("joint"), 1.0 if mult is None else mult, 0.0 if off is None else off)
    return UrdfJoint(name, jtype, parent.get("link"), child.get("link"), origin, axis, lower, upper, mimic,
                     limit is not None)


def _layout_tag(text: str) -> str | None:
    """The text after ``layout:`` on a line of an XML comment, if the URDF has one."""
    for comment in re.findall(r"<!--(.*?)-->", text, flags=re.DOTALL):
        m = re.search(r"^\s*layout:\s*(.+?)\s*$", comment, flags=re.IGNORECASE | re.MULTILINE)
        if m:
            return m.group(1)
    return None
