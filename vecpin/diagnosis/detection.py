"""What this campaign could have seen: per candidate effect family, the smallest size the
diagnosis would detect (a power calculation on the final model's linearised problem).

An effect of shape ψ (its prior-scaled parameters, whitened columns ``J_e``, metric
columns ``A_e``) added to the data moves the whitened readings by ``J_e ψ``; what the
model's own terms cannot take of it (with their priors, M = (G + I)^-1 over the model's
columns, C = J^T J_e) leaves the non-centrality

    λ = ψ^T (J_e^T J_e - C^T M C) ψ / σ²

of the F-test on its chi-square reduction (k = its number of terms, the fit's degrees of
freedom; σ² the scatter left per equation, whitened). Its size is the RMS of its
displacement of the measured points, ``|A_e ψ|`` over the point rows (the whole effect,
not the part the model leaves). An effect's shape is not known: it is drawn as its prior
(ψ isotropic; :data:`SHAPES` fixed draws), each draw with its own ratio ψ^T B ψ / ψ^T Q ψ,
B = mean A_e^T A_e, Q the projected Gram above; the size stated is the one the test
passes at with probability :data:`POWER` over the noise *and* the draws (a shape the
model's terms mostly take needs more size than the average shape). An effect must also
pass the paired test on held-out distances (its probability averaged over the same draws) and take
``min_shrink_pct`` off their mean: per point row the noise (σ per coordinate, from the
model's held-out distances), the move a_i the model's terms leave and the spread of the
effect's own estimate out of fold give the
expected distances (:func:`mean_distance`, a 3-D Gaussian displaced) and the gain's
spread (|a_i|² plus that estimate's, over 3: its projection on the noise). The effect's
estimate spreads at a row by E_i S_f^-1 E_i^T (E_i its move there less what the model's
terms give back, S_f its projected Gram with its prior over the rows out of the row's fold f:
the fold's own estimate, so a row the other folds hardly determine counts as such). The
largest of the three sizes is the one this campaign would detect.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, special
from scipy.special._ufuncs import _ncf_sf   # what scipy.stats' ncf.sf calls, without importing scipy.stats (1 s)

from vecpin.identification.crossval import FoldedProblem

from vecpin.identification.linearised import Linearised
from vecpin.units import MM_PER_M

POWER = 0.9   # the probability with which the stated size is detected (over the noise and the effect's shape)
SHAPES = 48   # shapes drawn from an effect's prior to average that probability over


def detectable_noncentrality(k: int, dof: float, threshold: float, power: float = POWER) -> float:
    """λ at which the F-test (k, dof) at false-alarm rate ``threshold`` passes with
    probability ``power`` (the non-central F distribution)."""
    f_crit = float(special.fdtri(k, dof, 1.0 - threshold))

    def short(lam: float) -> float:
        return float(_ncf_sf(f_crit, k, dof, lam)) - power
    hi = 10.0 + k
    while short(hi) < 0:
        hi *= 2
    return float(optimize.brentq(short, 0.0, hi, xtol=1e-6))


def mean_distance(a: np.ndarray, sigma: float) -> np.ndarray:
    """E|n + a| [a's unit] for n ~ N(0, σ² I_3) displaced by |a| = ``a`` (the mean of a
    non-central chi with 3 degrees of freedom; σ sqrt(8/π) at a = 0)."""
    a = np.asarray(a, float)
    z = a / (sigma * math.sqrt(2))
    far = np.exp(-z * z)
    far *= sigma * math.sqrt(2 / math.pi)
    far += (a + sigma ** 2 / np.maximum(a, 1e-300)) * special.erf(z)
    small = a < 1e-4 * sigma
    if not small.any():   # the series below only where a << σ (most calls: nowhere)
        return far
    near = sigma * math.sqrt(8 / math.pi) + 2 * a ** 2 / (3 * math.sqrt(2 * math.pi) * sigma)   # a << σ: its series
    return np.where(small, near, far)


@dataclass
class Sighting:
    """One candidate's detection size: ``rms_mm`` its RMS displacement of the measured
    points detected with probability :data:`POWER` [mm]; ``by`` the size each
    requirement alone needs {"the F-test", "the held-out test", "the held-out shrink"}."""

    name: str
    label: str
    rms_mm: float
    by: dict
    left_share: float = 1.0   # RMS of the move the model's terms leave over the effect's RMS (shaped as its prior)

    @property
    def limited_by(self) -> str:
        return max(self.by, key=self.by.get)


@dataclass
class Sight:
    """The detection sizes of one model's candidates (:meth:`add` per candidate's columns):
    the final model's folded problem ``base``, its linearisation, the noise left and the test."""

    base: FoldedProblem | None     # set by the scoring round that computes the columns
    lin: Linearised
    held_mm: np.ndarray            # the model's held-out distances [mm] per point row
    sigma2: float                  # whitened scatter per equation left by the model
    dof: float
    min_shrink_pct: float
    folds: int = 5
    threshold: float = float("nan")   # the round's Bonferroni threshold (set once known)
    found: list[Sighting] = field(default_factory=list)
    _pending: list = field(default_factory=list)

    def add(self, effect, cols: tuple, ev: dict | None = None) -> None:
        """Keep a candidate's columns' figures (A_e, J_e) until the round's threshold is known
        (none without rows that measure a point: a size at the tool tip needs them). ``ev``: the
        candidate's :meth:`FoldedProblem.evaluate_extended` on ``base`` when scored (its cross blocks
        are then not formed again)."""
        if self.lin.point_rows.any():
            self._pending.append((effect, self._shape(cols, ev)))

    def _shape(self, cols: tuple, ev: dict | None = None) -> tuple:
        """(k, per drawn shape ψ^T B ψ / ψ^T Q ψ [m² per unit λ σ²], per drawn shape and point row the |move the
        model leaves|² per unit ψ^T B ψ, per point row the variance [m² per unit whitened variance] of the
        effect's fitted move, from all rows). Shapes: :data:`SHAPES` isotropic draws of ψ (fixed seed)."""
        A1, J1 = cols
        Q = J1.shape[-1]
        if ev is None:
            b = J1.reshape(-1, Q)
            M, _ = self.base.full_inverse()
            C = self.base.J.reshape(-1, self.base.n_columns).T @ b
            MC, JtJ = M @ C, b.T @ b
        else:
            C, MC, JtJ = ev["cross"], ev["cross_m"], ev["gram"]
        gram = JtJ - C.T @ MC       # what the model's terms leave of the effect's columns (whitened)
        pts = self.lin.point_rows
        A1p = A1[pts].reshape(-1, Q)
        B = A1p.T @ A1p / max(int(pts.sum()), 1)
        psi = np.random.default_rng(0).normal(size=(SHAPES, Q))
        size2 = np.einsum("sq,qr,sr->s", psi, B, psi)
        proj = np.einsum("sq,qr,sr->s", psi, gram, psi)
        ratio = np.where(proj > 1e-12 * np.maximum(size2, 1e-300), size2 / np.maximum(proj, 1e-300), math.inf)
        A = self.base.A
        E = A1 - (A.reshape(-1, A.shape[-1]) @ MC).reshape(A1.shape)   # the move the model's terms leave, per unit ψ
        n = int(pts.sum())
        left = np.sum(((E[pts].reshape(-1, Q) @ psi.T) ** 2).reshape(n, 3, SHAPES), axis=1).T
        left /= np.maximum(size2, 1e-300)[:, None]
        return Q, ratio, left, self._out_of_fold(E, J1, None if ev is None else ev["fold_schur"])[pts]

    def _out_of_fold(self, E: np.ndarray, J1: np.ndarray, S_f: np.ndarray | None = None) -> np.ndarray:
        """Per row the variance [m² per unit whitened variance] of the effect's fitted move there as its fold
        estimates it (from the other folds' rows, beside the model's terms, with its prior): E_i S_f^-1 E_i^T,
        S_f = J1^T J1 + I - C^T M C over the rows out of fold f (:meth:`FoldedProblem.evaluate_extended`, whose
        ``fold_schur`` they are when given; ``E`` (N,3,Q): the effect's move less what the model's terms give back,
        per unit of its parameters, every row)."""
        base = self.base
        M_f, _, order, rows, J, _, _, _, _ = base._fold_inverses()
        Q = J1.shape[-1]
        E = E[order]
        out = np.empty(len(order))
        if S_f is None:
            J1s = J1[order]
            C_f, B_f = [], []
            for sl in rows:
                b = J1s[sl].reshape(-1, Q)
                C_f.append(J[sl].reshape(-1, base.n_columns).T @ b)
                B_f.append(b.T @ b)
            C, B = sum(C_f), sum(B_f)
            S_f = np.stack([(B - B_f[f]) + np.eye(Q) - (C - C_f[f]).T @ (M_f[f] @ (C - C_f[f]))
                            for f in range(len(rows))])
        for f, sl in enumerate(rows):
            Ef = E[sl].reshape(-1, Q)
            out[sl] = np.einsum("nq,nq->n", Ef @ np.linalg.inv(S_f[f]), Ef).reshape(-1, 3).sum(axis=1)
        spread = np.empty_like(out)
        spread[order] = out
        return spread

    def from_round(self, judged: list, base: FoldedProblem) -> list:
        """Every candidate of a scoring round already run against this model (``judged``:
        [(score, evaluation, columns)], ``base`` its folded problem) kept and settled at its
        threshold; returns ``judged``."""
        self.base = base
        for sc, ev, cols in judged:
            self.add(sc.effect, cols, ev)
        if judged:
            self.settle(judged[0][0].threshold)
        return judged

    def settle(self, threshold: float) -> None:
        """Every kept candidate's :class:`Sighting` at the round's ``threshold``."""
        self.threshold = threshold
        sigma = float(np.mean(self.held_mm)) / math.sqrt(8 / math.pi) if self.held_mm.size else 0.0
        for effect, (k, ratio, left, spread) in self._pending:
            by = {"the F-test": self._f_test(k, ratio)}
            by.update(self._held_out(left, spread * self.sigma2 * MM_PER_M ** 2, sigma))
            share = math.sqrt(float(np.mean(left)))
            self.found.append(Sighting(effect.name, effect.label, max(by.values()), by, share))
        self._pending = []

    def _f_test(self, k: int, ratio: np.ndarray) -> float:
        """The RMS [mm] at which the F-test (k terms) passes at the threshold with probability :data:`POWER`,
        averaged over the drawn shapes (``ratio``: each one's size² per unit λ σ², m²)."""
        ok = np.isfinite(ratio)
        if ok.mean() < POWER:
            return math.inf
        f_crit = float(special.fdtri(k, self.dof, 1.0 - self.threshold))
        per_lam = 1.0 / (ratio[ok] * self.sigma2)          # λ per m² of size²

        def short(rms_mm: float) -> float:
            lam = (rms_mm / MM_PER_M) ** 2 * per_lam
            return float(np.sum(_ncf_sf(f_crit, k, self.dof, lam))) / ratio.size - POWER
        scale = math.sqrt(detectable_noncentrality(k, self.dof, self.threshold) * self.sigma2
                          * float(np.median(ratio[ok]))) * MM_PER_M
        return _root(short, max(scale, 1e-12))

    def _held_out(self, left: np.ndarray, spread: np.ndarray, sigma: float) -> dict:
        """The RMS [mm] at which the paired held-out test passes with probability
        :data:`POWER` (averaged over the drawn shapes, ``left`` (S, n)), and at which the held-out mean
        shrinks by ``min_shrink_pct`` for the average shape (module docstring; each point row's noise σ [mm]
        per coordinate, ``spread`` [mm²] the variance of the effect's fitted move there, from every row)."""
        n = left.shape[-1]
        if sigma <= 0 or n < 2 or not np.any(left > 0):
            return {}
        h = spread                                          # estimated out of fold
        m_after = mean_distance(np.sqrt(h), sigma)
        t_crit = float(-special.stdtrit(n - 1, self.threshold))
        shrink = 1 - self.min_shrink_pct / 100
        mean_left, root_left = left.mean(axis=0), np.sqrt(left)

        def t_short(rms: float) -> float:
            a = rms * root_left
            gain = mean_distance(a, sigma) - m_after
            t = np.sum(gain, axis=-1) / np.sqrt(np.sum(a ** 2 + h, axis=-1) / 3)
            return float(np.mean(special.ndtr(t - t_crit))) - POWER

        def shrink_short(rms: float) -> float:
            return shrink - float(np.sum(m_after)) / float(np.sum(mean_distance(rms * np.sqrt(mean_left), sigma)))
        return {"the held-out test": _root(t_short, sigma), "the held-out shrink": _root(shrink_short, sigma)}

    def families(self) -> list[dict]:
        """Per effect family: the smallest size detected (its candidate), the largest, the
        rows and the test (sizes in µm, RMS over the measured points)."""
        out = []
        for name in dict.fromkeys(s.name for s in self.found):
            mine = sorted((s for s in self.found if s.name == name), key=lambda s: s.rms_mm)
            best, worst = mine[0], mine[-1]
            out.append({"effect": name, "detectable_rms_um": _um(best.rms_mm), "candidate": best.label,
                        "detectable_unmodelled_rms_um": _um(best.rms_mm * best.left_share),
                        "hardest_rms_um": _um(worst.rms_mm), "hardest_candidate": worst.label,
                        "limited_by": best.limited_by, "sizes_um": {k: _um(v) for k, v in best.by.items()},
                        "candidates": len(mine), "per_candidate_um": {x.label: _um(x.rms_mm) for x in mine},
                        "rows": int(len(self.lin.r)),
                        "power": POWER, "p_threshold": self.threshold})
        return sorted(out, key=lambda d: math.inf if d["detectable_rms_um"] is None else d["detectable_rms_um"])


