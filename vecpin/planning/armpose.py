"""Approach poses of a serial arm: the measured pose backed off along the tool axis.

A machine without linear axes (an arm, :func:`vecpin.kinematics.axes.is_arm`) has no
axis that lifts the tool off the work, so a plan approaches every point along the tool
axis in joint space: the *pre-pose* is the joint configuration whose tool link has the
measured pose's orientation and lies ``clearance`` [m] back along the tool axis
(``p_pre = p - clearance * u``, ``u`` the tool direction in the base frame). It is found
by damped least squares from the measured configuration, with Pinocchio's frame
Jacobian of the tool link (``LOCAL_WORLD_ALIGNED``: the velocity of the tool link's
origin and the angular velocity, base-frame axes):

    dq = J^T (J J^T + lambda^2 I)^-1 e,   e = (p_target - p, log3(R_target R^T))

A pre-pose is accepted when it reaches the target (:data:`POSITION_TOL` m,
:data:`ANGLE_TOL` rad), stays inside every joint's limits and is near the measured
configuration (no joint further than :data:`MAX_JOINT_STEP_DEG`: a pose near a
singularity needs large joint moves for a small tool move). The approach itself is the
joint move from the pre-pose to the measured pose: its tip must stay within
:data:`MAX_DEVIATION` of the clearance of the straight line along the tool axis
(:func:`approach_deviation`); the holder is checked for collisions with
the planner's geometry (:class:`~vecpin.planning.sightline.SightLine`, the holder a
cylinder of the plan's radius) along the whole joint move, as the moves between points
are (:func:`~vecpin.planning.armtransit.blocked_moves`).
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.units import M_PER_MM

POSITION_TOL = 1e-7        # m: the pre-pose's tool link within this of its target
ANGLE_TOL = 1e-7           # rad: and its orientation within this of the measured one
MAX_JOINT_STEP_DEG = 10.0  # deg, ASSUMED: no joint of the pre-pose further from the measured pose than this
PATH_SAMPLES = 3           # configurations between the pre-pose and the measured pose: the tip's deviation
MAX_DEVIATION = 0.25       # ASSUMED: the tip leaves the tool axis by at most this fraction of the clearance
DAMPING = 1e-4             # lambda of the damped least squares [m, rad]
MAX_ITERATIONS = 40


def _tool_frame(machine: Machine) -> tuple[int, np.ndarray]:
    """The Pinocchio frame id of the (first) tool link and the Jacobian columns (idx_v) of the axes."""
    cols = np.array([machine.model.joints[a.joint_id].idx_v for a in machine.axes])
    return machine.spindle_frame_id, cols


def _solve_one(machine: Machine, data, q0: np.ndarray, clearance: float, fid: int,
               cols: np.ndarray) -> tuple[np.ndarray, float, float]:
    """(pre-pose (n,) [rad], position error [m], angle error [rad]) of one measured pose ``q0``."""
    model = machine.model
    pin.framesForwardKinematics(model, data, machine.full_q(q0[None])[0])
    M0 = data.oMf[fid]
    R_t = M0.rotation.copy()
    p_t = M0.translation - clearance * (R_t @ machine.tool_axis)
    q = q0.copy()
    ep, er = np.inf, np.inf
    for _ in range(MAX_ITERATIONS):
        qf = machine.full_q(q[None])[0]
        pin.computeJointJacobians(model, data, qf)
        pin.updateFramePlacements(model, data)
        M = data.oMf[fid]
        e = np.r_[p_t - M.translation, pin.log3(R_t @ M.rotation.T)]
        ep, er = float(np.linalg.norm(e[:3])), float(np.linalg.norm(e[3:]))
        if ep < POSITION_TOL * 1e-2 and er < ANGLE_TOL * 1e-2:
            break
        J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[:, cols]
        q = q + J.T @ np.linalg.solve(J @ J.T + DAMPING ** 2 * np.eye(6), e)
    return q, ep, er


def pre_poses(machine: Machine, q: np.ndarray, clearance: float) -> tuple[np.ndarray, np.ndarray]:
    """The pre-poses (N, n) [rad] of measured poses ``q`` (N, n) [rad] ``clearance`` [m]
    back along the tool axis, and why each is refused ((N,) str, '' when accepted: 'out
    of reach' when the damped least squares does not reach it, 'joint limit' when a joint
    leaves its travel, 'near a singularity' when a joint moves more than
    :data:`MAX_JOINT_STEP_DEG`)."""
    q = np.atleast_2d(np.asarray(q, float))
    out = q.copy()
    why = np.full(len(q), "", dtype=object)
    if clearance == 0.0:
        return out, why
    fid, cols = _tool_frame(machine)
    data = machine.model.createData()
    lo, hi = machine.lower, machine.upper
    step = np.radians(MAX_JOINT_STEP_DEG)
    for i in range(len(q)):
        out[i], ep, er = _solve_one(machine, data, q[i], clearance, fid, cols)
        if not (ep < POSITION_TOL and er < ANGLE_TOL):
            why[i] = "out of reach"
        elif np.any(out[i] < lo) or np.any(out[i] > hi):
            why[i] = "joint limit"
        elif np.max(np.abs(out[i] - q[i])) > step:
            why[i] = "near a singularity"
    return out, why


def approach_path(q: np.ndarray, pre: np.ndarray) -> np.ndarray:
    """(S, N, n) configurations of the joint moves from ``pre`` to ``q`` (N, n): the
    pre-pose, :data:`PATH_SAMPLES` between, the measured pose."""
    s = np.linspace(0.0, 1.0, PATH_SAMPLES + 2)
    return pre[None] + s[:, None, None] * (q - pre)[None]


def approach_deviation(machine: Machine, q: np.ndarray, pre: np.ndarray, tool: float) -> np.ndarray:
    """(N,) how far [m] the tip of a holder ``tool`` [m] long leaves the straight line
    from its pre-pose tip to its measured tip on the joint move from ``pre`` to ``q``
    (N, n), at the :func:`approach_path` samples."""
    path = approach_path(q, pre)
    S, N, n = path.shape
    tips = machine.tool_tip(path.reshape(-1, n), tool, frame="base").reshape(S, N, 3)
    d = tips[-1] - tips[0]
    u = d / np.maximum(np.linalg.norm(d, axis=1), 1e-15)[:, None]
    r = tips - tips[0][None]
    perp = r - np.sum(r * u[None], axis=2)[..., None] * u[None]
    return np.linalg.norm(perp, axis=2).max(axis=0)


def approach_collisions(sight, q: np.ndarray, pre: np.ndarray, tools: np.ndarray) -> np.ndarray:
    """(N,) the solid a holder of any length ``tools`` [m] runs into on the approach from
    ``pre`` to ``q`` (N, n) [rad] ('' where free): the joint move posed as the moves
    between points are (:func:`~vecpin.planning.armtransit.blocked_moves`: every 2 deg
    and the area between, the holder a cylinder of the plan's radius)."""
    from vecpin.planning.armtransit import blocked_moves
    by = np.full(len(q), "", dtype=object)
    for L in np.atleast_1d(tools):
        hit = blocked_moves(sight, pre, q, float(L))
        new = (hit != "") & (by == "")
        by[new] = hit[new]
    return by


def approach_signs(q: np.ndarray, pre: np.ndarray) -> np.ndarray:
    """(N, n) the direction each joint reaches the measured pose from: +1 from below,
    -1 from above, 0 not moved (the template's approach columns of an arm's plan)."""
    d = np.asarray(q, float) - np.asarray(pre, float)
    return np.where(np.abs(d) < 1e-12, 0, np.sign(d)).astype(int)


def check_arm_approach(mode: str, clearance_mm: float) -> None:
    """An arm approaches along the tool axis: ``approach`` below (from the pre-pose
    ``approach_mm`` back) or none; above and both have no meaning there (names the option)."""
    if mode not in ("below", "none"):
        raise InputError(f"`approach` {mode}: an arm approaches every point along the tool axis, from a pre-pose "
                         "`approach_mm` back from it; choose `approach` below (the default) or none")
    if mode == "below" and not (np.isfinite(clearance_mm) and clearance_mm > 0):
        raise InputError(f"`approach_mm` {clearance_mm:g}: the clearance of an arm's pre-pose along the tool axis, "
                         "mm > 0 (or `approach` none)")


def arm_clearance(settings) -> float:
    """The pre-pose clearance [m] of a plan's ``settings`` (0 with ``approach`` none)."""
    return 0.0 if settings.approach == "none" else settings.approach_mm * M_PER_MM


def screen_approaches(machine: Machine, q: np.ndarray, clearance: float, sight, tools: np.ndarray) -> np.ndarray:
    """(N,) why each command ``q`` (N, n) [rad] cannot be approached ('' where it can):
    :func:`pre_poses`' reasons, or 'approach: SOLID' where a holder of a length in
    ``tools`` [m] runs into ``SOLID`` on the approach (``sight`` a
    :class:`~vecpin.planning.sightline.SightLine`)."""
    pre, why = pre_poses(machine, q, clearance)
    ok = np.flatnonzero(why == "")
    if len(ok) and clearance > 0:
        off = approach_deviation(machine, q[ok], pre[ok], float(np.max(tools))) > MAX_DEVIATION * clearance
        why[ok[off]] = "off the tool axis"
        ok = ok[~off]
    if sight is not None and len(ok):
        hit = approach_collisions(sight, q[ok], pre[ok], tools)
        why[ok[hit != ""]] = ["approach: " + h for h in hit[hit != ""]]
    return why


def arm_approach_signs(machine: Machine, q: np.ndarray, clearance: float) -> np.ndarray:
    """The approach columns (N, n) of an arm's template rows ``q`` (N, n) [rad]:
    :func:`approach_signs` from their pre-poses ``clearance`` [m] back."""
    return approach_signs(q, pre_poses(machine, q, clearance)[0])
