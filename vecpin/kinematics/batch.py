"""Pinocchio kinematics for N poses: joint Jacobian columns and frame placements.

One Pinocchio call per pose, ``pin.computeJointJacobians`` (1 to 2 µs for a five-axis
machine with its probes), gives the Jacobian of every joint in Pinocchio's WORLD convention:
column c is the twist ``[v0; w]`` (linear; angular) of everything downstream of joint
velocity c, written at the base origin, so a point ``x`` [m] carried downstream moves
with ``v0 + w × x``. Columns follow Pinocchio's *extended* velocity index
(``idx_vExtended``), which gives a ``<mimic>`` joint its own column already scaled by
its multiplier.

Frame placements are read from the same array. A free-flyer **probe** joint is
attached, held at the identity, at each frame of interest (a tool link, the workpiece,
an axis frame); its six columns are the adjoint of the frame's placement
``[[R, [p]x R], [0, R]]``, so ``R`` and ``p`` come out of the Jacobian with no second
call per pose (reading ``data.oMf`` from Python costs about 2 µs per frame, more than
the kinematics themselves). The tests check these placements against Pinocchio's own
``framesForwardKinematics``.

Everything is SI (m, rad) in the base frame (the URDF root link).
"""
from __future__ import annotations

from typing import Mapping

import numpy as np
import pinocchio as pin

PROBE_SUFFIX = "__probe"


class FrameProbes:
    """A copy of a Pinocchio model with a probe joint at each named frame.

    ``frames``: name -> (parent joint id in ``model``, placement of the frame in that
    joint's frame). The probes are appended after the model's joints, so the first
    ``model.nq`` entries of a configuration and the first :attr:`n_columns` Jacobian
    columns are the model's own.
    """

    def __init__(self, model: pin.Model, frames: Mapping[str, tuple[int, pin.SE3]]):
        probed = pin.Model(model)
        self.n_columns: int = model.nvExtended
        self._column: dict[str, int] = {}
        self._moves: dict[str, np.ndarray] = {}
        for name, (parent, placement) in frames.items():
            j = probed.addJoint(int(parent), pin.JointModelFreeFlyer(), placement, name + PROBE_SUFFIX)
            self._column[name] = probed.joints[j].idx_vExtended
            moves = np.zeros(self.n_columns, bool)
            for s in probed.supports[j]:  # the joints from the base to the probe
                if 0 < s < j:
                    jm = probed.joints[s]
                    moves[jm.idx_vExtended:jm.idx_vExtended + jm.nvExtended] = True
            self._moves[name] = moves
        self.model: pin.Model = probed
        self.data: pin.Data = probed.createData()  # after the last addJoint (an older data is invalid)
        self.neutral: np.ndarray = pin.neutral(probed)

    def moves(self, name: str) -> np.ndarray:
        """(n_columns,) bool: which of the model's Jacobian columns move frame ``name``."""
        return self._moves[name]

    def jacobians(self, configurations: np.ndarray) -> np.ndarray:
        """(N, 6, nv_extended) world Jacobians ``[v0; w]`` for N configurations (N, nq)."""
        model, data, compute = self.model, self.data, pin.computeJointJacobians
        cfg = np.asarray(configurations)
        new = np.r_[True, np.any(cfg[1:] != cfg[:-1], axis=1)] if len(cfg) else np.zeros(0, bool)
        out = np.empty((int(new.sum()), 6, model.nvExtended))
        for i, qi in enumerate(cfg[new]):   # a configuration repeated on the next rows: computed once
            out[i] = compute(model, data, qi)
        return out if new.all() else out[np.cumsum(new) - 1]

    def placement(self, J: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(R (N,3,3), p (N,3)) of frame ``name`` in the base frame, from its probe's columns.

        The angular columns are ``[p x r_k; r_k]`` for the frame axes ``r_k``; since
        ``r x (p x r) = p - r (r . p)``, ``p = 1/2 sum_k r_k x (p x r_k)``.
        """
        c = self._column[name] + 3
        R = J[:, 3:, c:c + 3]
        C = J[:, :3, c:c + 3]
        p = 0.5 * (cross(R[:, :, 0], C[:, :, 0]) + cross(R[:, :, 1], C[:, :, 1]) + cross(R[:, :, 2], C[:, :, 2]))
        return R.copy(), p


def point_velocities(J: np.ndarray, x: np.ndarray, n_columns: int) -> np.ndarray:
    """(N, 3, n_columns) velocity of a point at x (N,3) [m] carried downstream of each of
    the first ``n_columns`` Jacobian columns: ``v0 + w × x``."""
    v0 = J[:, :3, :n_columns]
    w = J[:, 3:, :n_columns]
    x0, x1, x2 = x[:, 0, None], x[:, 1, None], x[:, 2, None]
    out = np.empty(v0.shape)
    out[:, 0] = v0[:, 0] + w[:, 1] * x2 - w[:, 2] * x1
    out[:, 1] = v0[:, 1] + w[:, 2] * x0 - w[:, 0] * x2
    out[:, 2] = v0[:, 2] + w[:, 0] * x1 - w[:, 1] * x0
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (..., 3) arrays (faster than np.cross on small rows)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def apply(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R v row by row: R (N,3,3), v (N,3) -> (N,3)."""
    return np.einsum("pij,pj->pi", R, v)


def apply_transposed(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R^T v row by row: R (N,3,3), v (N,3) -> (N,3)."""
    return np.einsum("pji,pj->pi", R, v)
