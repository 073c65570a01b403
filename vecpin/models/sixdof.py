"""The 6-DoF model (Paper I eq. 3-6): an exact error transform after every axis whose
three translations and three rotations, in the axis' moving frame, are series in that
axis' position, carried by extra joints in the Pinocchio chain.

On a machine with ``<mimic>`` joints (Spar Mill 23's mirrored head) every mimic joint is
a physical slide of its own: it gets its own error transform (a *slot* of
:class:`~vecpin.kinematics.errorframes.ErrorFrames`) whose series are in the position of
the axis that drives it, in that axis' basis."""
from __future__ import annotations

import numpy as np

from vecpin.kinematics.errorframes import ErrorFrames
from vecpin.kinematics.machine import Machine
from vecpin.models.base import ErrorModel, register_model
from vecpin.models.tips import ModelPoints, ModelTip
from vecpin.models.parameters import DEFAULT_PRIORS, Parameter

COMPONENTS = ("dx", "dy", "dz", "ex", "ey", "ez")


@register_model
class SixDofModel(ErrorModel):
    """6-DoF model (Paper I eq. 3-6): an error transform after every axis (and every
    mimic joint) whose translations (dx, dy, dz) [m] and rotations (ex, ey, ez) [rad], in
    the joint's moving frame, are series in the driving axis' position. Parameter
    ``k.c.j``: column j of slot k's basis for component c (slot k: an axis or a mimic
    joint, named as the URDF joint)."""

    kind = "6dof"
    display_name = "6-DoF"

    def __init__(self, machine: Machine, order: int = 6, **kw):
        self.frames = ErrorFrames(machine)
        super().__init__(machine, order, **kw)

    @property
    def slot_axis(self) -> np.ndarray:
        """(S,) the axis index driving each slot (slots: axes, then mimic joints)."""
        return self.frames.slot_axis

    def _slot_mask(self) -> np.ndarray:
        """(K, S) basis columns each slot has (its driving axis' basis)."""
        return self._mask[:, self.slot_axis]

    def _series_parameters(self, mask: np.ndarray, labels: list[list[str]]) -> list[Parameter]:
        """Per basis column j, every slot whose driving axis has it, its six components
        (``slot.component.label``)."""
        out = []
        slot_mask = mask[:, self.slot_axis]
        for j in range(len(mask)):
            for s, name in enumerate(self.frames.slot_names):
                k = int(self.slot_axis[s])
                if not slot_mask[j, s]:
                    continue
                a = self.machine.axes[k]
                for c in COMPONENTS:
                    q = "length" if c[0] == "d" else "angle"
                    out.append(Parameter(f"{name}.{c}.{labels[k][j]}", q, DEFAULT_PRIORS[q] * self.prior_scale, j,
                                         f"{name}.{c}", a.name, labels[k][j]))
        return out

    def coefficients(self, b: np.ndarray) -> np.ndarray:
        """(K, S, 6) series coefficients of every slot (zeros where a slot's axis has fewer columns)."""
        A = np.zeros((self._K, self.frames.n_slots, 6))
        A[self._slot_mask()] = b[self._n_offsets():len(self.base_parameters)].reshape(-1, 6)
        return A

    def _slot_basis(self, q: np.ndarray, derivative: bool = False) -> np.ndarray:
        """(N, S, K) basis values of every slot (its driving axis' basis at that axis' position)."""
        return self._basis_values(q, derivative)[:, self.slot_axis, :]

    def error_values(self, q: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(N, S, 6) values (dx, dy, dz [m], ex, ey, ez [rad]) of every slot's errors."""
        return np.einsum("psk,ksc->psc", self._slot_basis(q), self.coefficients(b))

    def sensitivity(self, q: np.ndarray, tool: np.ndarray, *, frame: str = "base", point=0,
                    offset=None) -> tuple[np.ndarray, np.ndarray]:
        """What every basis shares at zero errors: (tool direction (N,3), d tip / d
        (delta_s, eps_s) (N,3,S,6) for every slot); :meth:`assemble` turns it into d tip / d b."""
        z = np.zeros((len(q), self.frames.n_slots, 3))
        out = self.frames.tool_tip(q, z, z, tool, True, frame=frame, point=point, offset=offset)
        return out.tool_dir, np.concatenate([out.J_delta, out.J_eps], axis=-1)

    def workpiece_sensitivity(self, q: np.ndarray, p_wp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`sensitivity` for points fixed in the workpiece frame (base frame): the
        tool direction is zero (the gauge line does not move a table nest)."""
        z = np.zeros((len(q), self.frames.n_slots, 3))
        out = self.frames.workpiece_points(q, z, z, p_wp, True)
        return np.zeros((len(q), 3)), np.concatenate([out.J_delta, out.J_eps], axis=-1)

    def assemble(self, Jv: np.ndarray, B: np.ndarray, tool: np.ndarray, tool_dir: np.ndarray,
                 mask: np.ndarray | None = None) -> np.ndarray:
        """d tip / d b (N,3,P_base) from the component sensitivities Jv (N,3,S,6) and the
        basis values B (N,n,K) of the axes (each slot uses its driving axis' values;
        ``mask``: :meth:`ErrorModel.assemble`)."""
        N = len(B)
        Bs = B[:, self.slot_axis, :]
        slot_mask = self._slot_mask() if mask is None else mask[:, self.slot_axis]
        k, s = np.nonzero(slot_mask)   # the (column, slot) pairs kept, in the parameters' order
        J_coef = (Jv[:, :, s, :] * Bs[:, s, k][:, None, :, None]).reshape(N, 3, -1)
        return np.concatenate([self._offset_columns(tool, tool_dir), J_coef], axis=-1)

    def _q_columns(self, J_q: np.ndarray, Jv: np.ndarray, q: np.ndarray, A: np.ndarray) -> np.ndarray:
        """Total d point / d q: the kinematics at fixed errors plus the change of every
        slot's errors with its driving axis."""
        dvals = np.einsum("psk,ksc->psc", self._slot_basis(q, derivative=True), A)
        per_slot = np.einsum("pisc,psc->pis", Jv, dvals)
        out = J_q.copy()
        for s, k in enumerate(self.slot_axis):
            out[:, :, k] += per_slot[:, :, s]
        return out

    def _base_tool_tip(self, q, tool, b, jacobian=True, *, frame="base", point=0, offset=None) -> ModelTip:
        A = self.coefficients(b)
        vals = np.einsum("psk,ksc->psc", self._slot_basis(q), A)
        out = self.frames.tool_tip(q, vals[..., :3], vals[..., 3:], self._effective_tool(tool, b), jacobian,
                                   frame=frame, point=point, offset=offset)
        if not jacobian:
            return ModelTip(out.tip, None, None, out.tool_dir, out.rotation)
        Jv = np.concatenate([out.J_delta, out.J_eps], axis=-1)  # (N,3,S,6)
        J_b = None if jacobian == "q" else self.assemble(Jv, self._basis_values(q), tool, out.tool_dir)
        return ModelTip(out.tip, J_b, self._q_columns(out.J_q, Jv, q, A), out.tool_dir, out.rotation)

    def _base_workpiece_points(self, q, p_wp, b, jacobian=True) -> ModelPoints:
        A = self.coefficients(b)
        vals = np.einsum("psk,ksc->psc", self._slot_basis(q), A)
        out = self.frames.workpiece_points(q, vals[..., :3], vals[..., 3:], p_wp, jacobian)
        if not jacobian:
            return ModelPoints(out.xyz, None, None, None)
        Jv = np.concatenate([out.J_delta, out.J_eps], axis=-1)
        z = np.zeros((len(q), 3))
        J_b = self.assemble(Jv, self._basis_values(q), z[:, 0], z)
        return ModelPoints(out.xyz, J_b, self._q_columns(out.J_q, Jv, q, A), out.J_p)
