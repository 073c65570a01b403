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

**Pinocchio model.** A copy of the machine's Pinocchio model in which a free-flyer joint
follows every slot joint: ``E_k`` is that joint's configuration ``(delta_k, quat(eps_k))``,
so the error transform is exact (no small-angle matrix) and Pinocchio computes the
erroneous kinematics and every Jacobian column in one call per pose. The copy is built
from the URDF with ``<mimic>`` joints as ordinary joints (set from their source axis)
so that each carries its own error joint. Frames and probes as in
:mod:`vecpin.kinematics.batch`.

The free-flyer's velocity is a twist ``(v, w)`` in its own (child) frame; its
translation is ``delta`` in the parent (axis) frame, so ``d delta = R_E v`` and
``d tip / d delta = J_v R_E^T``; its rotation ``R_E = exp3(eps)`` moves with
``w = Jr(eps) d eps`` (Jr the right Jacobian of exp3), so ``d tip / d eps = J_w Jr(eps)``.

Frames as in :class:`vecpin.kinematics.machine.Machine`: the tool tip in the base frame
or relative to the workpiece (errors of table axes move the workpiece, and enter the
relative tip with the opposite sign to head errors); points fixed in the workpiece frame
in the base frame.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin

from vecpin.errors import InputError
from vecpin.kinematics.axes import Frame, configuration_map, fill_configurations
from vecpin.kinematics.batch import FrameProbes, apply, apply_transposed, point_velocities
from vecpin.kinematics.machine import Machine
from vecpin.kinematics.so3 import exp3_and_right_jacobian, quaternion_xyzw

