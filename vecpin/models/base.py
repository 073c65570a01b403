"""Geometric error models of a machine: the common base of the 6-DoF and AP models.

Both map axis commands ``q`` [m, rad] and a tool length [m] to the tool tip in the
machine base frame, with analytic Jacobians with respect to their parameters ``b``
and to ``q``. Parameters are SI: translations in m, rotations in rad, AP
perturbations in the unit of their output axis.

* :class:`~vecpin.models.sixdof.SixDofModel`: ``F = T_1(q_1) E_1(q_1) ... T_n(q_n) E_n(q_n)``
  (eq. 3), each ``E_k`` an exact transform whose three translations and three rotations
  are series in ``q_k`` (eq. 5-6), carried by extra joints in the Pinocchio chain.
* :class:`~vecpin.models.ap.APModel`: ``F = F_n(q + q_hat(q))`` (eq. 7) with
  ``q_hat_j = c_j + sum_i f_ij(q_i)`` (eq. 8, 28).

Both carry the mechanical offsets a controller can change: ``T_offset``, the
gauge-line correction along the tool, and optionally a length correction per tool.
The tracker-frame correction ``E_0`` belongs to the measurement setup and is added
by the estimator (:mod:`vecpin.identification`). Effects
(:mod:`vecpin.models.effects`) add optional terms.

The estimator API follows scikit-learn: configuration in ``__init__``, learning in
:meth:`ErrorModel.fit`, learned state with a trailing underscore (``b_``, ``e0_``,
``setup_``, ``cov_``, ``noise_``, ``report_``; ``range_`` once the errors are held
beyond the measured commands: after every fit, and on reading a model file, on the axes
that stood still in the campaign, :func:`~vecpin.models.recorded.still_hold`).

Parameters are ordered by priority (offsets, then every order-0 term, then order 1,
...): redundancy removal keeps the earlier of two terms that move the tool tip alike.
"""
from __future__ import annotations

import numpy as np

from vecpin.errors import InputError, VecpinError
from vecpin.identification.fit import fit as ml_fit
from vecpin.identification.likelihood import Likelihood, predict_tracker
from vecpin.kinematics.machine import Machine
from vecpin.measurement.features import Features
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.registration import registered_errors
from vecpin.models import modelfile
from vecpin.models.basis import AxisBasis, bases_text, union_basis
from vecpin.models.effects.base import TipContext
from vecpin.models.parameters import DEFAULT_PRIORS, Parameter
from vecpin.models.recorded import still_hold
from vecpin.models.spec import ModelSpec
from vecpin.models.tips import ModelPoints, ModelTip, check_frame
from vecpin.units import MM_PER_M
from vecpin.threads import one_blas_thread

MODELS: dict[str, type["ErrorModel"]] = {}


def register_model(cls: type["ErrorModel"]) -> type["ErrorModel"]:
    """Make a model kind available by its ``kind`` (decorator); a kind that sets no
    ``display_name`` of its own is shown by its ``kind``."""
    if "display_name" not in cls.__dict__:
        cls.display_name = cls.kind
    MODELS[cls.kind] = cls
    return cls


