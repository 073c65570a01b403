"""The poses of a campaign and the sweeps of a design that moves one joint at a time.

A pose is one axis command: every row commanded there (both tool lengths, every target or
reflector read at that pose, every repeat) is one pose, found from the data (the same
commands to 1e-9 m or rad). Poses follow one another, in the order the campaign first
reaches them, by moves. A design that moves one joint at a time (a sweep of joint 1, then
one of joint 2, ...; a raster of lines along one axis) joins its poses into sweeps: runs of
moves that change the same single axis. Cross-validation that deals single poses to its
folds judges a candidate on poses whose neighbours along the sweep it was fitted on; whole
sweeps in one fold judge it on a sweep it has not seen, as the next campaign will
(:func:`vecpin.identification.folds.command_folds`).
"""
from __future__ import annotations

import numpy as np

from vecpin.measurement.campaign import Campaign

ONE_AT_A_TIME = 0.5  # a design moves one joint at a time when this share of its moves or more change one axis only
MIN_SWEEP = 3        # ... and some sweep joins at least this many poses


def poses(campaign: Campaign) -> tuple[np.ndarray, np.ndarray]:
    """(pose of each row (N,), the distinct commands (P, n) [m, rad]): rows with the same
    axis command (to 1e-9) are one pose."""
    uq, group = unique_rows(np.round(campaign.q, 9))
    return group, uq


def unique_rows(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the distinct rows of ``a`` (N, k) in lexicographic order, the index of each row's
    among them (N,)): ``np.unique(a, axis=0, return_inverse=True)``, by a lexicographic
    sort of the columns (twice as fast on a million rows)."""
    a = np.asarray(a)
    if not len(a):
        return a.copy(), np.zeros(0, np.intp)
    order = np.lexsort(a.T[::-1])
    s = a[order]
    new = np.r_[True, np.any(s[1:] != s[:-1], axis=1)]
    inverse = np.empty(len(a), np.intp)
    inverse[order] = np.cumsum(new) - 1
    return s[new], inverse


def sweep_of_moves(axis: np.ndarray) -> np.ndarray:
    """(m,) the sweep of every move, -1 for a move of several axes: ``axis`` (m,) the one
    axis each move changes (-1: several); a sweep is a maximal run of moves of one axis."""
    out = np.full(len(axis), -1)
    sid = -1
    for i, a in enumerate(axis):
        if a >= 0:
            if i == 0 or axis[i - 1] != a:
                sid += 1
            out[i] = sid
    return out


def pose_blocks(campaign: Campaign, min_blocks: int = 2) -> np.ndarray | None:
    """(N,) the block of each row where the design moves one joint at a time (module
    text), else None. A pose belongs to the sweep that reaches it, else the one that
    leaves it, else is a block of its own; a pose reached again later (a home pose between
    sweeps) stays in the block where it came first. None unless at least
    :data:`ONE_AT_A_TIME` of the moves change one axis only, some sweep joins
    :data:`MIN_SWEEP` poses or more and there are ``min_blocks`` blocks or more (random
    poses: every pose its own block, None)."""
    group, uq = poses(campaign)
    seq = group[np.r_[True, group[1:] != group[:-1]]]      # the poses in the order they were reached
    if len(seq) < 2:
        return None
    moved = np.abs(np.diff(uq[seq], axis=0)) > 1e-9
    single = moved.sum(axis=1) == 1
    if single.mean() < ONE_AT_A_TIME:
        return None
    sweep = sweep_of_moves(np.where(single, moved.argmax(axis=1), -1))
    n_sweeps = sweep.max() + 1
    block = np.full(len(uq), -1)
    own = n_sweeps
    for j, pose in enumerate(seq):
        arriving = sweep[j - 1] if j > 0 else -1
        leaving = sweep[j] if j < len(sweep) else -1
        b = arriving if arriving >= 0 else leaving
        if b < 0:
            b, own = own, own + 1
        if block[pose] < 0:
            block[pose] = b
    _, block = np.unique(block, return_inverse=True)
    sizes = np.bincount(block)
    if sizes.max() < MIN_SWEEP or len(sizes) < min_blocks:
        return None
    return block[group]


def sweep_folds(block: np.ndarray, k: int, rng: np.random.Generator) -> np.ndarray:
    """(N,) the fold of each row: whole blocks (``block``, :func:`pose_blocks`) dealt to
    ``k`` folds at random."""
    return rng.permutation(block.max() + 1)[block] % k
