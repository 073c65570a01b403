"""Time effects against the campaign's own structure: a step that coincides with a
change of the measurement program is not called a tracker move without evidence that
separates the two.

A program change at a row is a change of regime between the rows read just before it
and just after it (:data:`WINDOW` rows of the same station on each side, in time order):
the tool, tool point, target or instrument, or a label column of the file (a block,
point set or holder number: whole numbers with few values) take values after it that
none of the rows before took, or an axis jumps to a stretch of its travel the rows
before did not visit (the two windows' ranges apart, and the jump larger than the
moves within them). Rows that alternate tools or wander at random over the travel are
no change: both windows hold the same regime.

A step at such a change explains the residual of one part of the program as well as a
moved tracker would: the model may misfit that part. Only poses read on both sides of
the step (same command, tool, point, target, station: repeated reference points, a nest
read again) separate them: the model's prediction cancels in their difference, so a
tracker move shows as a difference beyond the noise and a misfit does not.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import special

from vecpin.diagnosis.grosserrors import pose_keys
from vecpin.diagnosis.scoring import paired_gain_p
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.features import Features

WINDOW = 12      # rows of one station on each side of a row that define the regime there
NEAR_ROWS = 2    # a step within this many rows of a change coincides with it (beyond the scan's own spacing)
LABEL_VALUES = 50  # a label column: whole numbers with at most this many values


@dataclass
class ProgramChanges:
    """Per station the rows in time order (``order[s]``) and the changes of the program
    at them (``changes[s]``: position in that order -> what changed)."""

    order: dict
    changes: dict
    spacing: dict

    def at_step(self, t0: float, station: int, feats: Features) -> str | None:
        """What changes where a step at ``t0`` on ``station`` starts (within the scan's
        spacing of it), or None."""
        rows = self.order.get(station)
        if rows is None or not self.changes.get(station):
            return None
        first = int(np.searchsorted(feats.time[rows], t0))
        tol = max(NEAR_ROWS, int(np.ceil(self.spacing[station] / 2)))
        near = [k for k in self.changes[station] if abs(k - first) <= tol]
        return None if not near else self.changes[station][min(near, key=lambda k: abs(k - first))]


def _labels(campaign: Campaign) -> dict[str, np.ndarray]:
    """The program's discrete columns: tool, tool point, target, instrument and the label
    columns of the file (whole numbers, few values; not time or temperature)."""
    out = {"tool": np.round(campaign.tool * 1e6).astype(np.int64), "tool point": campaign.point,
           "target": campaign.target.astype(str), "instrument": campaign.instrument.astype(str)}
    for name, v in campaign.extra.items():
        v = np.asarray(v, float)
        if name in ("time", "temperature") or not np.all(np.isfinite(v)):
            continue
        if np.all(v == np.round(v)) and len(np.unique(v)) <= LABEL_VALUES:
            out[f"column '{name}'"] = v
    return out


def _regime_change(x: np.ndarray, k: int, discrete: bool) -> bool:
    """Whether the rows from ``k`` on (``WINDOW`` of them) hold another regime of ``x``
    than the ``WINDOW`` rows before ``k``."""
    before, after = x[max(0, k - WINDOW):k], x[k:k + WINDOW]
    if discrete:
        return not (set(before.tolist()) & set(after.tolist()))
    if after.min() > before.max() or after.max() < before.min():
        moves = np.abs(np.diff(np.r_[before, after]))
        inside = np.r_[np.abs(np.diff(before)), np.abs(np.diff(after))]
        return bool(abs(x[k] - x[k - 1]) > 3 * np.median(inside) and moves.max() > 0)
    return False


def program_changes(machine, campaign: Campaign, feats: Features) -> ProgramChanges:
    """Every change of the program (module docstring), per tracker station, in time order."""
    order, changes, spacing = {}, {}, {}
    if not feats.has_time:
        return ProgramChanges(order, changes, spacing)
    labels = _labels(campaign)
    for s in np.unique(feats.station[feats.station >= 0]):
        rows = np.flatnonzero(feats.station == s)
        rows = rows[np.argsort(feats.time[rows], kind="stable")]
        order[int(s)], found = rows, {}
        n = len(rows)
        spacing[int(s)] = 0.9 * n / max(min(120, n // 4), 1)   # the step scan's spacing (instrument_shift)
        lab = {name: v[rows] for name, v in labels.items()}   # in time order, once per station
        axes = {f"the region of {a.name}": campaign.q[rows, a.index] for a in machine.axes}
        for k in range(max(2, WINDOW // 2), n - max(2, WINDOW // 2) + 1):
            what = [name for name, v in lab.items() if _regime_change(v, k, True)]
            what += [name for name, v in axes.items() if _regime_change(v, k, False)]
            if what:
                found[k] = f"{' and '.join(what)} (file line {int(campaign.lines[rows[k]])})"
        changes[int(s)] = found
    return ProgramChanges(order, changes, spacing)


def in_both_regions(campaign: Campaign, feats: Features, t0: float, station: int) -> np.ndarray:
    """(N,) the rows a step at ``t0`` on ``station`` moves whose commands lie, on every
    axis, within the range the rows before it measured: where a moved tracker and a
    model that misfits a region only one side of the step measured part ways (the
    first moves these rows too, the second does not)."""
    on = feats.station == station
    after, before = on & (feats.time >= t0), on & (feats.time < t0)
    if not before.any():
        return np.zeros(len(campaign), bool)
    lo, hi = campaign.q[before].min(axis=0), campaign.q[before].max(axis=0)
    return after & np.all((campaign.q >= lo) & (campaign.q <= hi), axis=1)


def step_not_shown(before: np.ndarray, after: np.ndarray, rows: np.ndarray, threshold: float) -> str | None:
    """Why a step is not called a tracker move although it is significant: its held-out
    gain (distances ``before`` and ``after`` [mm] per judged row) is not significant at
    ``threshold`` on the moved rows inside the region both sides measured (``rows``, a
    mask over the judged rows, :func:`in_both_regions`); None when it is."""
    p = paired_gain_p(before[rows], after[rows]) if rows.sum() > 1 else 1.0
    if p < threshold:
        return None
    return (f"held back: the rows after the step inside the region the rows before it measured ({int(rows.sum())}) do "
            f"not show it (held-out mean {before[rows].mean() if rows.any() else float('nan'):.4f} -> "
            f"{after[rows].mean() if rows.any() else float('nan'):.4f} mm, p = {p:.2g}): the gain comes from a region only "
            "one side measured, which the model may misfit, so it is not called a tracker move; read reference points "
            "again before and after to tell them apart")


@dataclass
class Sides:
    """The readings of every pose on each side of a step: ``group`` (N,) per row its
    (pose, side) group, 2 x pose + (after the step), -1 off the step's station;
    ``after``, ``before`` (P,) the two groups of each of the P poses read on both sides."""

    group: np.ndarray
    after: np.ndarray
    before: np.ndarray

    def means(self, x: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per group (G): the mean of ``x`` (N,3) over its valid entries (G,3), its readings
        (G,) and whether every entry of each component is valid (G,3); one bincount per
        component."""
        on = self.group >= 0
        g, G = self.group[on], int(self.group.max()) + 1 if on.any() else 0
        n = np.bincount(g, minlength=G).astype(float)
        xs, ok = np.where(valid, x, 0.0)[on], valid[on]
        sums = np.column_stack([np.bincount(g, xs[:, c], G) for c in range(x.shape[1])])
        bad = np.column_stack([np.bincount(g, ~ok[:, c], G) for c in range(x.shape[1])])
        return sums / np.maximum(n, 1)[:, None], n, bad == 0


