"""Rigid registration of the tracker frame to the machine frame.

Least-squares rotation and translation (Kabsch, by scipy's ``Rotation.align_vectors``)
mapping machine-frame points onto tracker-frame points: ``p_tracker ≈ R p_machine + t``.
Used to place the tracker from nominal kinematics with no user guess; the small
remaining correction ``E_0`` (Paper I eq. 10) is identified with the model.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from vecpin.errors import VecpinError


def register(p_machine: np.ndarray, p_tracker: np.ndarray, weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) minimising sum w_i |R p_machine_i + t - p_tracker_i|^2."""
    P = np.asarray(p_machine, float)
    Q = np.asarray(p_tracker, float)
    w = np.ones(len(P)) if weights is None else np.asarray(weights, float)
    w = w / w.sum()
    cp, cq = w @ P, w @ Q
    sv = np.linalg.svd((P - cp) * np.sqrt(w)[:, None], compute_uv=False)
    if len(sv) < 2 or sv[1] < 1e-9 * max(sv[0], 1e-300):
        raise VecpinError("the measured points are (nearly) collinear: the tracker frame cannot be registered")
    rot, _ = Rotation.align_vectors(Q - cq, P - cp, weights=w)
    R = rot.as_matrix()
    return R, cq - R @ cp


def registered_errors(p_machine: np.ndarray, p_tracker: np.ndarray) -> np.ndarray:
    """(N,3) residuals [same unit] of tracker points after the best rigid fit of the
    machine points: the 'uncompensated' volumetric error of the seed's tables."""
    R, t = register(p_machine, p_tracker)
    return p_tracker - (p_machine @ R.T + t)
