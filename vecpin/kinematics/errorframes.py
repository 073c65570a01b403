"""6-DoF error transforms injected into the Pinocchio chain (seed Paper I eq. 3-4).

``F(q) = T_1(q_1) E_1 T_2(q_2) E_2 ... T_n(q_n) E_n``: after every axis joint an
extra free-flyer joint carries the error transform ``E_k = (exp3(eps_k), delta_k)``
expressed in axis k's moving frame (translations ``delta`` [m], rotation vector
``eps`` [rad]). The transform is exact (no small-angle matrix), so large machines
stay accurate; Pinocchio supplies the tool-tip Jacobian with respect to the axis
commands and to the error twists, which is mapped to d tip / d delta and
d tip / d eps here.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin

from vecpin.kinematics.machine import TOOL_DIRECTION, Machine, frame_poses, shift_to_point
from vecpin.kinematics.so3 import exp3, quaternion_xyzw, right_jacobian

ERROR_JOINT_SUFFIX = "__error"


class ErrorTip(NamedTuple):
    """Tool tip of the machine with error transforms, base frame, SI.

    tip (N,3) [m]; rotation (N,3,3) spindle orientation; tool_dir (N,3) unit tool
    direction (d tip / d tool length); J_q (N,3,n) d tip / d q at fixed errors;
    J_delta, J_eps (N,3,n,3) d tip / d delta_k, d tip / d eps_k (None unless asked).
    """

    tip: np.ndarray
    rotation: np.ndarray
    tool_dir: np.ndarray
    J_q: np.ndarray | None
    J_delta: np.ndarray | None
    J_eps: np.ndarray | None


class ErrorFrames:
    """A copy of the machine's Pinocchio model with a 6-DoF error joint after every axis."""

    def __init__(self, machine: Machine):
        self.machine = machine
        nominal = machine.model
        model = pin.Model()
        model.name = nominal.name + "_with_errors"
        new_id = {0: 0}
        self.axis_joint: list[int] = []
        self.error_joint: list[int] = []
        for jid in range(1, nominal.njoints):
            parent = new_id[nominal.parents[jid]]
            j = model.addJoint(parent, nominal.joints[jid], nominal.jointPlacements[jid], nominal.names[jid])
            model.lowerPositionLimit[model.joints[j].idx_q] = nominal.lowerPositionLimit[nominal.joints[jid].idx_q]
            model.upperPositionLimit[model.joints[j].idx_q] = nominal.upperPositionLimit[nominal.joints[jid].idx_q]
            model.appendBodyToJoint(j, nominal.inertias[jid], pin.SE3.Identity())
            e = model.addJoint(j, pin.JointModelFreeFlyer(), pin.SE3.Identity(), nominal.names[jid] + ERROR_JOINT_SUFFIX)
            new_id[jid] = e
            self.axis_joint.append(j)
            self.error_joint.append(e)
        spindle = nominal.frames[machine.spindle_frame_id]
        self.spindle_frame_id = model.addFrame(
            pin.Frame("spindle", new_id[spindle.parentJoint], spindle.placement, pin.FrameType.OP_FRAME))
        self.model = model
        self.data = model.createData()  # after addFrame (pin 4.1: an older data corrupts memory)
        # chain order of machine.axes equals joint order along the single chain
        by_name = {model.names[j]: j for j in self.axis_joint}
        self._q_axis = np.array([model.joints[by_name[a.name]].idx_q for a in machine.axes])
        self._v_axis = np.array([model.joints[by_name[a.name]].idx_v for a in machine.axes])
        err_by_axis = [by_name[a.name] + 1 for a in machine.axes]  # error joint follows its axis
        self._q_err = np.array([model.joints[e].idx_q for e in err_by_axis])
        self._v_err = np.array([model.joints[e].idx_v for e in err_by_axis])

    def configuration(self, q: np.ndarray, delta: np.ndarray, eps: np.ndarray) -> np.ndarray:
        """Pinocchio configurations (N, nq) for axis commands q (N,n) and errors (N,n,3)."""
        N, n = q.shape
        qa = np.zeros((N, self.model.nq))
        qa[:, self._q_axis] = q
        idx = self._q_err[None, :, None] + np.arange(7)[None, None, :]
        block = np.concatenate([delta, quaternion_xyzw(eps)], axis=-1)  # (N,n,7)
        qa[np.arange(N)[:, None, None], idx] = block
        return qa

    def tool_tip(self, q: np.ndarray, delta: np.ndarray, eps: np.ndarray, tool: np.ndarray,
                 jacobian: bool = True) -> ErrorTip:
        """Tool tip for N poses with per-pose error transforms.

        q (N,n) [m, rad] chain order; delta (N,n,3) [m]; eps (N,n,3) [rad], both in
        the moving frame of each axis; tool (N,) effective tool length [m] from the
        nominal gauge line.
        """
        q = np.atleast_2d(np.asarray(q, float))
        N = q.shape[0]
        tool = np.broadcast_to(np.asarray(tool, float), (N,))
        qa = self.configuration(q, delta, eps)
        H, J6 = frame_poses(self.model, self.data, self.spindle_frame_id, qa, jacobian)
        R = H[:, :3, :3]
        u = R @ TOOL_DIRECTION
        r = u * tool[:, None]
        tip = H[:, :3, 3] + r
        if not jacobian:
            return ErrorTip(tip, R, u, None, None, None)
        Jt = shift_to_point(J6, r)
        J_q = Jt[:, :, self._v_axis]
        vi = self._v_err[:, None] + np.arange(6)[None, :]  # (n,6)
        Jerr = Jt[:, :, vi]  # (N,3,n,6): columns = local twist (v, w) of each error joint
        RE = exp3(eps)  # (N,n,3,3)
        # free-flyer: d delta = R_E v  ->  d tip/d delta = J_v R_E^T ; w = Jr(eps) d eps
        J_delta = np.einsum("pikj,pklj->pikl", Jerr[..., :3], RE)
        J_eps = np.einsum("pikj,pkjl->pikl", Jerr[..., 3:], right_jacobian(eps))
        return ErrorTip(tip, R, u, J_q, J_delta, J_eps)
