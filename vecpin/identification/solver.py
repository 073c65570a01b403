"""Damped Gauss-Newton for ``min |w(ψ)|² + |ψ|²`` (whitened residuals, unit priors).

Bounded and honest: each iteration tries at most :data:`MAX_DAMPING` increases of the
Levenberg-Marquardt damping; a step is accepted only when it lowers the objective;
when no damping finds a lower objective the current point is a minimum to numerical
precision if the decrease a full step promises is negligible (below
:data:`PROMISE_RTOL` of the objective or one unit of chi2), and otherwise the solver
raises :class:`~vecpin.errors.ConvergenceError` with what it saw. When the least damped
step goes uphill and the full step promised less than the convergence tolerance, the
point is a minimum at once (no further damping: on a million rows each trial is a
pass over every row, and a dozen of them found nothing). It raises as well when
no damping makes the damped normal equations solvable (they are not positive definite).
Non-finite residuals or normal equations at the start or at an accepted point (a model
evaluated far outside its travel, a unit mistake in the data) stop it at once; a trial
point whose residuals are not finite counts as a rejected step (the damping grows and a
shorter step is tried).
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
# A minimum to the data's resolution: when no damping lowers the objective, a full step
# that promises less than this share of it (or less than one unit of chi2: a step
# shorter than its own standard error) is numerical noise of the model's evaluation,
# not a descent the solver missed.
PROMISE_RTOL = 1e-5
PROMISE_ATOL = 1.0


@dataclass
class Solution:
    psi: np.ndarray           # prior-scaled unknowns (removed terms 0)
    chi2: float               # |w|^2 at psi
    G: np.ndarray             # J^T J at psi (J = dw/dpsi, all columns; when converged, at the point
    g: np.ndarray             # J^T w      before the last step, which lowered the objective by < tol)
    objective: float          # |w|^2 + |psi|^2
    iterations: int
    converged: bool


def _finite(chi2: float, G, g, what: str) -> None:
    if not (np.isfinite(chi2) and (G is None or np.isfinite(G).all()) and (g is None or np.isfinite(g).all())):
        raise ConvergenceError(f"the residuals or their derivatives became non-finite {what}: the model was evaluated "
                               "far outside what the data support (check units and the axis columns)")


def _promise(Nm: np.ndarray, grad: np.ndarray) -> float:
    """The decrease of the objective a full Gauss-Newton step promises (gᵀ N⁻¹ g)."""
    return float(grad @ linalg.lstsq(Nm, grad)[0])


def gauss_newton(normal_equations: Callable[[np.ndarray, bool], tuple], P: int, keep: np.ndarray,
                 max_iter: int = 30, tol: float = 1e-9, progress: Callable[[str], None] | None = None,
                 start: tuple | None = None, eager: bool = False) -> Solution:
    """Minimise ``|w(psi)|^2 + |psi|^2`` over the ``keep`` columns, from psi = 0.

    ``normal_equations(psi, jacobian) -> (|w|^2, J^T J, J^T w, ...)`` with J = dw/dpsi
    (G and g may be None without ``jacobian``: a trial point needs its chi2 only).
    ``start``: (|w|^2, J^T J, J^T w) at psi = 0 when the caller has them already (the
    fit evaluates them for its redundancy test), saving one evaluation with Jacobians.
    ``eager``: evaluate every trial point with its Jacobians, so that an accepted step
    (most are) needs no second pass over the rows; the same steps and result (a large
    campaign: each pass a pass over every row, most of it the kinematics both need). A
    step whose linearised decrease is below the tolerance is evaluated without them: taken,
    it ends the fit (the solution keeps the normal equations of the point before it)."""
    psi = np.zeros(P)
    chi2, G, g = (start if start is not None else normal_equations(psi, True))[:3]
    _finite(chi2, G, g, "at the start")
    obj = chi2
    converged = False
    it = 0
    lam = LAMBDA_START
    eye = np.eye(int(keep.sum()))
    for it in range(1, max_iter + 1):
        Nm = G[np.ix_(keep, keep)] + eye
        grad = g[keep] + psi[keep]
        accepted = solved = False
        for attempt in range(MAX_DAMPING + 1):
            if attempt == 1 and solved and _promise(Nm, grad) <= tol * max(obj, 1.0):
                break   # the least damped step went uphill and promised less than the tolerance: a minimum
            try:
                step = -linalg.solve(Nm + lam * np.diag(np.diag(Nm)), grad, assume_a="pos", check_finite=False)
            except (linalg.LinAlgError, ValueError):
                lam *= 10
                continue
            solved = solved or bool(np.isfinite(step).all())
            trial = psi.copy()
            trial[keep] += step
            # a step promising less than the tolerance ends the fit when taken: its Jacobians would go unused
            with_j = eager and -(2 * grad @ step + step @ Nm @ step) > tol * max(obj, 1.0)
            chi2_new, *at_trial = normal_equations(trial, with_j)
            if np.isfinite(chi2_new) and chi2_new + trial @ trial <= obj:
                accepted = True
                break
            lam *= 10  # a longer step went uphill or left the region where the residuals are finite
        if not solved:
            raise ConvergenceError(f"no damping made the normal equations solvable in iteration {it} (they are not "
                                   "positive definite: non-finite or contradictory derivatives); check units, the axis "
                                   "columns and the noise settings")
        if not accepted:
            # no damping lowers the objective: a minimum to numerical precision when the
            # decrease a full Gauss-Newton step promises is negligible; otherwise stuck
            promised = _promise(Nm, grad)
            if 0 <= promised <= max(PROMISE_RTOL * obj, PROMISE_ATOL):
                converged = True
                break
            raise ConvergenceError(f"the fit cannot lower chi2 = {obj:.6g} any further (a step promised {promised:.3g} "
                                   f"after {MAX_DAMPING} damping increases in iteration {it}): the problem is badly "
                                   "conditioned or the data contradict the model (check units, outliers, the noise "
                                   "settings)")
        obj_new = chi2_new + trial @ trial
        decrease = obj - obj_new
        psi, chi2, obj = trial, chi2_new, obj_new
        if progress:
            progress(f"iteration {it}: chi2 {obj:.6g}, step {np.abs(step).max():.3g}")
        if decrease <= tol * max(obj, 1.0) or np.abs(step).max() < 1e-10:
            converged = True   # G and g stay those of the point before this last, negligible step
            break
        chi2, G, g = (chi2, *at_trial[:2]) if with_j else normal_equations(psi, True)[:3]
        _finite(chi2, G, g, f"at the point accepted in iteration {it}")
        obj = chi2 + psi @ psi
        lam = max(lam / 10, LAMBDA_MIN)
    return Solution(psi, chi2, G, g, obj, it, converged)
