"""Vectorised forward kinematics and Jacobians of a machine's kinematic tree.

A :class:`KinematicTree` holds only the *moving* joints on the branches that matter
(base -> each tool link, base -> ``workpiece``); fixed joints are folded into the
constant placements. Every moving joint ("node") is driven by one axis command:
``value = multiplier * q[source] + offset`` (an independent axis has multiplier 1 and
offset 0; a URDF ``<mimic>`` joint follows its source axis).

For N poses at once (numpy, no loop over poses), :meth:`KinematicTree.forward` gives
every node's frame in the base frame after its motion, optionally followed by a 6-DoF
error transform ``E = (exp3(eps), delta)`` in that moving frame (seed Paper I eq. 3).

Jacobians use one fact: a change of any parameter (an axis command, an error
component) moves everything downstream of its node as a rigid body with a twist
``(v0, w)`` written at the base origin, so a point ``x`` carried by a frame downstream
moves with ``v0 + w x x``; a point carried by a frame that is not downstream does not
move. The point of the tool relative to the workpiece therefore has the columns of
the tool's point velocity minus those of the workpiece's, rotated into the workpiece
frame (shared nodes cancel).

Everything is SI (m, rad) in the base frame (the URDF root link).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from vecpin.kinematics.so3 import exp3_and_right_jacobian, skew


@dataclass(frozen=True)
class Node:
    """A moving joint on the branches.

    parent: index of the parent node (-1: the base); placement: (4,4) from the parent
    node's frame (after its motion and error transform) to this joint's frame before
    motion; kind: "linear" or "rotary"; axis: (3,) unit axis in the joint frame;
    source/multiplier/offset: value = multiplier * q[:, source] + offset [m or rad].
    """

    name: str
    parent: int
    placement: np.ndarray
    kind: str
    axis: np.ndarray
    source: int
    multiplier: float = 1.0
    offset: float = 0.0


class Poses(NamedTuple):
    """Frames of every node for N poses, base frame, SI; one array per node.

    A node's array is (3,3)/(3,) when it is the same for every pose (no rotary joint or
    error above it), else (N,3,3)/(N,3). R, p: after the joint's motion and its error
    transform; R_motion, p_motion: after the motion, before the error transform (the
    same objects as R, p without errors); axis: joint axes in the base frame; R_error,
    Jr_eps: (N,M,3,3) exp3(eps) and its right Jacobian (None without errors); n: N.
    """

    R: list
    p: list
    R_motion: list
    p_motion: list
    axis: list
    R_error: np.ndarray | None
    Jr_eps: np.ndarray | None
    n: int


class KinematicTree:
    """Moving joints in topological order (parents first) and named frames on them.

    frames: link name -> (node index or -1, (4,4) constant placement from the node's
    frame to the link frame).
    """

    def __init__(self, nodes: list[Node], frames: dict[str, tuple[int, np.ndarray]], n_axes: int):
        self.nodes = nodes
        self.frames = frames
        self.n_axes = n_axes
        M = len(nodes)
        anc = np.zeros((M, M), bool)  # anc[i, j]: node j is node i or one of its ancestors
        for i, nd in enumerate(nodes):
            anc[i, i] = True
            if nd.parent >= 0:
                anc[i] |= anc[nd.parent]
        self.ancestors = anc
        D = np.zeros((M, n_axes))  # d value_i / d q_k
        for i, nd in enumerate(nodes):
            D[i, nd.source] = nd.multiplier
        self.drive = D
        self._K = [skew(nd.axis) for nd in nodes]
        self._K2 = [k @ k for k in self._K]
        self._rotary = np.array([nd.kind == "rotary" for nd in nodes], bool)
        self._eye_rot = [np.array_equal(nd.placement[:3, :3], _EYE) for nd in nodes]
        self._zero_t = [not np.any(nd.placement[:3, 3]) for nd in nodes]
        self._principal = []
        for nd in nodes:
            k = int(np.argmax(np.abs(nd.axis)))
            exact = abs(abs(nd.axis[k]) - 1.0) < 1e-15 and np.count_nonzero(nd.axis) == 1
            self._principal.append((k, float(np.sign(nd.axis[k]))) if exact else None)

    # ------------------------------------------------------------------ structure
    def mask(self, link: str) -> np.ndarray:
        """(M,) which nodes move the frame ``link`` (its node and the node's ancestors)."""
        node = self.frames[link][0]
        return self.ancestors[node].copy() if node >= 0 else np.zeros(len(self.nodes), bool)

    def gains(self, link: str) -> np.ndarray:
        """(M, n) d value_node / d q_axis for the nodes that move ``link`` (zero elsewhere)."""
        return self.drive * self.mask(link)[:, None]

    # ------------------------------------------------------------------ kinematics
    def forward(self, q: np.ndarray, delta: np.ndarray | None = None, eps: np.ndarray | None = None) -> Poses:
        """Node frames for N poses: q (N,n) [m, rad]; delta, eps (N,M,3) per-node
        error translations [m] and rotation vectors [rad] in the node's moving frame, or None."""
        N = q.shape[0]
        R, p, Rm, pm, A = [], [], [], [], []
        RE, Jr = exp3_and_right_jacobian(eps) if delta is not None else (None, None)
        for i, nd in enumerate(self.nodes):
            if nd.parent < 0:
                Rp, pp = _EYE, _ZERO
            else:
                Rp, pp = R[nd.parent], p[nd.parent]
            R_pre = Rp if self._eye_rot[i] else Rp @ nd.placement[:3, :3]
            p_pre = pp if self._zero_t[i] else pp + _rv(Rp, nd.placement[:3, 3])
            value = q[:, nd.source] * nd.multiplier + nd.offset
            a = _rv(R_pre, nd.axis)
            if nd.kind == "rotary":
                R_i = _rotate(R_pre, i, self, value)
                p_i = p_pre
            else:
                R_i = R_pre
                p_i = p_pre + np.multiply.outer(value, a) if a.ndim == 1 else p_pre + a * value[:, None]
            Rm.append(R_i)
            pm.append(p_i)
            A.append(a)
            if delta is not None:
                R_i = R_i @ RE[:, i]
                p_i = p_i + _rv(Rm[i], delta[:, i])
            R.append(R_i)
            p.append(p_i)
        return Poses(R, p, Rm, pm, A, RE, Jr, N)

    def frame(self, poses: Poses, link: str) -> tuple[np.ndarray, np.ndarray]:
        """(R (N,3,3), p (N,3)) of a named frame in the base frame."""
        node, T = self.frames[link]
        N = poses.n
        if node < 0:
            Rn, pn = _EYE, _ZERO
        else:
            Rn, pn = poses.R[node], poses.p[node]
        Rf = Rn if np.array_equal(T[:3, :3], _EYE) else Rn @ T[:3, :3]
        pf = pn + _rv(Rn, T[:3, 3])
        return _full(Rf, (N, 3, 3)), _full(pf, (N, 3))

    def twists(self, poses: Poses) -> tuple[np.ndarray, np.ndarray]:
        """Per-node unit-motion twists at the base origin, (v0, w), each (N,M,3):
        rotary: w = axis, v0 = p x axis; linear: w = 0, v0 = axis."""
        N, M = poses.n, len(self.nodes)
        v0 = np.zeros((N, M, 3))
        w = np.zeros((N, M, 3))
        for i in range(M):
            a = poses.axis[i]
            if self._rotary[i]:
                w[:, i] = a
                v0[:, i] = cross(poses.p_motion[i], a)
            else:
                v0[:, i] = a
        return v0, w

    @staticmethod
    def stacked(arrays: list, nodes, N: int, shape: tuple) -> np.ndarray:
        """(N, len(nodes), *shape) stack of per-node arrays (constants broadcast to N)."""
        return np.stack([np.broadcast_to(arrays[i], (N,) + shape) for i in nodes], axis=1)


_EYE = np.eye(3)
_ZERO = np.zeros(3)


def _full(x: np.ndarray, shape: tuple) -> np.ndarray:
    """x as an array of ``shape``: itself, or a writable copy of a constant broadcast to N."""
    return x if x.shape == shape else np.broadcast_to(x, shape).copy()


def _rv(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R v for R (3,3) or (N,3,3) and v (3,) or (N,3)."""
    if R.ndim == 2:
        return v @ R.T
    if v.ndim == 1:
        return R @ v
    return np.einsum("pij,pj->pi", R, v)


def _rotate(R_pre: np.ndarray, i: int, tree: "KinematicTree", angle: np.ndarray) -> np.ndarray:
    """R_pre Rot(axis_i, angle) for N angles; a coordinate axis needs only column mixing."""
    s, c = np.sin(angle), np.cos(angle)
    k = tree._principal[i]
    if k is None:
        Rot = np.eye(3) + s[:, None, None] * tree._K[i] + (1.0 - c)[:, None, None] * tree._K2[i]
        return R_pre @ Rot
    k, sign = k
    s = s * sign
    j, l = (k + 1) % 3, (k + 2) % 3  # rotation about e_k mixes columns j and l
    N = angle.shape[0]
    out = np.empty((N, 3, 3))
    cj, cl = R_pre[..., :, j], R_pre[..., :, l]
    if R_pre.ndim == 2:
        out[:, :, k] = R_pre[:, k]
        out[:, :, j] = np.multiply.outer(c, cj) + np.multiply.outer(s, cl)
        out[:, :, l] = np.multiply.outer(c, cl) - np.multiply.outer(s, cj)
    else:
        out[:, :, k] = R_pre[:, :, k]
        out[:, :, j] = c[:, None] * cj + s[:, None] * cl
        out[:, :, l] = c[:, None] * cl - s[:, None] * cj
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (..., 3) arrays (faster than np.cross on small rows)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def point_columns(v0: np.ndarray, w: np.ndarray, x: np.ndarray, gains: np.ndarray) -> np.ndarray:
    """Velocity columns (N,3,n) of points x (N,3): sum over nodes of gains[node, k] (v0 + w x x).

    gains: (M, n) shared by all poses or (N, M, n) per pose."""
    V = v0 + cross(w, x[:, None, :])
    return np.swapaxes(V, 1, 2) @ gains
