"""A second reader of a machine's URDF: its branches as vectorised 4x4 transforms.

Written without Pinocchio (and without vecpin's kinematics) so a simulated true
machine does not share code with the models it judges: the URDF is parsed with the
standard XML library, each joint becomes ``origin (xyz, rpy) @ motion(q)`` and each
path from the root link (to the tool links, to the workpiece link of a table machine)
is multiplied out for N poses at once as (N,4,4) arrays; a ``<mimic>`` joint follows
its source (``multiplier * q + offset``, the URDF specification). URDF conventions
(ROS REP 103 / the URDF joint specification): ``rpy`` is roll about x, then pitch
about y, then yaw about z, all about the fixed parent axes, so R = Rz(yaw) Ry(pitch)
Rx(roll); a revolute joint turns about its unit ``axis`` (default x) by q [rad],
a prismatic joint moves along it by q [m]; a missing ``origin`` is the identity.

Error transforms enter as exact 4x4 matrices right after an axis' motion (in that
axis' moving frame), which is where vecpin's 6-DoF model puts them too.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from vecpin.errors import MachineError

SPINDLE_LINK = "spindle"  # the gauge-line link; the tool points along its -z


def rotation_about(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rodrigues: (N,3,3) rotations by ``angle`` (N,) [rad] about the unit ``axis`` (3,) or (N,3)."""
    angle = np.asarray(angle, float)
    k = np.broadcast_to(np.asarray(axis, float), angle.shape + (3,))
    K = np.zeros(angle.shape + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -k[..., 2], k[..., 1], -k[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = k[..., 2], -k[..., 1], k[..., 0]
    s, c = np.sin(angle)[..., None, None], np.cos(angle)[..., None, None]
    return np.eye(3) + s * K + (1 - c) * (K @ K)


def rotation_vector(v: np.ndarray) -> np.ndarray:
    """(N,3,3) exact rotations of rotation vectors v (N,3) [rad] (angle |v| about v/|v|)."""
    v = np.asarray(v, float)
    angle = np.linalg.norm(v, axis=-1)
    safe = np.where(angle > 0, angle, 1.0)
    axis = v / safe[..., None]
    axis[angle == 0] = (1.0, 0.0, 0.0)
    return rotation_about(axis, angle)


def rpy_matrix(rpy) -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw [rad] -> 3x3 rotation Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def error_transform(delta: np.ndarray, eps: np.ndarray) -> np.ndarray:
    """(N,4,4) exact error transforms [[exp(eps), delta], [0, 1]]: translation delta [m]
    and rotation vector eps [rad], both (N,3) in the moving frame they follow."""
    E = np.zeros(delta.shape[:-1] + (4, 4))
    E[..., :3, :3] = rotation_vector(eps)
    E[..., :3, 3] = delta
    E[..., 3, 3] = 1.0
    return E


@dataclass(frozen=True)
class ChainJoint:
    """One joint on a path from the base: ``origin`` (4,4) parent -> joint frame,
    ``kind`` "fixed", "prismatic" or "revolute", unit ``axis`` in the joint frame;
    ``mimic``: (source joint, multiplier, offset) for a joint that follows another."""

    name: str
    kind: str
    origin: np.ndarray
    axis: np.ndarray
    mimic: tuple[str, float, float] | None = None


class URDFChain:
    """The URDF's paths from the root link to the tool links and the workpiece, as 4x4
    transforms (SI, base frame).

    ``tool_links``: the links whose origin the tool hangs from (default ``spindle``);
    ``tool_axis`` (3,): the tool direction in those links (default -z); ``workpiece``:
    the table frame link (default ``workpiece`` when the URDF has it); ``axis_names``:
    the column order of every q array (default: the actuated joints on the paths in path
    order, tool links first). A ``<mimic>`` joint moves by ``multiplier * q_source +
    offset``; joints on no path are ignored (fixed)."""

    def __init__(self, urdf_xml: str, source: str = "<string>", *, tool_links=(SPINDLE_LINK,),
                 tool_axis=(0.0, 0.0, -1.0), workpiece: str | None = "workpiece", axis_names=None):
        try:
            robot = ET.fromstring(urdf_xml)
        except ET.ParseError as exc:
            raise MachineError(f"{source}: not readable XML ({exc})") from None
        self._by_child = {j.find("child").get("link"): j for j in robot.findall("joint")}
        links = {lk.get("name") for lk in robot.findall("link")}
        self.tool_links = tuple(tool_links)
        self.tool_axis = np.asarray(tool_axis, float)
        self.workpiece = workpiece if workpiece in links else None
        self.paths: dict[str, list[ChainJoint]] = {}
        for link in self.tool_links + ((self.workpiece,) if self.workpiece else ()):
            self.paths[link] = self._path(link, source)
        order = []
        for link in self.paths:
            for j in self.paths[link]:
                a = j.mimic[0] if j.mimic else j.name
                if j.kind != "fixed" and a not in order:
                    order.append(a)
        self.axis_names = list(axis_names) if axis_names is not None else order
        self._column = {a: k for k, a in enumerate(self.axis_names)}
        self.joints = self.paths[self.tool_links[0]]  # the first tool link's chain

    def _path(self, link: str, source: str) -> list[ChainJoint]:
        raw = []
        while link in self._by_child:
            j = self._by_child[link]
            raw.append(j)
            link = j.find("parent").get("link")
        if not raw:
            raise MachineError(f"{source}: no joint chain leads to the link '{link}'")
        out = []
        for j in reversed(raw):
            kind = j.get("type")
            if kind not in ("fixed", "prismatic", "revolute"):
                raise MachineError(f"{source}: joint '{j.get('name')}' of type '{kind}' is not a machine axis")
            o = j.find("origin")
            T = np.eye(4)
            if o is not None:
                T[:3, :3] = rpy_matrix([float(v) for v in o.get("rpy", "0 0 0").split()])
                T[:3, 3] = [float(v) for v in o.get("xyz", "0 0 0").split()]
            a = j.find("axis")
            axis = np.array([float(v) for v in a.get("xyz").split()]) if a is not None else np.array([1.0, 0.0, 0.0])
            m = j.find("mimic")
            mimic = None if m is None else (m.get("joint"), float(m.get("multiplier", "1")), float(m.get("offset", "0")))
            out.append(ChainJoint(j.get("name"), kind, T, axis / np.linalg.norm(axis), mimic))
        return out

    def pose(self, link: str, q: np.ndarray, errors: dict | None = None) -> np.ndarray:
        """(N,4,4) pose of ``link`` in the base frame for commands q (N,n) [m, rad].
        ``errors[joint name]``: (N,4,4) transform right after that joint's motion."""
        q = np.atleast_2d(np.asarray(q, float))
        N = len(q)
        T = np.broadcast_to(np.eye(4), (N, 4, 4)).copy()
        for j in self.paths[link]:
            T = T @ j.origin
            if j.kind == "fixed":
                continue
            if j.mimic is None:
                v = q[:, self._column[j.name]]
            else:
                v = j.mimic[1] * q[:, self._column[j.mimic[0]]] + j.mimic[2]
            M = np.broadcast_to(np.eye(4), (N, 4, 4)).copy()
            if j.kind == "revolute":
                M[:, :3, :3] = rotation_about(j.axis, v)
            else:
                M[:, :3, 3] = v[:, None] * j.axis
            T = T @ M
            if errors and errors.get(j.name) is not None:
                T = T @ errors[j.name]
        return T

    def _by_axis(self, errors):
        if errors is None or isinstance(errors, dict):
            return errors
        return {a: e for a, e in zip(self.axis_names, errors)}

    def tool_tip(self, q: np.ndarray, tool: np.ndarray | float, errors=None, *, point: int = 0,
                 offset: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(tip (N,3) [m], unit tool direction (N,3)) in the base frame; the tool of
        length ``tool`` [m] points along ``tool_axis`` of tool link ``point``; ``offset``
        (3,) or (N,3) [m] a further target offset in that link's frame. ``errors``: a
        list per axis or a dict per joint name of (N,4,4) transforms."""
        T = self.pose(self.tool_links[point], q, self._by_axis(errors))
        u = T[:, :3, :3] @ self.tool_axis
        tool = np.broadcast_to(np.asarray(tool, float), (len(T),))
        tip = T[:, :3, 3] + u * tool[:, None]
        if offset is not None:
            tip = tip + np.einsum("pij,pj->pi", T[:, :3, :3], np.broadcast_to(np.asarray(offset, float), tip.shape))
        return tip, u
