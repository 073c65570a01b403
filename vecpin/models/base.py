"""Geometric error models of a machine: 6-DoF and axis perturbation (Paper I §2).

Both map axis commands ``q`` [m, rad] and a tool length [m] to the tool tip in the
machine base frame, with analytic Jacobians with respect to their parameters ``b``
and to ``q``. Parameters are SI: translations in m, rotations in rad, AP
perturbations in the unit of their output axis.

* :class:`SixDofModel`: ``F = T_1(q_1) E_1(q_1) ... T_n(q_n) E_n(q_n)`` (eq. 3), each
  ``E_k`` an exact transform whose three translations and three rotations are
  series in ``q_k`` (eq. 5-6), carried by extra joints in the Pinocchio chain.
* :class:`APModel`: ``F = F_n(q + q_hat(q))`` (eq. 7) with
  ``q_hat_j = c_j + sum_i f_ij(q_i)`` (eq. 8, 28).

Both carry the mechanical offsets a controller can change: ``T_offset``, the
gauge-line correction along the tool, and optionally a length correction per tool.
The tracker-frame correction ``E_0`` belongs to the measurement setup and is added
by the estimator (:mod:`vecpin.identify`).

Parameters are ordered by priority (offsets, then every order-0 term, then order 1,
...): redundancy removal keeps the earlier of two terms that move the tool tip alike.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from vecpin.models.basis import AxisBasis
from vecpin.kinematics.errorframes import ErrorFrames
from vecpin.kinematics.machine import Machine

COMPONENTS = ("dx", "dy", "dz", "ex", "ey", "ez")


@dataclass(frozen=True)
class Parameter:
    """One model parameter: ``quantity`` is "length" [m] or "angle" [rad];
    ``prior`` is the prior standard deviation (Σ_b of eq. 11), SI; ``order`` is the
    basis order (-1 for offsets); ``group`` names the function it belongs to."""

    name: str
    quantity: str
    prior: float
    order: int
    group: str


class ModelTip(NamedTuple):
    """tip (N,3) [m] machine frame; J_b (N,3,P); J_q (N,3,n) total d tip / d q;
    tool_dir (N,3) unit tool direction."""

    tip: np.ndarray
    J_b: np.ndarray | None
    J_q: np.ndarray | None
    tool_dir: np.ndarray


DEFAULT_PRIORS = {"length": 1e-3, "angle": 1e-3, "offset": 5e-3}


class ErrorModel:
    """Base of the error models: bases, offsets, parameter bookkeeping.

    ``order``: series order on every axis (eq. 5). ``basis="auto"`` (default) uses
    Chebyshev polynomials over the travel, except a Fourier series on rotary axes
    that travel more than a turn (errors that repeat every turn, which Chebyshev
    needs a high order for); ``basis="chebyshev"`` is the seed's choice everywhere;
    ``bases``
    overrides everything with one :class:`~vecpin.basis.AxisBasis` per axis
    (column 0 must be the constant). ``tool_lengths`` [m] adds a length correction
    per tool; ``prior_scale`` multiplies every prior standard deviation (Σ_b).
    """

    kind = "base"

    def __init__(self, machine: Machine, order: int = 6, basis: str = "auto",
                 tool_lengths: list[float] | None = None, prior_scale: float = 1.0,
                 bases: list[AxisBasis] | None = None, effects: list | None = None):
        from vecpin.errors import VecpinError
        if order < 0:
            raise VecpinError("the series order must be >= 0")
        basis = "auto" if basis == "fourier" else basis
        if basis not in ("chebyshev", "auto"):
            raise VecpinError("basis is 'auto' (Fourier on rotary axes travelling more than a turn) or 'chebyshev'")
        self.machine = machine
        self.order = int(order)
        self.basis = basis
        self.prior_scale = float(prior_scale)
        self.tool_lengths = None if tool_lengths is None else [float(t) for t in tool_lengths]
        if bases is None:
            bases = [AxisBasis(a.lower, a.upper, self.order,
                               "fourier" if basis == "auto" and a.kind == "rotary" and a.travel > 2 * math.pi else "chebyshev",
                               rotary=a.kind == "rotary") for a in machine.axes]
            self.basis_kind = basis
        else:
            if len(bases) != machine.n_axes:
                raise ValueError("one basis per axis")
            self.basis_kind = "custom"
        self.bases = list(bases)
        self._K = max(B.size for B in self.bases)
        self._mask = np.array([[j < B.size for B in self.bases] for j in range(self._K)])  # (K, n)
        self.base_parameters: list[Parameter] = self._offset_parameters() + self._model_parameters()
        self.effects = list(effects or [])
        self.parameters: list[Parameter] = self.base_parameters + [p for e in self.effects for p in e.parameters()]

    # --------------------------------------------------------------- parameters
    def _offset_parameters(self) -> list[Parameter]:
        p = [Parameter("T_offset", "length", DEFAULT_PRIORS["offset"] * self.prior_scale, -1, "offsets")]
        for L in self.tool_lengths or []:
            p.append(Parameter(f"tool[{L * 1e3:.3f}mm]", "length", DEFAULT_PRIORS["offset"] * self.prior_scale, -1, "offsets"))
        return p

    def _model_parameters(self) -> list[Parameter]:
        raise NotImplementedError

    @property
    def n_parameters(self) -> int:
        return len(self.parameters)

    @property
    def parameter_names(self) -> list[str]:
        return [p.name for p in self.parameters]

    @property
    def priors(self) -> np.ndarray:
        return np.array([p.prior for p in self.parameters])

    def _n_offsets(self) -> int:
        return 1 + len(self.tool_lengths or [])

    def _offset_columns(self, tool: np.ndarray, tool_dir: np.ndarray) -> np.ndarray:
        cols = [tool_dir]
        for L in self.tool_lengths or []:
            cols.append(tool_dir * np.isclose(tool, L, atol=1e-7)[:, None])
        return np.stack(cols, axis=-1)

    def _effective_tool(self, tool: np.ndarray, b: np.ndarray) -> np.ndarray:
        eff = tool + b[0]
        for k, L in enumerate(self.tool_lengths or []):
            eff = eff + b[1 + k] * np.isclose(tool, L, atol=1e-7)
        return eff

    def _basis_values(self, q: np.ndarray, derivative: bool = False) -> np.ndarray:
        """(N, n, K) basis values (or derivatives) of every axis, zero-padded to K columns."""
        out = np.zeros((len(q), self.machine.n_axes, self._K))
        for k, B in enumerate(self.bases):
            out[:, k, :B.size] = B.derivative(q[:, k]) if derivative else B.values(q[:, k])
        return out

    # --------------------------------------------------------------- kinematics
    def _base_tool_tip(self, q: np.ndarray, tool: np.ndarray, b: np.ndarray, jacobian: bool) -> ModelTip:
        raise NotImplementedError

    def effect_slices(self) -> list[tuple]:
        """(effect, slice of its parameters in b) for every effect."""
        out, k = [], len(self.base_parameters)
        for e in self.effects:
            out.append((e, slice(k, k + e.n_parameters)))
            k += e.n_parameters
        return out

    def with_effects(self, effects: list) -> "ErrorModel":
        """A new, unfitted model of the same kind and bases with these effects."""
        return type(self)(self.machine, self.order, basis=self.basis,
                          tool_lengths=self.tool_lengths, prior_scale=self.prior_scale,
                          bases=self.bases if self.basis_kind == "custom" else None, effects=effects)

    def tool_tip(self, q: np.ndarray, tool: np.ndarray | float, b: np.ndarray, jacobian: bool = True,
                 features=None) -> ModelTip:
        """Tool tip of the model with parameters b, machine base frame (SI). ``features``
        (:class:`~vecpin.features.Features`) are needed when effects depend on the rows."""
        q = np.atleast_2d(np.asarray(q, float))
        N = len(q)
        tool = np.broadcast_to(np.asarray(tool, float), (N,))
        nb = len(self.base_parameters)
        if not self.effects:
            return self._base_tool_tip(q, tool, b, jacobian)
        if features is None:
            from vecpin.errors import VecpinError
            raise VecpinError("this model has effects (" + ", ".join(e.label for e in self.effects) +
                              ") that depend on the rows: evaluate it on a campaign (time, temperature, row order)")
        slices = self.effect_slices()
        S_all = []
        q_eff = q.copy()
        for e, sl in slices:
            if "command" in e.kinds:
                S = e.command(q, features)
                q_eff = q_eff + np.einsum("pnk,k->pn", S, b[sl])
                S_all.append((sl, S))
        out = self._base_tool_tip(q_eff, tool, b[:nb], jacobian)  # tip effects need only tip and tool direction
        tip = out.tip.copy()
        J_cmd = np.zeros((N, 3, len(self.parameters) - nb)) if jacobian else None
        J_tip = np.zeros_like(J_cmd) if jacobian else None
        for sl, S in S_all:
            if jacobian:  # through the base kinematics at the perturbed commands
                J_cmd[:, :, sl.start - nb:sl.stop - nb] += np.einsum("pin,pnk->pik", out.J_q, S)
        from vecpin.models.effects import TipContext
        ctx = TipContext(self.machine, q_eff, out.tip, out.tool_dir)
        grad = np.zeros((N, 3, 3))
        for e, sl in slices:
            if "tip" in e.kinds:
                D = e.tip(ctx, features)
                tip += np.einsum("pik,k->pi", D, b[sl])
                if jacobian:
                    J_tip[:, :, sl.start - nb:sl.stop - nb] += D
                    grad += e.tip_gradient(ctx, features, b[sl])
        if not jacobian:
            return ModelTip(tip, None, None, out.tool_dir)
        # tip displacements that move with the tip (a rotation's lever arm): chain rule
        M = np.eye(3) + grad
        J_b = np.concatenate([M @ out.J_b, M @ J_cmd + J_tip], axis=-1)
        return ModelTip(tip, J_b, M @ out.J_q, out.tool_dir)

    def describe(self) -> dict:
        return {"kind": self.kind, "order": self.order, "basis": self.basis_kind,
                "axis_bases": [B.to_dict() for B in self.bases], "tool_lengths_mm":
                None if self.tool_lengths is None else [t * 1e3 for t in self.tool_lengths],
                "prior_scale": self.prior_scale}

    # --------------------------------------------------------------- estimator API
    def fit(self, campaign, noise=None, *, remove_redundant: bool = True, max_iter: int = 30,
            underdetermined: bool = False, progress=None) -> "ErrorModel":
        """Identify the parameters from a campaign by maximum likelihood
        (:func:`vecpin.identify.fit`). Sets ``b_`` (model parameters, SI),
        ``e0_`` (tracker-frame correction E_0), ``setup_`` (tracker pose), ``cov_``,
        ``noise_`` and ``report_``; returns self."""
        from vecpin.identification.fit import fit as _fit
        from vecpin.measurement.noise import NoiseModel
        noise = noise or NoiseModel.default(self.machine)
        theta, setup, cov, report = _fit(self, campaign, noise, remove_redundant=remove_redundant,
                                         max_iter=max_iter, underdetermined=underdetermined, progress=progress)
        n = 6 + self.n_parameters  # beyond: station poses and pivots, kept in the setup
        self.b_, self.e0_, self.setup_, self.cov_ = theta[6:n], theta[:6], setup, cov[:n, :n]
        self.noise_, self.report_ = noise, report
        return self

    def _check_fitted(self):
        if not hasattr(self, "b_"):
            from vecpin.errors import VecpinError
            raise VecpinError("the model is not fitted: call fit(campaign) or load a model file")

    @property
    def std_(self) -> np.ndarray:
        """Standard deviations of the model parameters b_ (SI; 0 for removed terms)."""
        self._check_fitted()
        return np.sqrt(np.diag(self.cov_)[6:])

    def predict(self, q: np.ndarray, tool: np.ndarray | float, frame: str = "tracker", features=None) -> np.ndarray:
        """Modelled tool tips (N,3) [m] for commands q (N,n) [m, rad] and tool
        lengths [m], in the tracker frame of the fitted campaign or the machine frame.
        ``features``: per-row time/temperature/directions, for models with effects."""
        self._check_fitted()
        if frame == "tracker" and any("tracker" in e.kinds for e in self.effects):
            from vecpin.identification.fit import predict_tracker
            return predict_tracker(self, q, tool, np.r_[self.e0_, self.b_], self.setup_, features, False)[0]
        tip = self.tool_tip(q, tool, self.b_, jacobian=False, features=features).tip
        if frame == "machine":
            return tip
        if frame != "tracker":
            raise ValueError("frame is 'tracker' or 'machine'")
        return self.setup_.to_tracker(tip)

    def predict_nominal(self, q: np.ndarray, tool: np.ndarray | float) -> np.ndarray:
        """Nominal tool tips (N,3) [m] placed with the tracker pose registered on the nominal
        kinematics (no E_0): the seed's 'uncompensated' reference."""
        self._check_fitted()
        return self.machine.tool_tip(q, tool) @ self.setup_.R.T + self.setup_.t

    def residuals(self, campaign, reregister: bool = False) -> np.ndarray:
        """Measured minus modelled tool tips (N,3) [m], tracker frame. ``reregister``:
        fit the tracker pose to this campaign first (the tracker was moved). Effects
        take time, temperature and approach directions from the campaign's rows."""
        self._check_fitted()
        feats = None
        if self.effects:
            from vecpin.measurement.features import Features
            feats = Features.from_campaign(campaign)
        if reregister:
            from vecpin.measurement.registration import registered_errors
            tip = self.tool_tip(campaign.q, campaign.tool, self.b_, jacobian=False, features=feats).tip
            return registered_errors(tip, campaign.xyz)
        from vecpin.identification.fit import predict_tracker
        theta = np.r_[self.e0_, self.b_]
        if not getattr(campaign, "mixed", False):
            return campaign.xyz - predict_tracker(self, campaign.q, campaign.tool, theta, self.setup_, feats, False)[0]
        # several stations (ball bar rows have no point: NaN)
        out = np.full((len(campaign), 3), np.nan)
        tip = self.tool_tip(campaign.q, campaign.tool, self.b_, jacobian=False, features=feats).tip
        for s in np.unique(campaign.station[campaign.tracker_rows]):
            rows = campaign.tracker_rows[campaign.station[campaign.tracker_rows] == s]
            if int(s) != 0 and int(s) not in self.setup_.stations:
                from vecpin.errors import VecpinError
                raise VecpinError(f"{campaign.source}: station {s} was not in the fitted campaign")
            out[rows] = campaign.xyz[rows] - self.setup_.to_tracker(tip[rows], int(s))
        return out

    def ballbar_residuals(self, campaign) -> np.ndarray:
        """Measured minus modelled ball bar radius [m] for the campaign's ball bar rows."""
        self._check_fitted()
        bb = campaign.ballbar_rows
        tip = self.tool_tip(campaign.q[bb], campaign.tool[bb], self.b_, jacobian=False).tip
        centres = np.array([self.setup_.pivots[int(p)] for p in campaign.pivot[bb]])
        return campaign.radius[bb] - np.linalg.norm(tip - centres, axis=1)

    def save(self, path) -> None:
        """Write the fitted model to a versioned JSON file (:mod:`vecpin.modelfile`)."""
        from vecpin.models.modelfile import save_model
        save_model(self, path)

    @staticmethod
    def load(path) -> "ErrorModel":
        from vecpin.models.modelfile import load_model
        return load_model(path)


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
                    out.append(Parameter(f"{a.name}.{c}.{labels[k][j]}", q, DEFAULT_PRIORS[q] * self.prior_scale, j, f"{a.name}.{c}"))
        return out

    def coefficients(self, b: np.ndarray) -> np.ndarray:
        """(K, n, 6) series coefficients from the parameter vector (zeros where an axis has fewer columns)."""
        A = np.zeros((self._K, self.machine.n_axes, 6))
        A[self._mask] = b[self._n_offsets():len(self.base_parameters)].reshape(-1, 6)
        return A

    def error_values(self, q: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(N, n, 6) values (dx, dy, dz [m], ex, ey, ez [rad]) of every axis' errors."""
        return np.einsum("pnk,knc->pnc", self._basis_values(q), self.coefficients(b))

    def _base_tool_tip(self, q, tool, b, jacobian=True) -> ModelTip:
        N = len(q)
        B = self._basis_values(q)
        A = self.coefficients(b)
        vals = np.einsum("pnk,knc->pnc", B, A)
        out = self.frames.tool_tip(q, vals[..., :3], vals[..., 3:], self._effective_tool(tool, b), jacobian)
        if not jacobian:
            return ModelTip(out.tip, None, None, out.tool_dir)
        Jv = np.concatenate([out.J_delta, out.J_eps], axis=-1)  # (N,3,n,6)
        J_coef = np.einsum("pinc,pnk->piknc", Jv, B)[:, :, self._mask, :].reshape(N, 3, -1)
        J_b = np.concatenate([self._offset_columns(tool, out.tool_dir), J_coef], axis=-1)
        dvals = np.einsum("pnk,knc->pnc", self._basis_values(q, derivative=True), A)
        J_q = out.J_q + np.einsum("pinc,pnc->pin", Jv, dvals)
        return ModelTip(out.tip, J_b, J_q, out.tool_dir)


class APModel(ErrorModel):
    """Axis-perturbation model (Paper I eq. 7-8; Section 3 eq. 26-29): every axis
    command is perturbed by a constant plus a sum of series in each axis' position.
    Parameter ``i->j.m`` is the coefficient of column m of f_ij (input axis i,
    output j), in the unit of axis j [m or rad]; ``j.offset`` is the constant of q_hat_j."""

    kind = "ap"

    def _model_parameters(self) -> list[Parameter]:
        axes = self.machine.axes
        out = [Parameter(f"{a.name}.offset", "length" if a.kind == "linear" else "angle",
                         DEFAULT_PRIORS["length" if a.kind == "linear" else "angle"] * self.prior_scale, 0, f"{a.name}.offset")
               for a in axes]
        labels = [B.labels() for B in self.bases]
        for m in range(1, self._K):
            for i, ai in enumerate(axes):
                if not self._mask[m, i]:
                    continue
                for aj in axes:
                    q = "length" if aj.kind == "linear" else "angle"
                    out.append(Parameter(f"{ai.name}->{aj.name}.{labels[i][m]}", q, DEFAULT_PRIORS[q] * self.prior_scale, m, f"{ai.name}->{aj.name}"))
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

    def _base_tool_tip(self, q, tool, b, jacobian=True) -> ModelTip:
        N, n = q.shape
        c, a = self.split(b)
        B = self._basis_values(q)[:, :, 1:]  # (N, n, K-1)
        qp = q + c + np.einsum("pim,mij->pj", B, a)
        kin = self.machine.kinematics(qp, self._effective_tool(tool, b), jacobian)
        tool_dir = kin.rotation[:, :, 2] * -1.0
        if not jacobian:
            return ModelTip(kin.tip, None, None, tool_dir)
        J = kin.jacobian  # (N,3,n) at the perturbed commands
        J_a = np.einsum("pxj,pim->pxmij", J, B)[:, :, self._mask[1:], :].reshape(N, 3, -1)
        J_b = np.concatenate([self._offset_columns(tool, tool_dir), J, J_a], axis=-1)
        D = np.einsum("pim,mij->pij", self._basis_values(q, derivative=True)[:, :, 1:], a)  # d q_hat_j / d q_i
        J_q = J + np.einsum("pxj,pij->pxi", J, D)
        return ModelTip(kin.tip, J_b, J_q, tool_dir)


MODELS = {"6dof": SixDofModel, "ap": APModel}


def make_model(kind: str, machine: Machine, order: int = 6, **kw) -> ErrorModel:
    """Build a model by name: "6dof" or "ap"."""
    try:
        cls = MODELS[kind]
    except KeyError:
        from vecpin.errors import VecpinError
        raise VecpinError(f"unknown model '{kind}' (choose 6dof or ap)") from None
    return cls(machine, order, **kw)
