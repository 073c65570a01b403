"""The axis-perturbation model (Paper I eq. 7-8; Section 3 eq. 26-29): every axis
command perturbed by a constant plus a sum of series in each axis' position."""
from __future__ import annotations

import numpy as np

from vecpin.models.base import ErrorModel, ModelTip, register_model
from vecpin.models.parameters import DEFAULT_PRIORS, Parameter


@register_model
class APModel(ErrorModel):
    """Axis-perturbation model (Paper I eq. 7-8; Section 3 eq. 26-29): every axis
    command is perturbed by a constant plus a sum of series in each axis' position.
    Parameter ``i->j.m`` is the coefficient of column m of f_ij (input axis i,
    output j), in the unit of axis j [m or rad]; ``j.offset`` is the constant of q_hat_j."""

    kind = "ap"

    def _model_parameters(self) -> list[Parameter]:
        axes = self.machine.axes
        out = [Parameter(f"{a.name}.offset", "length" if a.kind == "linear" else "angle",
                         DEFAULT_PRIORS["length" if a.kind == "linear" else "angle"] * self.prior_scale, 0,
                         f"{a.name}.offset", "", "")
               for a in axes]
        labels = [B.labels() for B in self.bases]
        for m in range(1, self._K):
            for i, ai in enumerate(axes):
                if not self._mask[m, i]:
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
        return c + np.einsum("pim,mij->pj", self._basis_values(q)[:, :, 1:], a)

    def sensitivity(self, q: np.ndarray, tool: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """What every basis shares at zero perturbation: (tool direction (N,3), d tip / d q
        (N,3,n)); :meth:`assemble` turns it into d tip / d b."""
        kin = self.machine.kinematics(q, tool, True)
        return kin.tool_dir, kin.jacobian

    def assemble(self, J: np.ndarray, B: np.ndarray, tool: np.ndarray, tool_dir: np.ndarray) -> np.ndarray:
        """d tip / d b (N,3,P_base) from d tip / d q (N,3,n) and the basis values B (N,n,K)."""
        N = len(B)
        J_a = np.einsum("pxj,pim->pxmij", J, B[:, :, 1:])[:, :, self._mask[1:], :].reshape(N, 3, -1)
        return np.concatenate([self._offset_columns(tool, tool_dir), J, J_a], axis=-1)

    def _base_tool_tip(self, q, tool, b, jacobian=True) -> ModelTip:
        N, n = q.shape
        c, a = self.split(b)
        B = self._basis_values(q)[:, :, 1:]  # (N, n, K-1)
        qp = q + c + np.einsum("pim,mij->pj", B, a)
        kin = self.machine.kinematics(qp, self._effective_tool(tool, b), jacobian)
        tool_dir = kin.tool_dir
        if not jacobian:
            return ModelTip(kin.tip, None, None, tool_dir)
        J = kin.jacobian  # (N,3,n) at the perturbed commands
        J_b = self.assemble(J, self._basis_values(q), tool, tool_dir)
        D = np.einsum("pim,mij->pij", self._basis_values(q, derivative=True)[:, :, 1:], a)  # d q_hat_j / d q_i
        J_q = J + np.einsum("pxj,pij->pxi", J, D)
        return ModelTip(kin.tip, J_b, J_q, tool_dir)