def straddling(campaign: Campaign, feats: Features, t0: float, station: int) -> Sides:
    """The poses read on both sides of a step at ``t0`` on ``station`` (:func:`pose_keys`:
    same command within the readings' resolution, tool, point, target, station)."""
    key = pose_keys(campaign)
    on = feats.station == station
    group = np.where(on, 2 * key + (feats.time >= t0), -1)
    n = np.bincount(group[on], minlength=2 * (int(key.max()) + 1) if len(key) else 0)
    both = np.flatnonzero((n[0::2] > 0) & (n[1::2] > 0))
    return Sides(group, 2 * both + 1, 2 * both)


def _moved(sides: Sides, w: np.ndarray, valid: np.ndarray, level: float) -> tuple[float, int]:
    """(chi2, equations) of the differences of the mean whitened residuals ``w`` of each
    pose after and before (the model's prediction cancels), at the noise ``level``."""
    m, n, ok = sides.means(w, valid)
    a, b = sides.after, sides.before
    both = ok[a] & ok[b]
    d = np.where(both, m[a] - m[b], 0.0)
    return float(np.sum(np.sum(d ** 2, axis=1) / (level * (1 / n[a] + 1 / n[b])))), int(both.sum())


def repeats_across(campaign: Campaign, feats: Features, t0: float, station: int, w: np.ndarray,
                   valid: np.ndarray, alpha: float) -> tuple[int, float]:
    """(poses read on both sides of a step at ``t0`` on ``station``, p-value that their
    readings did not move): the differences of the mean whitened residuals ``w`` of each
    such pose after and before, whose prediction cancels, against the noise of the rows
    (their robust level), chi2 over the poses' equations. p = 1 when there are none."""
    sides = straddling(campaign, feats, t0, station)
    stat, dof = _moved(sides, w, valid, _level(w, valid))
    return len(sides.after), (float(special.chdtrc(dof, stat)) if dof else 1.0)


