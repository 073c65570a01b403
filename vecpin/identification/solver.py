"""Damped Gauss-Newton for ``min |w(ψ)|² + |ψ|²`` (whitened residuals, unit priors).

Bounded and honest: each iteration tries at most :data:`MAX_DAMPING` increases of the
Levenberg-Marquardt damping; a step is accepted only when it lowers the objective;
when no damping finds a lower objective the current point is a minimum to numerical
precision if the decrease a full step promises is negligible, and otherwise the solver raises
:class:`~vecpin.errors.ConvergenceError` with what it saw. Non-finite residuals (a
model evaluated far outside its travel, a unit mistake in the data) stop it at once.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy import linalg

from vecpin.errors import ConvergenceError

MAX_DAMPING = 12          # damping increases (x10 each) per iteration before giving up on a descent step
LAMBDA_START = 1e-6
LAMBDA_MIN = 1e-9


@dataclass
class Solution:
    psi: np.ndarray           # prior-scaled unknowns (removed terms 0)
    w: np.ndarray             # whitened residuals at psi (flat)
    J: np.ndarray             # dw/dpsi at psi (flat rows, all columns)
    objective: float          # |w|^2 + |psi|^2
    iterations: int
    converged: bool


def _finite(w: np.ndarray, what: str) -> None:
    if not np.all(np.isfinite(w)):
        raise ConvergenceError(f"the residuals became {what} non-finite: the model was evaluated far outside what the "
                               "data support (check units and the axis columns)")


def gauss_newton(evaluate: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], P: int, keep: np.ndarray,
                 max_iter: int = 30, tol: float = 1e-9, progress: Callable[[str], None] | None = None) -> Solution:
    """Minimise ``|w(psi)|^2 + |psi|^2`` over the ``keep`` columns, from psi = 0.

    ``evaluate(psi) -> (w (E,), J (E, P))`` with J = dw/dpsi."""
    psi = np.zeros(P)
    w, J = evaluate(psi)
    _finite(w, "at the start")
    obj = float(w @ w)
    converged = False
    it = 0
    lam = LAMBDA_START
    eye = np.eye(int(keep.sum()))
    for it in range(1, max_iter + 1):
        Ja = J[:, keep]
        Nm = Ja.T @ Ja + eye
        g = Ja.T @ w + psi[keep]
        accepted = False
        for _ in range(MAX_DAMPING + 1):
            try:
                step = -linalg.solve(Nm + lam * np.diag(np.diag(Nm)), g, assume_a="pos", check_finite=False)
            except (linalg.LinAlgError, ValueError):
                lam *= 10
                continue
            trial = psi.copy()
            trial[keep] += step
            w_new, J_new = evaluate(trial)
            if np.all(np.isfinite(w_new)):
                obj_new = float(w_new @ w_new + trial @ trial)
                if obj_new <= obj:
                    accepted = True
                    break
            lam *= 10
        if not accepted:
            # no damping lowers the objective: a minimum to numerical precision when the
            # decrease a full Gauss-Newton step promises is negligible; otherwise stuck
            promised = float(g @ linalg.lstsq(Nm, g)[0])
            if promised <= 1e-6 * max(obj, 1.0):
                converged = True
                break
            raise ConvergenceError(f"the fit cannot lower chi2 = {obj:.6g} any further (a step promised {promised:.3g} after "
                                   f"{MAX_DAMPING} damping increases in iteration {it}): the problem is badly "
                                   "conditioned or the data contradict the model (check units, outliers, the noise "
                                   "settings)")
        decrease = obj - obj_new
        psi, w, J, obj = trial, w_new, J_new, obj_new
        lam = max(lam / 10, LAMBDA_MIN)
        if progress:
            progress(f"iteration {it}: chi2 {obj:.6g}, step {np.abs(step).max():.3g}")
        if decrease <= tol * max(obj, 1.0) or np.abs(step).max() < 1e-10:
            converged = True
            break
    return Solution(psi, w, J, obj, it, converged)