ERROR_JOINT_SUFFIX = "__error"


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
    """The machine's Pinocchio model with a 6-DoF error joint after every slot joint."""

    def __init__(self, machine: Machine):
        self.machine = machine
        self.slot_names: list[str] = machine.axis_names + [mj.name for mj in machine.mimic_joints]
        self.slot_axis = np.array([a.index for a in machine.axes]
                                  + [machine.axis(mj.axis).index for mj in machine.mimic_joints], int)
        slot = {name: k for k, name in enumerate(self.slot_names)}
        nominal = machine.model_without_mimic()
        model = pin.Model()
        model.name = nominal.name + "_with_errors"
        new_id = {0: 0}
        error_joint = [0] * len(self.slot_names)
        for jid in range(1, nominal.njoints):
            name = nominal.names[jid]
            j = model.addJoint(new_id[nominal.parents[jid]], nominal.joints[jid], nominal.jointPlacements[jid], name)
            new_id[jid] = j
            if name in slot:
                e = model.addJoint(j, pin.JointModelFreeFlyer(), pin.SE3.Identity(), name + ERROR_JOINT_SUFFIX)
                new_id[jid] = e  # the joint's children hang after its error transform
                error_joint[slot[name]] = e
        links = machine.tool_links + ((machine.workpiece_link,) if machine.has_workpiece else ())
        frames = {}
        for link in links:
            f = nominal.frames[nominal.getFrameId(link, pin.FrameType.BODY)]
            frames[link] = (new_id[f.parentJoint], f.placement)
        self.model: pin.Model = model
        self._probes = FrameProbes(model, frames)
        self._fill, gain = configuration_map(model, machine.axes, machine.mimic_joints, mimic_in_model=False)
        self._q_err = np.array([model.joints[e].idx_q for e in error_joint])
        self._v_err = np.array([model.joints[e].idx_vExtended for e in error_joint])
        self._moves_tool = np.stack([self._probes.moves(t) for t in machine.tool_links]).astype(float)  # (P, c)
        self._moves_wp = (self._probes.moves(machine.workpiece_link).astype(float) if machine.has_workpiece
                          else np.zeros(self._probes.n_columns))
        self._G_tool = gain * self._moves_tool[:, :, None]  # (P, c, n)
        self._G_wp = gain * self._moves_wp[:, None]

    @property
    def n_slots(self) -> int:
        return len(self.slot_names)

    def _checked_errors(self, delta, eps, N: int) -> tuple[np.ndarray, np.ndarray]:
        delta = np.asarray(delta, float)
        eps = np.asarray(eps, float)
        n, S = self.machine.n_axes, self.n_slots
        if delta.shape != eps.shape or delta.ndim != 3 or delta.shape[0] != N or delta.shape[2] != 3 \
                or delta.shape[1] not in (n, S):
            raise InputError(f"errors: delta and eps must be (N, {n}, 3) or (N, {S}, 3) for N = {N} poses, "
                             f"got {delta.shape} and {eps.shape}")
        return delta, eps

    def configuration(self, q: np.ndarray, delta: np.ndarray, eps: np.ndarray) -> np.ndarray:
        """Pinocchio configurations (N, nq) of the error model (with its probes) for axis
        commands q (N, n) and errors delta, eps (N, S', 3) on the first S' slots."""
        qa = fill_configurations(self._probes.neutral, self._fill, q)
        used = delta.shape[1]
        idx = self._q_err[:used, None] + np.arange(7)  # (S', 7): x y z, qx qy qz qw
        qa[:, idx] = np.concatenate([delta, quaternion_xyzw(eps)], axis=-1)
        return qa

    def _error_columns(self, V: np.ndarray, moves: np.ndarray, eps: np.ndarray):
        """(J_delta, J_eps) (N,3,S',3) from point velocities V (N,3,c) and the weights
        ``moves`` ((c,) or (N,c): 1 moves the point, 0 not, -1 moves the reference frame)."""
        used = eps.shape[1]
        cols = self._v_err[:used]
        w = moves[..., cols]  # (S',) or (N, S')
        VE = V[:, :, cols[:, None] + np.arange(6)]  # (N, 3, S', 6): unit twists of each error joint
        VE = np.transpose(VE, (0, 2, 1, 3)) * (w[..., :, None, None] if w.ndim == 2 else w[:, None, None])
        RE, Jr = exp3_and_right_jacobian(eps)  # (N, S', 3, 3)
        J_delta = np.transpose(VE[..., :3] @ np.swapaxes(RE, -1, -2), (0, 2, 1, 3))
        J_eps = np.transpose(VE[..., 3:] @ Jr, (0, 2, 1, 3))
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
        delta, eps = self._checked_errors(delta, eps, N)
        J6 = self._probes.jacobians(self.configuration(q, delta, eps))
        R, _, u, tip = m._tip(self._probes, J6, pt, tool, offset)
        relative = frame == "workpiece" and m.has_workpiece
        J_q = J_delta = J_eps = None
        if jacobian:
            V = point_velocities(J6, tip, self._probes.n_columns)
            G = self._G_tool[pt] - self._G_wp if relative else self._G_tool[pt]
            J_q = V @ G
            moves = self._moves_tool[pt] - self._moves_wp if relative else self._moves_tool[pt]
            J_delta, J_eps = self._error_columns(V, moves, eps)
        if relative:
            Rw, pw = self._probes.placement(J6, m.workpiece_link)
            RwT = np.swapaxes(Rw, 1, 2)
            tip = apply_transposed(Rw, tip - pw)
            R = RwT @ R
            u = apply_transposed(Rw, u)
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
        delta, eps = self._checked_errors(delta, eps, N)
        used = delta.shape[1]
        if not m.has_workpiece:
            if not jacobian:
                return ErrorWorkpiecePoints(p.copy(), None, None, None, None)
            return ErrorWorkpiecePoints(p.copy(), np.zeros((N, 3, m.n_axes)),
                                        np.broadcast_to(np.eye(3), (N, 3, 3)).copy(),
                                        np.zeros((N, 3, used, 3)), np.zeros((N, 3, used, 3)))
        J6 = self._probes.jacobians(self.configuration(q, delta, eps))
        Rw, pw = self._probes.placement(J6, m.workpiece_link)
        xyz = pw + apply(Rw, p)
        if not jacobian:
            return ErrorWorkpiecePoints(xyz, None, None, None, None)
        V = point_velocities(J6, xyz, self._probes.n_columns)
        J_delta, J_eps = self._error_columns(V, self._moves_wp, eps)
        return ErrorWorkpiecePoints(xyz, V @ self._G_wp, Rw, J_delta, J_eps)
