"""An error model whose ``fit`` makes the model choice (scikit-learn's ``RidgeCV`` pattern).

:class:`ErrorModelCV` is configured in its constructor (what to fix of the model, the
noise, the folds), learns in :meth:`ErrorModelCV.fit` (the kind, the bases and the order
chosen on held-out data where not fixed, then the maximum-likelihood fit), keeps what it
learned with a trailing underscore (``model_``, ``choice_``, ``run_``) and predicts the
tool-tip error with its standard deviation (:meth:`ErrorModelCV.predict`).

Its fit is :func:`vecpin.workflows.fitting.fit_campaign`, the one fitting path: ``vecpin
fit`` runs this class, and ``vecpin.fit`` is that function.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from vecpin.errors import VecpinError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.planning.zones import Zone
from vecpin.workflows.fitting import fit_campaign


class ErrorModelCV:
    """The error model of ``machine`` the data choose. Every argument after ``machine`` is
    :func:`~vecpin.workflows.fitting.fit_campaign`'s: ``noise`` (default: the tracker's
    native spherical model), ``kind`` ("auto", "6dof", "ap"), ``basis``, ``order`` ("auto"
    or a whole number): what to fix of the model (default: the data choose all three);
    ``tool_corrections``, ``prior_scale``, ``underdetermined``, ``folds`` (of the choice's
    cross-validation, grouped by command), ``zone`` ({axis: (low, high)} mm/deg),
    ``noise_from_data``, ``nest_heights`` ({nest id: mm above the table face}), ``progress``.

    After :meth:`fit`: ``model_`` (the fitted :class:`~vecpin.models.ErrorModel`),
    ``choice_`` (the :class:`~vecpin.selection.choice.ModelChoice`, None when nothing was
    left to choose), ``run_`` (the :class:`~vecpin.workflows.fitting.FitRun`: its
    ``lines()`` are what ``vecpin fit`` prints)."""

    def __init__(self, machine: Machine, noise: NoiseModel | None = None, *, kind: str = "auto", basis: str = "auto",
                 order: int | str = "auto", tool_corrections: bool = False, prior_scale: float = 1.0,
                 underdetermined: bool = False, folds: int = 5, zone: Zone | None = None,
                 noise_from_data: bool | None = None, nest_heights: dict | None = None,
                 progress: Callable[[str], None] | None = None):
        self.machine, self.noise = machine, noise
        self.kind, self.basis, self.order = kind, basis, order
        self.tool_corrections, self.prior_scale, self.underdetermined = tool_corrections, prior_scale, underdetermined
        self.folds, self.zone, self.noise_from_data, self.progress = folds, zone, noise_from_data, progress
        self.nest_heights = nest_heights

    def fit(self, campaign: Campaign) -> "ErrorModelCV":
        """Choose (where not fixed) and fit the model of ``campaign``; returns self."""
        run = fit_campaign(self.machine, campaign, **self.get_params())
        self.run_, self.model_, self.choice_ = run, run.model, run.choice
        return self

    def predict(self, q: np.ndarray, tool: np.ndarray | float = 0.0, *, frame: str = "workpiece",
                return_std: bool = False, features=None, point: int | np.ndarray = 0,
                offset: np.ndarray | None = None):
        """The predicted tool-tip error (N,3) [m] at commands q (N,n) [m, rad] and tool
        lengths [m], relative to the workpiece (``frame="workpiece"``, what compensation
        corrects) or in the machine base frame (``"machine"``); with ``return_std``, also
        its standard deviation (N,3) [m] from the fit's covariance: the noise's share, not a
        misfit of the chosen model (:meth:`~vecpin.models.ErrorModel.predict_error`)."""
        if not hasattr(self, "model_"):
            raise VecpinError("the estimator is not fitted: call fit(campaign) first")
        return self.model_.predict_error(q, tool, frame, features, point=point, offset=offset, return_std=return_std)

    _PARAMS = ("noise", "kind", "basis", "order", "tool_corrections", "prior_scale", "underdetermined", "folds",
               "zone", "noise_from_data", "nest_heights", "progress")

    def get_params(self) -> dict:
        """The settings given to the constructor, by name (scikit-learn's contract; ``machine`` apart)."""
        return {k: getattr(self, k) for k in self._PARAMS}

    def set_params(self, **params) -> "ErrorModelCV":
        """Change settings by name before the next :meth:`fit`; an unknown name is refused."""
        unknown = sorted(set(params) - set(self._PARAMS))
        if unknown:
            raise VecpinError(f"ErrorModelCV has no setting {', '.join(unknown)}: its settings are "
                              f"{', '.join(self._PARAMS)}")
        for k, v in params.items():
            setattr(self, k, v)
        return self

    @property
    def best_score_(self) -> float | None:
        """The chosen model's held-out score: minus its mean held-out distance [mm] in the
        model choice's cross-validation (higher is better, scikit-learn's sign); None when
        nothing was left to choose."""
        if not hasattr(self, "model_"):
            raise VecpinError("the estimator is not fitted: call fit(campaign) first")
        return None if self.choice_ is None else -float(self.choice_.chosen.mean)

    def score(self, campaign: Campaign) -> float:
        """Minus the mean distance [mm] of ``campaign``'s measured points from the fitted
        model's, each tracker or nest row in the fit's tracker frame (a campaign measured with
        the same tracker pose, e.g. a validation run): higher is better, scikit-learn's sign."""
        if not hasattr(self, "model_"):
            raise VecpinError("the estimator is not fitted: call fit(campaign) first")
        d = np.linalg.norm(self.model_.residuals(campaign), axis=1)
        return -float(np.nanmean(d) * 1000.0)

    def save(self, path) -> None:
        """Write the fitted model's file (:meth:`~vecpin.models.ErrorModel.save`)."""
        if not hasattr(self, "model_"):
            raise VecpinError("the estimator is not fitted: call fit(campaign) first")
        self.model_.save(path)
