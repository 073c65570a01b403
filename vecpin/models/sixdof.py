"""The 6-DoF model (Paper I eq. 3-6): an exact error transform after every axis whose
three translations and three rotations, in the axis' moving frame, are series in that
axis' position, carried by extra joints in the Pinocchio chain."""
from __future__ import annotations

import numpy as np

from vecpin.kinematics.errorframes import ErrorFrames
from vecpin.kinematics.machine import Machine
from vecpin.models.base import ErrorModel, ModelTip, register_model
from vecpin.models.parameters import DEFAULT_PRIORS, Parameter

COMPONENTS = ("dx", "dy", "dz", "ex", "ey", "ez")


@register_model
class SixDofModel(ErrorModel):
    """6-DoF model (Paper I eq. 3-6): an error transform after every axis whose
    translations (dx, dy, dz) [m] and rotations (ex, ey, ez) [rad], in the axis'
    moving frame, are series in that axis' position. Parameter ``k.c.j``: column j
    of axis k's basis for component c."""

    kind = "6dof"

    def __init__(self, machine: Machine, order: int = 6, **kw):
        super().__init__(machine, order, **kw)
        self.frames = ErrorFrames(machine)

    def _model_parameters(self) -> list[Parameter]:
        out = []
        labels = [B.labels() for B in self.bases]
        for j in range(self._K):
            for k, a in enumerate(self.machine.axes):
                if not self._mask[j, k]:
                    continue
                for c in COMPONENTS:
                    q = "length" if c[0] == "d" else "angle"
                    out.append(Parameter(f"{a.name}.{c}.{labels[k][j]}", q, DEFAULT_PRIORS[q] * self.prior_scale, j,
                                         f"{a.name}.{c}", a.name, labels[k][j]))
        return out

    def coefficients(self, b: np.ndarray) -> np.ndarray:
        """(K, n, 6) series coefficients from the parameter vector (zeros where an axis has fewer columns)."""
        A = np.zeros((self._K, self.machine.n_axes, 6))
        A[self._mask] = b[self._n_offsets():len(self.base_parameters)].reshape(-1, 6)
        return A

    def error_values(self, q: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(N, n, 6) values (dx, dy, dz [m], ex, ey, ez [rad]) of every axis' errors."""
        return np.einsum("pnk,knc->pnc", self._basis_values(q), self.coefficients(b))

    def sensitivity(self, q: np.ndarray, tool: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """What every basis shares at zero errors: (tool direction (N,3), d tip / d
        (delta_k, eps_k) (N,3,n,6)); :meth:`assemble` turns it into d tip / d b."""
        z = np.zeros((len(q), self.machine.n_axes, 3))
        out = self.frames.tool_tip(q, z, z, tool, True)
        return out.tool_dir, np.concatenate([out.J_delta, out.J_eps], axis=-1)

    def assemble(self, Jv: np.ndarray, B: np.ndarray, tool: np.ndarray, tool_dir: np.ndarray) -> np.ndarray:
        """d tip / d b (N,3,P_base) from the component sensitivities Jv (N,3,n,6) and the
        basis values B (N,n,K)."""
        N = len(B)
        J_coef = np.einsum("pinc,pnk->piknc", Jv, B)[:, :, self._mask, :].reshape(N, 3, -1)
        return np.concatenate([self._offset_columns(tool, tool_dir), J_coef], axis=-1)

    def _base_tool_tip(self, q, tool, b, jacobian=True) -> ModelTip:
        B = self._basis_values(q)
        A = self.coefficients(b)
        vals = np.einsum("pnk,knc->pnc", B, A)
        out = self.frames.tool_tip(q, vals[..., :3], vals[..., 3:], self._effective_tool(tool, b), jacobian)
        if not jacobian:
            return ModelTip(out.tip, None, None, out.tool_dir)
        Jv = np.concatenate([out.J_delta, out.J_eps], axis=-1)  # (N,3,n,6)
        J_b = self.assemble(Jv, B, tool, out.tool_dir)
        dvals = np.einsum("pnk,knc->pnc", self._basis_values(q, derivative=True), A)
        J_q = out.J_q + np.einsum("pinc,pnc->pin", Jv, dvals)
        return ModelTip(out.tip, J_b, J_q, out.tool_dir)


