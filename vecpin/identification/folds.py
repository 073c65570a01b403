"""The folds of the cross-validation (:mod:`vecpin.identification.crossval`): which rows
are held out together. Folds are grouped by command: both tool lengths of one axis
command always fall in the same fold (they share the axis position, so splitting them
would leak); along an axis measured over part of its travel the commands at each end of
its measured span are held out whole, so the held-out rows judge how a model
extrapolates.
"""
from __future__ import annotations

import numpy as np

from vecpin.measurement.campaign import Campaign


END_SHARE = 0.1  # the share of the commands at each end of an axis that :func:`command_folds` holds out together
END_SPAN = 0.2   # the share of an axis' measured span at each end that :func:`end_blocks` ``by_span`` holds out


def end_blocks(campaign: Campaign, ends=(), by_span: bool = False
               ) -> tuple[np.ndarray, np.ndarray, list[tuple[int, np.ndarray]]]:
    """The commands of ``campaign`` and the ends of the axes ``ends``: (group (N,) the
    command of each row, n_commands, [(axis, commands)] two blocks per axis, the
    :data:`END_SHARE` of the commands with the lowest position on it and that share
    with the highest; ``by_span``: the commands within :data:`END_SPAN` of the axis'
    measured span from its lowest command, and those from its highest (at least one
    each), so the extrapolation a block judges reaches as far wherever commands crowd)."""
    keys = np.round(campaign.q, 9)
    uq, group = np.unique(keys, axis=0, return_inverse=True)
    group = np.asarray(group).ravel()
    m = max(1, int(round(END_SHARE * len(uq))))
    blocks = []
    for a in ends:
        x = uq[:, a]
        if by_span:
            reach = END_SPAN * (x.max() - x.min())
            blocks += [(a, np.flatnonzero(x <= x.min() + reach)), (a, np.flatnonzero(x >= x.max() - reach))]
        else:
            by_position = np.argsort(x, kind="stable")
            blocks += [(a, by_position[:m]), (a, by_position[-m:])]
    return group, len(uq), blocks


def end_folds(campaign: Campaign, axis: int) -> np.ndarray:
    """(N,) three folds that judge how a model extrapolates along ``axis``: 0 the rows
    whose command lies within :data:`END_SPAN` of the axis' measured span from its lowest
    command, 1 those from its highest, 2 the rest (a command at both ends, where the axis
    stands at one position, goes low): each end is estimated without any of its own
    commands, whatever other axes' ends hold (:func:`end_blocks` ``by_span``)."""
    group, _, blocks = end_blocks(campaign, (axis,), by_span=True)
    fold = np.full(len(group), 2)
    fold[np.isin(group, blocks[1][1])] = 1
    fold[np.isin(group, blocks[0][1])] = 0
    return fold


def command_folds(campaign: Campaign, k: int, rng: np.random.Generator, ends=()) -> np.ndarray:
    """Fold index per row; rows with the same axis command share a fold.

    ``ends``: axis indices whose ends are held out whole: on each such axis the
    :data:`END_SHARE` of the commands with the lowest position, and that share with the
    highest, form a block each (:func:`end_blocks`), the blocks dealt to the folds in
    random order (a command in two blocks goes with the first), so that each block's
    fold is estimated without any command beyond the rest of the axis' measured span:
    its held-out rows judge how a model *extrapolates* along that axis. The other
    commands are dealt at random (interleaved folds). Without ``ends``: interleaved
    folds only."""
    group, n, blocks = end_blocks(campaign, ends)
    if not len(ends):
        perm = rng.permutation(n)
        return perm[group] % k
    fold = np.full(n, -1)
    for f, b in enumerate(rng.permutation(len(blocks))):
        free = blocks[b][1][fold[blocks[b][1]] < 0]
        fold[free] = f % k
    rest = np.flatnonzero(fold < 0)
    fold[rest] = rng.permutation(len(rest)) % k
    return fold[group]