def repeats_verdict(campaign: Campaign, feats: Features, step, lin, fitted: tuple[np.ndarray, np.ndarray],
                    alpha: float) -> tuple[str, str]:
    """What the poses read on both sides of a step (``step.t0``, ``step.station``) say of
    it. The model's prediction cancels in each pose's difference (after - before), so
    this is the one evidence on a step that no model of the machine colours: the
    differences d are regressed on the step's predicted differences p (whitened), d = b p,
    and b judged with the poses' own scatter about it (Student t, one-sided ``alpha``),
    which holds whatever moved between the readings besides the step. ("none", "")
    without such poses; ("confirmed", text) when b is above 1/2 (they moved more like the
    step than like nothing); ("contradicted", why) when below 1/2: held back;
    ("silent", text) otherwise. ``lin``: the model without the step, linearised;
    ``fitted``: its (whitened, metric [m]) residuals (N,3) with the step fitted."""
    sides = straddling(campaign, feats, step.t0, step.station)
    a, b = sides.after, sides.before
    if not len(a):
        return "none", ""
    (w, _, ok), wf = sides.means(lin.w, lin.valid), sides.means(fitted[0], lin.valid)[0]
    use = ok[a] & ok[b]
    d = np.where(use, w[a] - w[b], 0.0)
    p = np.where(use, d - (wf[a] - wf[b]), 0.0)
    pp, k = float(np.sum(p ** 2)), int(use.sum())
    r, f = sides.means(lin.r, lin.valid)[0], sides.means(fitted[1], lin.valid)[0]
    seen = (f"the {len(a)} poses read on both sides of it moved by "
            f"{np.linalg.norm(r[a] - r[b], axis=1).mean() * 1e3:.4f} mm on average, the step predicts "
            f"{np.linalg.norm(f[b] - f[a] + r[a] - r[b], axis=1).mean() * 1e3:.4f} mm")
    if pp <= 0 or k < 2:
        return "silent", f"the poses read twice cannot tell: {seen}"
    slope = float(np.sum(d * p)) / pp
    se = math.sqrt(float(np.sum((d - slope * p) ** 2)) / (k - 1) / pp)
    t = float(-special.stdtrit(k - 1, alpha))
    share = f"{slope:.2f} ± {se:.2f} of the predicted move"
    if slope + t * se < 0.5:
        return "contradicted", (f"held back: {seen}; they moved by {share}, less than half of it beyond their own "
                                "scatter: the readings of the same poses, in which no model of the machine enters, "
                                "contradict a tracker move")
    if slope - t * se > 0.5:
        return "confirmed", f"confirmed by the poses read twice: {seen}; they moved by {share}"
    return "silent", f"the poses read twice cannot tell: {seen}; they moved by {share}"


def _level(w: np.ndarray, valid: np.ndarray) -> float:
    """The whitened residuals' robust variance per equation (1 when the noise model is right)."""
    k = np.maximum(valid.sum(axis=1), 1)
    s = np.sum(np.where(valid, w, 0.0) ** 2, axis=1)
    return float(max(np.median(s / special.chdtri(k, 0.5)), 1e-300))


def held_back(changes: ProgramChanges, campaign: Campaign, feats: Features, effect, lin, alpha: float) -> str | None:
    """Why a step candidate (an effect with a step time ``t0`` on a ``station``) cannot be
    called a tracker move: it starts at a change of the program (``changes``) and no pose
    read on both sides of it moved beyond the noise (the whitened residuals of ``lin``,
    the current model linearised on ``campaign``'s rows, at ``alpha``); None when nothing
    holds it back."""
    t0, station = getattr(effect, "t0", None), getattr(effect, "station", None)
    what = None if t0 is None else changes.at_step(t0, station, feats)
    if what is None:
        return None
    n, p = repeats_across(campaign, feats, t0, station, lin.w, lin.valid, alpha)
    if n and p < alpha:
        return None  # the same poses read before and after it moved: separating evidence
    seen = (f"the {n} poses read on both sides of it agree (p = {p:.2g})" if n
            else "no pose was read on both sides of it")
    return (f"held back: the step starts at a change of the program, {what}, and {seen}, so it is not called a "
            "tracker move (the model may misfit one part of the program); read reference points again before and "
            "after such a change to tell them apart")