class ErrorModel:
    """Base of the error models: bases, offsets, parameter bookkeeping, estimator API.

    ``order``: series order on every axis (eq. 5). ``basis="fourier"`` (default) uses
    Chebyshev polynomials over the travel, except a Fourier series on rotary axes
    that travel more than a turn (errors that repeat every turn, which Chebyshev
    needs a high order for); ``basis="chebyshev"`` is the seed's choice everywhere;
    ``bases`` overrides everything with one :class:`~vecpin.models.basis.AxisBasis`
    per axis (column 0 must be the constant). ``tool_lengths`` [m] adds a length
    correction per tool; ``prior_scale`` multiplies every prior sd (Σ_b), ``prior`` (a SmoothPrior) sets them.
    The arguments make the model's :class:`~vecpin.models.spec.ModelSpec` (``spec``), from
    which it is built; :meth:`from_spec` builds a model from a spec.
    """

    kind = "base"
    display_name = "base"  # the kind as printed in tables, figures and reports (e.g. '6-DoF')

    def __init__(self, machine: Machine, order: int = 6, basis: str = "fourier",
                 tool_lengths: list[float] | None = None, prior_scale: float = 1.0,
                 bases: list[AxisBasis] | None = None, effects: list | None = None, prior=None):
        self.machine = machine
        self.spec = ModelSpec.of(self.kind, machine, order, basis, tool_lengths, prior_scale, bases, effects, prior)
        self.order, self.prior_scale = self.spec.order, self.spec.prior_scale
        self.tool_lengths = None if self.spec.tool_lengths is None else list(self.spec.tool_lengths)
        self.bases = list(self.spec.bases)
        self._K = max(B.size for B in self.bases)
        self._mask = np.array([[j < B.size for B in self.bases] for j in range(self._K)])  # (K, n)
        self.base_parameters: list[Parameter] = self.spec.priors_of(self._offset_parameters() + self._series_parameters(
            self._mask, [B.labels() for B in self.bases]), machine.axis_names)   # a smoothness prior's (models.prior)
        self.effects = list(self.spec.effects)
        self.parameters: list[Parameter] = self.base_parameters + [p for e in self.effects for p in e.parameters()]

    @staticmethod
    def from_spec(machine: Machine, spec: ModelSpec) -> "ErrorModel":
        """The unfitted model of ``spec`` on ``machine`` (its kind's constructor)."""
        try:
            cls = MODELS[spec.kind]
        except KeyError:
            raise InputError(f"`kind` '{spec.kind}': unknown model (choose {' or '.join(MODELS)})") from None
        return cls(machine, **spec.options())

    @property
    def basis_kind(self) -> str:
        """How the bases were made: "fourier", "chebyshev" or "custom" (:data:`~vecpin.models.spec.BASIS_RULES`)."""
        return self.spec.basis

    def _offset_parameters(self) -> list[Parameter]:
        prior = DEFAULT_PRIORS["offset"] * self.prior_scale
        return [Parameter("T_offset", "length", prior, -1, "offsets")] + [
            Parameter(f"tool[{L * MM_PER_M:.3f}mm]", "length", prior, -1, "offsets") for L in self.tool_lengths or []]

    def _series_parameters(self, mask: np.ndarray, labels: list[list[str]]) -> list[Parameter]:
        """The terms after the offsets by priority (``assemble``'s order), axis i's column j if ``mask[j, i]``."""
        raise NotImplementedError

    def candidate_columns(self, S: np.ndarray, tool: np.ndarray, tool_dir: np.ndarray,
                          functions: list[tuple[list[str], np.ndarray]]) -> tuple[np.ndarray, list[Parameter]]:
        """For the model choice, every term a candidate basis of this kind can have: (d point / d psi
        (N,3,P) [m per prior sigma], their :class:`Parameter`): ``assemble`` over the union of the axes'
        candidate functions ``functions[i]`` = (names, values (N, F_i)), times this model's priors. A
        candidate's own Jacobian at zero error, prior-scaled: the offsets, the terms of no function
        (constants) and those whose ``axis`` and ``label`` name its functions."""
        B, mask, labels = union_basis(functions, len(tool))
        terms = self._offset_parameters() + self._series_parameters(mask, labels)
        D = self.assemble(S, B, tool, tool_dir, mask)
        D *= np.array([p.prior for p in terms])
        return D, terms

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
        """(N, n, K) basis values (or derivatives) of every axis, zero-padded to K columns.
        Held (:meth:`hold_beyond_measured`): every error at its value at the edge of
        ``range_`` (per axis [m, rad]; derivative zero beyond)."""
        held = getattr(self, "range_", None)
        inside = None
        if held is not None:
            inside = (q >= held[0]) & (q <= held[1])
            q = np.clip(q, held[0], held[1])
        out = np.zeros((len(q), self.machine.n_axes, self._K))
        for k, B in enumerate(self.bases):
            if not derivative:
                out[:, k, :B.size] = B.values(q[:, k])
            else:
                d = B.derivative(q[:, k])
                out[:, k, :B.size] = d if inside is None else d * inside[:, k, None]
        return out

    # --------------------------------------------------------------- kinematics
    def _base_tool_tip(self, q: np.ndarray, tool: np.ndarray, b: np.ndarray, jacobian: bool, *,
                       frame: str = "base", point=0, offset=None) -> ModelTip:
        raise NotImplementedError

    def _base_workpiece_points(self, q: np.ndarray, p_wp: np.ndarray, b: np.ndarray, jacobian: bool) -> ModelPoints:
        raise NotImplementedError

    def effect_slices(self) -> list[tuple]:
        """(effect, slice of its parameters in b) for every effect."""
        out, k = [], len(self.base_parameters)
        for e in self.effects:
            out.append((e, slice(k, k + e.n_parameters)))
            k += e.n_parameters
        return out

    def with_effects(self, effects: list) -> "ErrorModel":
        """A new, unfitted model of the same spec with these effects instead of its own."""
        return ErrorModel.from_spec(self.machine, self.spec.with_effects(effects))

    def geometric_part(self) -> tuple["ErrorModel", list]:
        """(this fitted model with only its geometric effects, the row-dependent effects
        left out): what tables can carry. Parameters, covariance and setup are kept."""
        self._check_fitted()
        dropped = [e for e in self.effects if not e.geometric]
        if not dropped:
            return self, []
        kept = [e for e in self.effects if e.geometric]
        new = self.with_effects(kept)
        idx = list(range(len(self.base_parameters)))
        idx += [i for e, sl in self.effect_slices() if e.geometric for i in range(sl.start, sl.stop)]
        full = np.r_[np.arange(6), 6 + np.array(idx, int)]
        new.b_, new.e0_, new.setup_ = self.b_[idx], self.e0_, self.setup_
        new.cov_ = self.cov_[np.ix_(full, full)]
        new.noise_, new.report_ = self.noise_, self.report_
        for attr in ("selection_", "zone_", "range_"):
            if hasattr(self, attr):
                setattr(new, attr, getattr(self, attr))
        return new, dropped

    @property
    def row_dependent(self) -> bool:
        """True when an effect depends on the rows (time, temperature, move order)."""
        return any(not e.geometric for e in self.effects)

    def tool_tip(self, q: np.ndarray, tool: np.ndarray | float, b: np.ndarray, jacobian: bool = True,
                 features: Features | None = None, *, frame: str = "base", point: int | np.ndarray = 0,
                 offset: np.ndarray | None = None) -> ModelTip:
        """Tool tip of the model with parameters b (SI). ``frame``: "base" (the machine
        frame a floor tracker sees, default) or "workpiece" (relative to the model's
        workpiece frame: what compensation corrects; the base frame on a machine without
        a workpiece). ``point``: tool point index, one or per pose; ``offset`` (3,) or
        (N,3) [m]: a target offset in the tool link frame. ``features`` are needed when
        effects depend on the rows (geometric effects need none). ``jacobian="q"``: d tip / d q,
        and d tip / d b only where effects need it (a trial point of the fit)."""
        q = np.atleast_2d(np.asarray(q, float))
        N = len(q)
        tool = np.broadcast_to(np.asarray(tool, float), (N,))
        frame = check_frame(frame)
        nb = len(self.base_parameters)
        kinematic = self._kinematic_effects(features)
        where = {"frame": frame, "point": point, "offset": offset}
        if not kinematic:
            return self._plain_tip(q, tool, b, jacobian, **where)
        jacobian = bool(jacobian)   # effects: every column
        if frame == "workpiece" and self.machine.has_workpiece and any("tip" in e.kinds for e, _ in kinematic):
            return self._relative_tip(q, tool, b, jacobian, features, point, offset)
        q_eff, S_all = self._command_effects(q, b, kinematic, features)
        out = self._base_tool_tip(q_eff, tool, b[:nb], jacobian, **where)  # tip effects need only tip and tool direction
        tip = out.tip.copy()
        J_cmd = self._command_columns(out.J_q, S_all, N) if jacobian else None
        J_tip = np.zeros_like(J_cmd) if jacobian else None
        ctx = TipContext(self.machine, q_eff, out.tip, out.tool_dir)
        grad = np.zeros((N, 3, 3))
        for e, sl in kinematic:
            if "tip" in e.kinds:
                D = e.tip(ctx, features)
                tip += np.einsum("pik,k->pi", D, b[sl])
                if jacobian:
                    J_tip[:, :, sl.start - nb:sl.stop - nb] += D
                    grad += e.tip_gradient(ctx, features, b[sl])
        if not jacobian:
            return ModelTip(tip, None, None, out.tool_dir, out.rotation)
        # tip displacements that move with the tip (a rotation's lever arm): chain rule
        M = np.eye(3) + grad
        J_b = np.concatenate([M @ out.J_b, M @ J_cmd + J_tip], axis=-1)
        return ModelTip(tip, J_b, M @ out.J_q, out.tool_dir, M @ out.rotation)

    def workpiece_points(self, q: np.ndarray, p_wp: np.ndarray, b: np.ndarray, jacobian: bool = True,
                         features: Features | None = None) -> ModelPoints:
        """Points fixed in the model's (erroneous) workpiece frame at p_wp (3,) or (N,3) [m],
        in the base frame, with d/db, d/dq and d/dp_wp: what a floor tracker sees of a
        target in a table nest. Command effects move the table axes too; tip effects act
        on the tool only."""
        q = np.atleast_2d(np.asarray(q, float))
        N = len(q)
        nb = len(self.base_parameters)
        p_wp = np.broadcast_to(np.asarray(p_wp, float), (N, 3))
        kinematic = self._kinematic_effects(features)
        q_eff, S_all = self._command_effects(q, b, kinematic, features)
        out = self._base_workpiece_points(q_eff, p_wp, b[:nb], jacobian)
        if not jacobian or nb == len(self.parameters):
            return out
        J_b = np.concatenate([out.J_b, self._command_columns(out.J_q, S_all, N)], axis=-1)
        return out._replace(J_b=J_b)

    def _kinematic_effects(self, features) -> list[tuple]:
        kinematic = [(e, sl) for e, sl in self.effect_slices() if "command" in e.kinds or "tip" in e.kinds]
        if kinematic and features is None and any(not e.geometric for e, _ in kinematic):
            raise VecpinError("this model has effects (" + ", ".join(e.label for e in self.effects) +
                              ") that depend on the rows: evaluate it on a campaign (time, temperature, row order)")
        return kinematic

    def _command_effects(self, q, b, kinematic, features):
        """Commands perturbed by the command effects, and their (slice, S) pairs."""
        S_all = []
        q_eff = q.copy()
        for e, sl in kinematic:
            if "command" in e.kinds:
                S = e.command(q, features)
                q_eff = q_eff + np.einsum("pnk,k->pn", S, b[sl])
                S_all.append((sl, S))
        return q_eff, S_all

    def _command_columns(self, J_q, S_all, N) -> np.ndarray:
        """Effect columns (N,3,P_effects): command effects through d point / d q."""
        nb = len(self.base_parameters)
        J = np.zeros((N, 3, len(self.parameters) - nb))
        for sl, S in S_all:
            J[:, :, sl.start - nb:sl.stop - nb] += np.einsum("pin,pnk->pik", J_q, S)
        return J

    def _relative_tip(self, q, tool, b, jacobian, features, point, offset) -> ModelTip:
        """The tip relative to the workpiece from the base-frame tip (with tip effects,
        which act in the base frame) and the workpiece frame: ``p_rel = R_w^T (p - p_w)``,
        ``d p_rel = R_w^T (d p - d W p_rel)`` with ``W p_rel`` the workpiece-fixed point
        at the tip."""
        base = self.tool_tip(q, tool, b, jacobian, features, frame="base", point=point, offset=offset)
        w0 = self.workpiece_points(q, np.zeros(3), b, True, features)
        Rw = w0.J_p
        RwT = np.swapaxes(Rw, 1, 2)
        rel = np.einsum("pij,pj->pi", RwT, base.tip - w0.xyz)
        u = np.einsum("pij,pj->pi", RwT, base.tool_dir)
        if not jacobian:
            return ModelTip(rel, None, None, u, RwT @ base.rotation)
        wp = self.workpiece_points(q, rel, b, True, features)
        return ModelTip(rel, RwT @ (base.J_b - wp.J_b), RwT @ (base.J_q - wp.J_q), u, RwT @ base.rotation)

    def _plain_tip(self, q, tool, b, jacobian, **where) -> ModelTip:
        """The base kinematics; effect columns (tracker-frame effects only) are zero here."""
        nb = len(self.base_parameters)
        out = self._base_tool_tip(q, tool, b[:nb], jacobian, **where)
        if not jacobian or nb == len(self.parameters) or out.J_b is None:
            return out
        pad = np.zeros(out.J_b.shape[:2] + (len(self.parameters) - nb,))
        return out._replace(J_b=np.concatenate([out.J_b, pad], axis=-1))

    def tracker_terms(self, y: np.ndarray, features: Features, b: np.ndarray):
        """Tracker-frame effects at readings y (N,3): (shift (N,3), d shift / d b (N,3,P),
        d shift / d y (N,3,3))."""
        N, P = len(y), len(self.parameters)
        shift, D, grad = np.zeros((N, 3)), np.zeros((N, 3, P)), np.zeros((N, 3, 3))
        for e, sl in self.effect_slices():
            if "tracker" in e.kinds:
                De = e.tracker(y, features)
                shift += np.einsum("pik,k->pi", De, b[sl])
                D[:, :, sl] = De
                grad += e.tracker_gradient(y, features, b[sl])
        return shift, D, grad

    def label(self) -> str:
        """The kind and bases in words, e.g. '6-DoF with Chebyshev order 6 on every axis' or
        'AP with Chebyshev order 4 on X, Y, Z and B; Fourier order 6 with a trend of order 2 on C'."""
        return bases_text(self.display_name, self.machine.axis_names, [B.readable() for B in self.bases]) + \
            (f", a {self.spec.prior.kernel} smoothness prior from the evidence" if self.spec.prior is not None else "")

    # --------------------------------------------------------------- estimator API
    @one_blas_thread
    def fit(self, campaign, noise: NoiseModel | None = None, *, remove_redundant: bool = True, max_iter: int = 30,
            underdetermined: bool = False, progress=None) -> "ErrorModel":
        """Identify the parameters from a campaign by maximum likelihood
        (:func:`vecpin.identification.fit.fit`). Sets ``b_`` (model parameters, SI),
        ``e0_`` (tracker-frame correction E_0), ``setup_`` (tracker pose), ``cov_``,
        ``noise_`` and ``report_``; returns self."""
        noise = noise or NoiseModel.default(self.machine)
        self.range_ = None  # a former fit's hold (hold_beyond_measured) has no say in this one
        points: dict = {}
        theta, setup, cov, report = ml_fit(self, campaign, noise, remove_redundant=remove_redundant,
                                           max_iter=max_iter, underdetermined=underdetermined, progress=progress,
                                           points=points)
        n = 6 + self.n_parameters  # beyond: station poses and pivots, kept in the setup
        self.b_, self.e0_, self.setup_, self.cov_ = theta[6:n], theta[:6], setup, cov[:n, :n]
        self.noise_, self.report_ = noise, report
        self.range_ = still_hold(self)   # an axis that stood still: its errors held where it stood
        same = not (self.effects or points["folded"] or self.range_ is not None)   # residuals: the same numbers
        self._fitted_points = (campaign, np.r_[self.e0_, self.b_], self.setup_, points["y"]) if same else None
        return self

    def hold_beyond_measured(self) -> "ErrorModel":
        """Hold every error of this fitted model at its value at the edge of the commands
        its campaign measured (``report_.measured_range``), as the tables do: its
        predictions beyond them no longer extrapolate the series (``range_``; an AP model
        with Fourier series of order 12 on a UR10 whose joint 1 was measured over 128°:
        12.3 mm held-out mean just beyond, 0.84 mm held). Not kept in the model file; a
        new fit drops it. Returns self."""
        self._check_fitted()
        span = self.report_.measured_range
        missing = [a.name for a in self.machine.axes if a.name not in span]
        if missing:
            raise VecpinError(f"the fit report has no measured range of {', '.join(missing)} (a damaged or edited model "
                              "file): the range to hold the errors in is unknown; fit the model again")
        self.range_ = tuple(np.array([float(a.to_si(span[a.name][j])) for a in self.machine.axes]) for j in (0, 1))
        return self

    def _check_fitted(self):
        if not hasattr(self, "b_"):
            raise VecpinError("the model is not fitted: call fit(campaign) or load a model file")

    @property
    def std_(self) -> np.ndarray:
        """Standard deviations of the model parameters b_ (SI; 0 for removed terms)."""
        self._check_fitted()
        return np.sqrt(np.diag(self.cov_)[6:])

    def predict(self, q: np.ndarray, tool: np.ndarray | float = 0.0, frame: str = "workpiece", features=None, *,
                point: int | np.ndarray = 0, offset: np.ndarray | None = None, return_std: bool = False):
        """The modelled tool-tip error (N,3) [m] at commands q (N,n) [m, rad] and tool lengths
        [m]: the modelled tip minus the nominal tip, relative to the workpiece ("workpiece",
        what compensation corrects; the base frame on a machine without a workpiece) or in
        the machine base frame ("machine"), the frame's axes either way. The one quantity
        ``predict`` gives, here and on :class:`~vecpin.fitting.estimator.ErrorModelCV`; the
        modelled tips themselves (where a tracker reads them) are :meth:`predict_tip`.
        ``point``, ``offset``: tool point and target offset [m] (tool link frame); ``features``:
        per-row time/temperature/directions, for models with row-dependent effects.
        ``return_std``: also its standard deviation (N,3) [m] per coordinate, the fit's
        covariance of the model parameters (``cov_``, E_0 left out) through d tip / d b at
        ``b_`` (linearised; 0 for terms the fit removed): what the measurement noise leaves
        uncertain, not what the model's bases cannot describe."""
        self._check_fitted()
        if frame not in ("machine", "workpiece"):
            raise InputError(f"`frame` '{frame}': the error is 'workpiece' (relative to the table) or 'machine' "
                             "(base frame); the modelled tips in the tracker frame are predict_tip's")
        where = {"frame": "base" if frame == "machine" else "workpiece", "point": point, "offset": offset}
        q = np.atleast_2d(np.asarray(q, float))
        out = self.tool_tip(q, tool, self.b_, jacobian=return_std, features=features, **where)
        error = out.tip - self.machine.tool_tip(q, tool, **where)
        if not return_std:
            return error
        var = np.einsum("nip,pk,nik->ni", out.J_b, self.cov_[6:, 6:], out.J_b)
        return error, np.sqrt(np.clip(var, 0.0, None))

    def predict_tip(self, q: np.ndarray, tool: np.ndarray | float, frame: str = "tracker", features=None, *,
                    point: int | np.ndarray = 0, offset: np.ndarray | None = None) -> np.ndarray:
        """Modelled tool tips (N,3) [m] for commands q (N,n) [m, rad] and tool lengths
        [m]: in the tracker frame of the fitted campaign ("tracker", what the tracker reads),
        the machine base frame ("machine") or relative to the workpiece ("workpiece").
        ``point``, ``offset``: tool point and target offset [m] (tool link frame).
        ``features``: per-row time/temperature/directions, for models with effects."""
        self._check_fitted()
        if frame not in ("tracker", "machine", "workpiece"):
            raise InputError(f"`frame` '{frame}': the tips are in 'tracker', 'machine' or 'workpiece'")
        if frame == "tracker":
            return predict_tracker(self, q, tool, np.r_[self.e0_, self.b_], self.setup_, features, False,
                                   point=point, offset=offset)[0]
        return self.tool_tip(q, tool, self.b_, jacobian=False, features=features, point=point, offset=offset,
                             frame="base" if frame == "machine" else "workpiece").tip

    def predict_nominal(self, q: np.ndarray, tool: np.ndarray | float, *, point: int | np.ndarray = 0,
                        offset: np.ndarray | None = None) -> np.ndarray:
        """Nominal tool tips (N,3) [m] placed with the tracker pose registered on the nominal
        kinematics (no E_0): the seed's 'uncompensated' reference."""
        self._check_fitted()
        return self.machine.tool_tip(q, tool, frame="base", point=point, offset=offset) @ self.setup_.R.T + self.setup_.t

    def row_residuals(self, campaign, features: Features | None = None):
        """The fitted model's residual of every row through the one likelihood (an
        :class:`~vecpin.identification.likelihood.Evaluation` without Jacobians): ``metric``
        (N,3) [m] measured minus modelled, each tracker or nest row in its station's frame
        (a range or a ball bar radius in column 0 on rows read that way); ``w`` (N,3) the
        same whitened by the row's noise (instrument and positioning); ``valid`` (N,3) the
        row's real equations; ``y`` (N,3) [m] the modelled instrument-frame points (NaN on
        ball bar rows). Tracker-frame effects act as in the fit (on the rows of the
        station they concern). ``features``: per-row time, temperature, approach
        directions and stations (default: from the campaign's own rows). Every residual
        vecpin reports of a fitted model comes from here."""
        self._check_fitted()
        for s in np.unique(campaign.station[campaign.instrument != "ballbar"]):
            if int(s) != 0 and int(s) not in self.setup_.stations:
                raise VecpinError(f"{campaign.source}: station {s} was not in the fitted campaign")
        if features is None and self.effects:
            features = Features.from_campaign(campaign)
        lik = Likelihood(self, campaign, self.noise_, setup=self.setup_, features=features)
        return lik.evaluate(lik.theta_of(self), jacobian=False)

    def residuals(self, campaign, reregister: bool = False) -> np.ndarray:
        """Measured minus modelled points (N,3) [m], each tracker or nest row in its
        station's frame (NaN on rows without a point, e.g. ball bar rows), from
        :meth:`row_residuals`. ``reregister``: fit the tracker pose to this campaign first
        (the tracker was moved). Effects take time, temperature and approach directions
        from the campaign's rows."""
        kept = getattr(self, "_fitted_points", None)   # the fit's own points of these rows at these parameters
        same = kept is not None and kept[0] is campaign and kept[2] is self.setup_ and self.range_ is None
        y = kept[3] if same and np.array_equal(kept[1], np.r_[self.e0_, self.b_]) else self.row_residuals(campaign).y
        if not reregister:
            return campaign.xyz - y
        out = np.full((len(campaign), 3), np.nan)
        for s in np.unique(campaign.station[campaign.instrument != "ballbar"]):
            rows = np.flatnonzero((campaign.instrument != "ballbar") & (campaign.station == s))
            p = self.setup_.pose(int(s))
            machine_frame = (y[rows] - p[1]) @ p[0]  # back to (corrected) machine coordinates
            out[rows] = registered_errors(machine_frame, campaign.xyz[rows])
        return out

    def nominal_residuals(self, campaign) -> np.ndarray:
        """Measured minus nominal points (N,3) [m] with the fitted tracker poses, nests and
        targets but no model (b = 0, no E_0): the 'uncompensated' column of the reports."""
        self._check_fitted()
        if campaign.plain and not campaign.mixed:
            return campaign.xyz - self.predict_nominal(campaign.q, campaign.tool)
        feats = Features.from_campaign(campaign) if self.effects else None
        lik = Likelihood(self, campaign, self.noise_, setup=self.setup_, features=feats)
        return campaign.xyz - lik.predicted_points(np.zeros(lik.n_unknowns))

    def ballbar_residuals(self, campaign) -> np.ndarray:
        """Measured minus modelled ball bar radius [m] for the campaign's ball bar rows."""
        self._check_fitted()
        bb = campaign.ballbar_rows
        tip = self.tool_tip(campaign.q[bb], campaign.tool[bb], self.b_, jacobian=False, point=campaign.point[bb]).tip
        centres = np.array([self.setup_.pivots[int(p)] for p in campaign.pivot[bb]])
        return campaign.radius[bb] - np.linalg.norm(tip - centres, axis=1)

    def save(self, path) -> None:
        """Write the fitted model to a versioned JSON file (:mod:`vecpin.models.modelfile`)."""
        self._check_fitted()
        modelfile.save_model(self, path)

    @staticmethod
    def load(path) -> "ErrorModel":
        """Read a model file (any version this vecpin reads)."""
        return modelfile.load_model(path, ErrorModel.from_spec)


def make_model(kind: str, machine: Machine, order: int = 6, **kw) -> ErrorModel:
    """Build a model by name: "6dof" or "ap" (or any registered kind); ``kw``: the
    constructor's options (:meth:`ModelSpec.of`)."""
    return ErrorModel.from_spec(machine, ModelSpec.of(kind, machine, order, **kw))
