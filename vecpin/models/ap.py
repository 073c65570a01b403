"""The axis-perturbation model (Paper I eq. 7-8; Section 3 eq. 26-29): every axis
command perturbed by a constant plus a sum of series in each axis' position."""
from __future__ import annotations

import numpy as np

from vecpin.models.base import ErrorModel, register_model
from vecpin.models.tips import ModelPoints, ModelTip
from vecpin.models.parameters import DEFAULT_PRIORS, Parameter


@register_model
class APModel(ErrorModel):
    """Axis-perturbation model (Paper I eq. 7-8; Section 3 eq. 26-29): every axis
    command is perturbed by a constant plus a sum of series in each axis' position.
    Parameter ``i->j.m`` is the coefficient of column m of f_ij (input axis i,
    output j), in the unit of axis j [m or rad]; ``j.offset`` is the constant of q_hat_j."""

    kind = "ap"
    display_name = "AP"

    def _series_parameters(self, mask: np.ndarray, labels: list[list[str]]) -> list[Parameter]:
        """A constant per output axis, then per basis column m >= 1 every input axis i
        having it into every output axis j (``i->j.label``), in the output's unit."""
        axes = self.machine.axes
        out = [Parameter(f"{a.name}.offset", "length" if a.kind == "linear" else "angle",
                         DEFAULT_PRIORS["length" if a.kind == "linear" else "angle"] * self.prior_scale, 0,
                         f"{a.name}.offset", "", "")
               for a in axes]
        for m in range(1, len(mask)):
            for i, ai in enumerate(axes):
                if not mask[m, i]:
                    continue
                for aj in axes:
                    q = "length" if aj.kind == "linear" else "angle"
                    out.append(Parameter(f"{ai.name}->{aj.name}.{labels[i][m]}", q, DEFAULT_PRIORS[q] * self.prior_scale,
                                         m, f"{ai.name}->{aj.name}", ai.name, labels[i][m]))
        return out

    def split(self, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(offsets c (n,), coefficients a (K-1, n_in, n_out), zero where an input has fewer columns)."""
        n = self.machine.n_axes
        k = self._n_offsets()
        a = np.zeros((self._K - 1, n, n))
        a[self._mask[1:]] = b[k + n:len(self.base_parameters)].reshape(-1, n)
        return b[k:k + n], a

    def perturbation(self, q: np.ndarray, b: np.ndarray) -> np.ndarray:
        """q_hat(q) (N, n) [m, rad] (eq. 8)."""
        c, a = self.split(b)
        return c + np.einsum("pim,mij->pj", self._basis_values(q)[:, :, 1:], a, optimize=True)

    def sensitivity(self, q: np.ndarray, tool: np.ndarray, *, frame: str = "base", point=0,
                    offset=None) -> tuple[np.ndarray, np.ndarray]:
        """What every basis shares at zero perturbation: (tool direction (N,3), d tip / d q
        (N,3,n)); :meth:`assemble` turns it into d tip / d b."""
        kin = self.machine.kinematics(q, tool, True, frame=frame, point=point, offset=offset)
        return kin.tool_dir, kin.jacobian

    def workpiece_sensitivity(self, q: np.ndarray, p_wp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`sensitivity` for points fixed in the workpiece frame (base frame); the
        tool direction is zero (the gauge line does not move a table nest)."""
        wp = self.machine.workpiece_points(q, p_wp, True)
        return np.zeros((len(q), 3)), wp.J_q

    def assemble(self, J: np.ndarray, B: np.ndarray, tool: np.ndarray, tool_dir: np.ndarray,
                 mask: np.ndarray | None = None) -> np.ndarray:
        """d tip / d b (N,3,P_base) from d tip / d q (N,3,n) and the basis values B (N,n,K)
        (``mask``: :meth:`ErrorModel.assemble`)."""
        N = len(B)
        mask = self._mask if mask is None else mask
        m, i = np.nonzero(mask[1:])   # the (column, input axis) pairs kept, in the parameters' order
        J_a = (J[:, :, None, :] * B[:, i, m + 1][:, None, :, None]).reshape(N, 3, -1)
        return np.concatenate([self._offset_columns(tool, tool_dir), J, J_a], axis=-1)

    def _perturbed(self, q, b, B=None):
        """(q + q_hat(q), d q_hat_j / d q_i (N,n,n)); ``B``: the basis values at q when known."""
        c, a = self.split(b)
        B = self._basis_values(q) if B is None else B
        qp = q + c + np.einsum("pim,mij->pj", B[:, :, 1:], a, optimize=True)
        D = np.einsum("pim,mij->pij", self._basis_values(q, derivative=True)[:, :, 1:], a, optimize=True)
        return qp, D

    def _base_tool_tip(self, q, tool, b, jacobian=True, *, frame="base", point=0, offset=None) -> ModelTip:
        B = self._basis_values(q)
        qp, D = self._perturbed(q, b, B)
        kin = self.machine.kinematics(qp, self._effective_tool(tool, b), jacobian, frame=frame, point=point,
                                      offset=offset)
        if not jacobian:
            return ModelTip(kin.tip, None, None, kin.tool_dir, kin.rotation)
        J = kin.jacobian  # (N,3,n) at the perturbed commands
        J_q = J + J @ np.swapaxes(D, 1, 2)
        if jacobian == "q":   # d tip / d q only (ErrorModel.tool_tip)
            return ModelTip(kin.tip, None, J_q, kin.tool_dir, kin.rotation)
        J_b = self.assemble(J, B, tool, kin.tool_dir)
        return ModelTip(kin.tip, J_b, J_q, kin.tool_dir, kin.rotation)

    def _base_workpiece_points(self, q, p_wp, b, jacobian=True) -> ModelPoints:
        qp, D = self._perturbed(q, b)
        wp = self.machine.workpiece_points(qp, p_wp, jacobian)
        if not jacobian:
            return ModelPoints(wp.xyz, None, None, None)
        z = np.zeros((len(q), 3))
        J_b = self.assemble(wp.J_q, self._basis_values(q), z[:, 0], z)
        return ModelPoints(wp.xyz, J_b, wp.J_q + wp.J_q @ np.swapaxes(D, 1, 2), wp.J_p)
