"""An error model whose ``fit`` makes the model choice (scikit-learn's ``RidgeCV`` pattern).

:class:`ErrorModelCV` is configured in its constructor (the settings of
:data:`vecpin.fitting.problem.DEFAULTS`, the defaults of ``vecpin fit`` and ``vecpin.fit``),
learns in :meth:`ErrorModelCV.fit` (a :class:`~vecpin.fitting.problem.FitProblem` solved: the
kind, the bases and the order chosen on held-out data where not fixed, then the
maximum-likelihood fit), keeps what it learned with a trailing underscore (``model_``,
``choice_``, ``result_``) and predicts what :meth:`vecpin.models.ErrorModel.predict` does:
the tool-tip error, modelled minus nominal tip [m], relative to the workpiece by default.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from vecpin.errors import VecpinError
from vecpin.fitting.problem import FitProblem
from vecpin.fitting.settings import DEFAULTS, default
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaignrows import Campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.planning.zones import Zone


class ErrorModelCV:
    """The error model of ``machine`` the data choose. ``noise``: a :class:`NoiseModel`, None
    (the tracker's native spherical model, its level taken from the data) or an instrument's
    name; every other argument is a fit setting of :data:`~vecpin.fitting.problem.DEFAULTS`
    (``kind``, ``basis``, ``order``: what to fix of the model, default: the data choose all
    three; ``tool_corrections``, ``prior_scale``, ``underdetermined``, ``cv`` (a number of folds
    or one fold label per row), ``zone`` ({axis: (low, high)} mm/deg), ``noise_from_data``,
    ``nest_heights`` ({nest id: mm above the table face}), ``table_face`` ({axis: (distance mm, the
    indicator's change µm)})); ``progress``: a callback for
    progress lines.

    After :meth:`fit`: ``model_`` (the fitted :class:`~vecpin.models.ErrorModel`),
    ``choice_`` (the :class:`~vecpin.selection.choice.ModelChoice`, None when nothing was
    left to choose), ``result_`` (the :class:`~vecpin.fitting.problem.FitResult`)."""

    def __init__(self, machine: Machine, noise: NoiseModel | str | None = None, *, kind: str = default("kind"),
                 basis: str = default("basis"), order: int | str = default("order"),
                 tool_corrections: bool = default("tool_corrections"), prior_scale: float = default("prior_scale"),
                 underdetermined: bool = default("underdetermined"), cv: int | np.ndarray = default("cv"),
                 zone: Zone | None = default("zone"), noise_from_data: bool | None = default("noise_from_data"),
                 nest_heights: dict | None = default("nest_heights"), table_face: dict | None = default("table_face"),
                 progress: Callable[[str], None] | None = None):
        self.machine, self.noise = machine, noise
        self.kind, self.basis, self.order = kind, basis, order
        self.tool_corrections, self.prior_scale, self.underdetermined = tool_corrections, prior_scale, underdetermined
        self.cv, self.zone, self.noise_from_data, self.progress = cv, zone, noise_from_data, progress
        self.nest_heights, self.table_face = nest_heights, table_face

    _PARAMS = ("noise", *DEFAULTS, "progress")

    def fit(self, campaign: Campaign) -> "ErrorModelCV":
        """Choose (where not fixed) and fit the model of ``campaign``; returns self."""
        settings = {k: getattr(self, k) for k in DEFAULTS}
        result = FitProblem.build(self.machine, campaign, self.noise, **settings).solve(self.progress)
        self.result_, self.model_, self.choice_ = result, result.model, result.choice
        return self

    def _fitted(self):
        if not hasattr(self, "model_"):
            raise VecpinError("the estimator is not fitted: call fit(campaign) first")
        return self.model_

    def predict(self, q: np.ndarray, tool: np.ndarray | float = 0.0, *, frame: str = "workpiece",
                return_std: bool = False, features=None, point: int | np.ndarray = 0,
                offset: np.ndarray | None = None):
        """The predicted tool-tip error (N,3) [m] at commands q (N,n) [m, rad] and tool lengths
        [m]: the fitted model's :meth:`~vecpin.models.ErrorModel.predict`, modelled minus
        nominal tip, relative to the workpiece (``frame="workpiece"``, what compensation
        corrects) or in the machine base frame (``"machine"``); with ``return_std``, also its
        standard deviation (N,3) [m] from the fit's covariance: the noise's share, not a
        misfit of the chosen model."""
        return self._fitted().predict(q, tool, frame, features, point=point, offset=offset, return_std=return_std)

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
        self._fitted()
        return None if self.choice_ is None else -float(self.choice_.chosen.mean)

    def score(self, campaign: Campaign) -> float:
        """Minus the mean distance [mm] of ``campaign``'s measured points from the fitted
        model's, each tracker or nest row in the fit's tracker frame (a campaign measured with
        the same tracker pose, e.g. a validation run): higher is better, scikit-learn's sign."""
        d = np.linalg.norm(self._fitted().residuals(campaign), axis=1)
        return -float(np.nanmean(d) * 1000.0)

    def save(self, path) -> None:
        """Write the fitted model's file (:meth:`~vecpin.models.ErrorModel.save`)."""
        self._fitted().save(path)