def _root(short, scale: float) -> float:
    """The smallest size [scale's unit] where ``short`` (increasing) reaches 0; inf when none up to 1e6 x scale does."""
    if short(0.0) >= 0:
        return 0.0
    hi = scale
    while short(hi) < 0:
        hi *= 2
        if hi > 1e6 * scale:
            return math.inf
    return float(optimize.brentq(short, 0.0, hi, xtol=1e-4 * scale, rtol=1e-4))


def _um(mm: float) -> float | None:
    """mm -> µm, None where nothing this campaign measures would show it."""
    return float(mm * 1e3) if math.isfinite(mm) else None


def sight_of(lin: Linearised, ev: dict, held_mm: np.ndarray, min_shrink_pct: float, folds: int) -> Sight:
    """A :class:`Sight` for the model of ``lin`` (``ev``: its folded evaluation, ``held_mm``
    its held-out distances [mm]): the scatter its fit leaves per degree of freedom."""
    dof = max(lin.n_equations - ev["p_eff"], 1.0)
    return Sight(None, lin, held_mm, max(float(ev["chi2"]) / dof, 1e-12), dof, min_shrink_pct, folds)


def sightings_text(families: list[dict], rows: int, limit: int = 3) -> str:
    """'this plan (N rows) would detect rotary_periodic from 1.8 µm, ...' (RMS at the measured points). The
    sizes hold for effects of the candidates' own forms (their shapes drawn from their priors): an effect of
    another form (a lag, a curvature, terms on other axes) shows only the part those forms carry."""
    seen = [f for f in families if f["detectable_rms_um"] is not None][:limit]
    if not seen:
        return f"this plan ({rows} rows) would detect none of the candidate effects"
    return (f"this plan ({rows} rows) would detect " + ", ".join(
        f"{f['effect']} from {um_text(f['detectable_rms_um'])}" for f in seen)
        + f" (RMS at the tool tip, {POWER:.0%} of the time, of an effect in the form its family models; "
        "another form can need more)")


def um_text(um: float | None) -> str:
    """A detection size [µm] as text, in mm from 1 mm (None: the campaign cannot show it)."""
    if um is None:
        return "no size (the campaign cannot show it)"
    return f"{um / 1e3:.1f} mm" if um >= 1e3 else f"{um:.1f} µm"
