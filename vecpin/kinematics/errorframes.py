"""6-DoF error transforms after every moving joint of the machine (seed Paper I eq. 3-4).

``F(q) = T_1(q_1) E_1 T_2(q_2) E_2 ... T_n(q_n) E_n`` along each branch: after every
axis joint (head and table branches alike) an error transform
``E_k = (exp3(eps_k), delta_k)`` expressed in axis k's moving frame (translations
``delta`` [m], rotation vector ``eps`` [rad]). The transform is exact (no small-angle
matrix), so large machines stay accurate.

**Slots.** The error transforms sit in *slots*: slot k < n is axis k (vecpin's axis
order); on a machine with ``<mimic>`` joints (Spar Mill 23's mirrored head) the mimic
joints are further slots n, n+1, ... (:attr:`ErrorFrames.slot_names`), each a physical
slide with its own errors, driven by its source axis (:attr:`ErrorFrames.slot_axis`).
Callers give ``delta``/``eps`` for the n axes only (mimic slots then carry no error) or
for all slots; the error Jacobians have as many slots as the errors given.

Frames as in :class:`vecpin.kinematics.machine.Machine`: the tool tip in the base frame
or relative to the workpiece (errors of table axes move the workpiece, and enter the
relative tip with the opposite sign to head errors); points fixed in the workpiece frame
in the base frame. Jacobians are analytic (see :mod:`vecpin.kinematics.tree`).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from vecpin.errors import InputError
from vecpin.kinematics.machine import Frame, Machine
from vecpin.kinematics.tree import cross, point_columns


class ErrorTip(NamedTuple):
    """Tool tip of the machine with error transforms, SI, in ``frame``.

    tip (N,3) [m]; rotation (N,3,3) tool-link orientation; tool_dir (N,3) unit tool
    direction (d tip / d tool length); J_q (N,3,n) d tip / d q at fixed errors;
    J_delta, J_eps (N,3,S,3) d tip / d delta_k, d tip / d eps_k for the S slots given
    (None unless asked); frame: "base" or "workpiece".
    """

    tip: np.ndarray
    rotation: np.ndarray
    tool_dir: np.ndarray
    J_q: np.ndarray | None
    J_delta: np.ndarray | None
    J_eps: np.ndarray | None
    frame: str = "base"


class ErrorWorkpiecePoints(NamedTuple):
    """Points fixed in the (erroneous) workpiece frame, in the base frame, SI.

    xyz (N,3) [m]; J_q (N,3,n); J_p (N,3,3) d xyz / d p_wp; J_delta, J_eps (N,3,S,3).
    """

    xyz: np.ndarray
    J_q: np.ndarray | None
    J_p: np.ndarray | None
    J_delta: np.ndarray | None
    J_eps: np.ndarray | None


class ErrorFrames:
    """The machine's kinematic tree with a 6-DoF error transform after every moving joint."""

    def __init__(self, machine: Machine):
        self.machine = machine
        self.kin = machine.kin
        nodes = [machine.node_of[a.name] for a in machine.axes]
        nodes += [machine.node_of[mj.name] for mj in machine.mimic_joints]
        self._slot_node = np.array(nodes, int)
        self.slot_names: list[str] = machine.axis_names + [mj.name for mj in machine.mimic_joints]
        self.slot_axis = np.array([self.kin.nodes[i].source for i in nodes], int)
        M = len(self.kin.nodes)
        self._mask_tool = np.stack([self.kin.mask(t) for t in machine.tool_links])  # (P, M)
        self._mask_wp = self.kin.mask(machine.workpiece_link) if machine.has_workpiece else np.zeros(M, bool)

    @property
    def n_slots(self) -> int:
        return len(self.slot_names)

    def _node_errors(self, delta, eps, N: int):
        delta = np.asarray(delta, float)
        eps = np.asarray(eps, float)
        n, S = self.machine.n_axes, self.n_slots
        if delta.shape != eps.shape or delta.ndim != 3 or delta.shape[0] != N or delta.shape[2] != 3 \
                or delta.shape[1] not in (n, S):
            raise InputError(f"errors: delta and eps must be (N, {n}, 3) or (N, {S}, 3) for N = {N} poses, "
                             f"got {delta.shape} and {eps.shape}")
        M = len(self.kin.nodes)
        used = delta.shape[1]
        d = np.zeros((N, M, 3))
        e = np.zeros((N, M, 3))
        d[:, self._slot_node[:used]] = delta
        e[:, self._slot_node[:used]] = eps
        return d, e, used

    def _error_columns(self, poses, x: np.ndarray, mask: np.ndarray, used: int):
        """(J_delta, J_eps) (N,3,S,3) of points x (N,3) carried by frames whose moving
        nodes are ``mask`` ((M,) or (N,M), entries 1, 0 or -1)."""
        nodes = self._slot_node[:used]
        m = mask[..., nodes].astype(float)
        if m.ndim == 1:
            m = np.broadcast_to(m, (len(x), used))
        N = len(x)
        Rm = self.kin.stacked(poses.R_motion, nodes, N, (3, 3))  # (N,S,3,3)
        J_delta = np.swapaxes(Rm * m[:, :, None, None], 1, 2)  # (N,3,S,3)
        W = self.kin.stacked(poses.R, nodes, N, (3, 3)) @ poses.Jr_eps[:, nodes]  # angular velocity of d eps
        o = self.kin.stacked(poses.p, nodes, N, (3,))
        # column c: w_c x (x - o) = (o - x) x w_c, with the columns of W as rows
        lever = cross((o - x[:, None, :])[:, :, None, :], np.swapaxes(W, 2, 3))  # (N,S,c,3)
        J_eps = np.transpose(lever * m[:, :, None, None], (0, 3, 1, 2))
        return J_delta, J_eps

    def tool_tip(self, q: np.ndarray, delta: np.ndarray, eps: np.ndarray, tool: np.ndarray | float,
                 jacobian: bool = True, *, frame: Frame | None = None, point: int | np.ndarray = 0,
                 offset: np.ndarray | None = None) -> ErrorTip:
        """Tool tip for N poses with per-pose error transforms.

        q (N,n) [m, rad] axis order; delta (N,n,3) or (N,S,3) [m]; eps same shape [rad],
        both in the moving frame of each slot's joint; tool (N,) effective tool length [m]
        from the nominal gauge line along the tool axis; offset (3,) or (N,3) [m] in the
        tool link frame; point: tool point index or (N,) indices; frame: "base" or
        "workpiece" (default: the machine's default frame).
        """
        m = self.machine
        q = np.atleast_2d(np.asarray(q, float))
        N = q.shape[0]
        frame = m._frame(frame)
        pt = m._points(point, N)
        tool = np.broadcast_to(np.asarray(tool, float), (N,))
        d, e, used = self._node_errors(delta, eps, N)
        poses = self.kin.forward(q, d, e)
        R, o = m._tool_frames(poses, pt, N)
        u = R @ m.tool_axis
        local = tool[:, None] * m.tool_axis
        if offset is not None:
            local = local + np.broadcast_to(np.asarray(offset, float), (N, 3))
        tip = o + np.einsum("pij,pj->pi", R, local)
        relative = frame == "workpiece" and m.has_workpiece
        J_q = J_delta = J_eps = None
        if jacobian:
            v0, w = self.kin.twists(poses)
            J_q = point_columns(v0, w, tip, m._gains(pt, frame))
            mask = self._mask_tool[pt].astype(int)
            if relative:
                mask = mask - self._mask_wp
            J_delta, J_eps = self._error_columns(poses, tip, mask, used)
        if relative:
            Rw, pw = self.kin.frame(poses, m.workpiece_link)
            RwT = np.swapaxes(Rw, 1, 2)
            tip = np.einsum("pij,pj->pi", RwT, tip - pw)
            R = RwT @ R
            u = np.einsum("pij,pj->pi", RwT, u)
            if jacobian:
                J_q = RwT @ J_q
                J_delta = (RwT @ J_delta.reshape(N, 3, -1)).reshape(J_delta.shape)
                J_eps = (RwT @ J_eps.reshape(N, 3, -1)).reshape(J_eps.shape)
        return ErrorTip(tip, R, u, J_q, J_delta, J_eps, frame)

    def workpiece_points(self, q: np.ndarray, delta: np.ndarray, eps: np.ndarray, p_wp: np.ndarray,
                         jacobian: bool = True) -> ErrorWorkpiecePoints:
        """Points fixed in the workpiece frame (table nests) in the base frame, with the
        table axes' errors: q (N,n); delta, eps as in :meth:`tool_tip`; p_wp (3,) or (N,3) [m]."""
        m = self.machine
        q = np.atleast_2d(np.asarray(q, float))
        N = q.shape[0]
        p = np.broadcast_to(np.asarray(p_wp, float), (N, 3))
        d, e, used = self._node_errors(delta, eps, N)
        if not m.has_workpiece:
            if not jacobian:
                return ErrorWorkpiecePoints(p.copy(), None, None, None, None)
            return ErrorWorkpiecePoints(p.copy(), np.zeros((N, 3, m.n_axes)),
                                        np.broadcast_to(np.eye(3), (N, 3, 3)).copy(),
                                        np.zeros((N, 3, used, 3)), np.zeros((N, 3, used, 3)))
        poses = self.kin.forward(q, d, e)
        Rw, pw = self.kin.frame(poses, m.workpiece_link)
        xyz = pw + np.einsum("pij,pj->pi", Rw, p)
        if not jacobian:
            return ErrorWorkpiecePoints(xyz, None, None, None, None)
        v0, w = self.kin.twists(poses)
        J_q = point_columns(v0, w, xyz, m._G_wp)
        J_delta, J_eps = self._error_columns(poses, xyz, self._mask_wp.astype(int), used)
        return ErrorWorkpiecePoints(xyz, J_q, Rw, J_delta, J_eps)
