"""A second reader of a machine's URDF: the serial chain as vectorised 4x4 transforms.

Written without Pinocchio (and without vecpin's kinematics) so a simulated true
machine does not share code with the models it judges: the URDF is parsed with the
standard XML library, each joint becomes ``origin (xyz, rpy) @ motion(q)`` and the
chain is multiplied out for N poses at once as (N,4,4) arrays. URDF conventions
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
    """One joint on the base -> spindle path: ``origin`` (4,4) parent -> joint frame,
    ``kind`` "fixed", "prismatic" or "revolute", unit ``axis`` in the joint frame."""

    name: str
    kind: str
    origin: np.ndarray
    axis: np.ndarray


class URDFChain:
    """The base -> ``spindle`` chain of a URDF as 4x4 transforms (SI, base frame).

    ``axis_names``: actuated joints in chain order (the columns of every q array)."""

    def __init__(self, urdf_xml: str, source: str = "<string>"):
        try:
            robot = ET.fromstring(urdf_xml)
        except ET.ParseError as exc:
            raise MachineError(f"{source}: not readable XML ({exc})") from None
        by_child = {}
        for j in robot.findall("joint"):
            by_child[j.find("child").get("link")] = j
        joints, link = [], SPINDLE_LINK
        while link in by_child:
            j = by_child[link]
            joints.append(j)
            link = j.find("parent").get("link")
        if not joints:
            raise MachineError(f"{source}: no joint chain leads to the link '{SPINDLE_LINK}'")
        self.joints: list[ChainJoint] = []
        for j in reversed(joints):
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
            self.joints.append(ChainJoint(j.get("name"), kind, T, axis / np.linalg.norm(axis)))
        self.axis_names = [j.name for j in self.joints if j.kind != "fixed"]

    def spindle_pose(self, q: np.ndarray, errors: list[np.ndarray | None] | None = None) -> np.ndarray:
        """(N,4,4) pose of the spindle (gauge-line) frame in the base frame for commands
        q (N,n) [m, rad]. ``errors[k]``: (N,4,4) transform after axis k's motion, or None."""
        q = np.atleast_2d(np.asarray(q, float))
        N = len(q)
        T = np.broadcast_to(np.eye(4), (N, 4, 4)).copy()
        k = 0
        for j in self.joints:
            T = T @ j.origin
            if j.kind == "fixed":
                continue
            M = np.broadcast_to(np.eye(4), (N, 4, 4)).copy()
            if j.kind == "revolute":
                M[:, :3, :3] = rotation_about(j.axis, q[:, k])
            else:
                M[:, :3, 3] = q[:, k, None] * j.axis
            T = T @ M
            if errors is not None and errors[k] is not None:
                T = T @ errors[k]
            k += 1
        return T

    def tool_tip(self, q: np.ndarray, tool: np.ndarray | float, errors=None) -> tuple[np.ndarray, np.ndarray]:
        """(tip (N,3) [m], unit tool direction (N,3)) in the base frame; the tool of
        length ``tool`` [m] from the gauge line points along -z of the spindle frame."""
        T = self.spindle_pose(q, errors)
        u = -T[:, :3, 2]
        tool = np.broadcast_to(np.asarray(tool, float), (len(T),))
        return T[:, :3, 3] + u * tool[:, None], u
