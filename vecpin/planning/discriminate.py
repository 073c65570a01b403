"""What to measure next: a short measurement that tells rival explanations apart.

When a campaign cannot tell two (or more) explanations of its residual apart (an
ambiguity group of the diagnosis: a gantry skew or a coupling of two axes), each
explanation is a model fitted to the same rows. They agree where the campaign measured
and differ elsewhere; this module picks the commands where their predicted tracker
readings differ most *relative to what a reading there can tell*:

* a pool of quasi-random commands (:func:`vecpin.planning.candidates.candidate_commands`)
  over the machine's travel (where the campaign did not go, two explanations that agree
  on it may part), each with every target holder the campaign used (the tool length is a
  lever arm one explanation may have and another not);
* for every pair of candidate models, the difference of their predicted readings,
  whitened by the one likelihood (the tracker's noise there and the machine's
  positioning noise, and the model's misfit beyond it: ``scatter``), as a Gaussian process whose covariance also holds each model's
  own prediction covariance (``cov_``): a difference that a model could absorb by
  refitting its uncertain terms counts less, and so does a second point where the first
  already told the same (the process is conditioned on the points taken);
* greedily the point whose reading adds most to the chi-square between the hardest pair
  of candidates, given those taken: at least ``n_min``, then up to ``n_max`` while a
  point still adds more than 1 (more than the noise);
* ordered into a short tour (:func:`vecpin.planning.route.order_points`), measured right
  after the campaign (times continue from its last row, at its median time per row;
  the temperature stays at its last reading), and the expected reading of every point
  under every candidate.

Appending the readings to the campaign (same tracker set-up) and diagnosing again
settles the group: the readings follow one candidate's predictions (the expected
chi-square between the two closest candidates is printed with the plan).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vecpin.errors import InputError
from vecpin.identification.likelihood import Likelihood
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.features import Features, approach_directions
from vecpin.measurement.plantemplate import PlanTemplate
from vecpin.models import ErrorModel
from vecpin.planning import route
from vecpin.planning.ncprogram import write_program
from vecpin.planning.candidates import candidate_commands
from vecpin.units import MM_PER_M


@dataclass
class Discrimination:
    """A discriminating measurement: ``labels`` of the candidates (C), the commands ``q``
    (K,n) [m, rad] in measurement order with target holder lengths ``tool`` (K,) [m],
    ``expected`` (C,K,3) [m] each candidate's predicted tracker reading (the fitted
    campaign's tracker frame), ``gain`` (K,) what each point's reading adds to the
    chi-square between the two closest candidates, given the points chosen before it
    (each candidate refitting its own uncertain terms), ``time`` (K,) [s]
    the rows' times as planned and ``temperature`` (K,) [°C] or None."""

    labels: list[str]
    q: np.ndarray
    tool: np.ndarray
    expected: np.ndarray
    gain: np.ndarray
    time: np.ndarray
    temperature: np.ndarray | None = None
    files: dict = field(default_factory=dict)  # what was written: {"plan": name, "expected": name, programs...}
    # the axes whose commands leave the campaign's measured range (:func:`measured_box`), with that range in
    # the axis' unit: {name: (low, high, "mm" or "deg")}; empty: every command inside it (no extrapolation)
    beyond: dict = field(default_factory=dict)

    @property
    def chi2_gap(self) -> float:
        """The expected chi-square between the two closest candidates over all points."""
        return float(np.sum(self.gain))

    def template(self) -> PlanTemplate:
        """The points as a plan template (no approach moves: positioned directly)."""
        return PlanTemplate(np.arange(1, len(self.tool) + 1), self.q, self.tool, None, "discriminating plan")

    def expected_csv(self, machine: Machine) -> str:
        """One line per point: its commands (mm, deg), holder [mm], the expected reading
        under each candidate (x, y, z [mm], tracker frame) and what it adds to the chi-square
        between the two closest candidates."""
        head = ["point"] + machine.axis_names + ["tool"]
        for lab in self.labels:
            head += [f"{lab} {c} [mm]" for c in "xyz"]
        head.append("gain [chi2]")
        q_user = machine.to_user(self.q)
        lines = [",".join(f'"{h}"' if "," in h else h for h in head)]
        for k in range(len(self.tool)):
            cells = [str(k + 1)] + [f"{v:.3f}" for v in q_user[k]] + [f"{self.tool[k] * MM_PER_M:.3f}"]
            cells += [f"{v * MM_PER_M:.4f}" for c in range(len(self.labels)) for v in self.expected[c, k]]
            lines.append(",".join(cells + [f"{self.gain[k]:.2f}"]))
        return "\n".join(lines) + "\n"

    def program(self, machine: Machine, dialect: str, **kw) -> str:
        """The NC program visiting the points (:func:`vecpin.planning.ncprogram.write_program`)."""
        return write_program(dialect, machine, self.template(), np.zeros(machine.n_axes),
                             title=f"to tell {', '.join(self.labels[:-1])} and {self.labels[-1]} apart", **kw)

    def outcome(self) -> str:
        """The expected outcome under each candidate, in words (sizes in µm, in mm from 1 mm)."""
        d = np.linalg.norm(self.expected[:, None] - self.expected[None, :], axis=-1) * MM_PER_M  # mm
        pairs = [(i, j) for i in range(len(self.labels)) for j in range(i + 1, len(self.labels))]
        said = "; ".join(f"{self.labels[i]} and {self.labels[j]} predict readings {length_text(d[i, j].mean())} apart "
                         f"on average (up to {length_text(d[i, j].max())})" for i, j in pairs)
        text = (f"{len(self.tool)} points where {said}: an expected chi2 of {self.chi2_gap:.0f} between the two "
                "closest candidates, each refitting its own uncertain terms; the readings will follow the true "
                "candidate's column of the expected readings")
        if self.beyond:
            text += (f". Extrapolation: these points go beyond the campaign's measured range ({self.beyond_text()}), "
                     "where every candidate's prediction is an extrapolation of a model fitted inside it; trust the "
                     "readings there, not the predicted sizes")
        return text

    def beyond_text(self) -> str:
        """'X beyond its measured 0.0..300.0 mm, ...' per axis the plan leaves the measured range on."""
        return ", ".join(f"{name} beyond its measured {lo:.1f}..{hi:.1f} {unit}"
                         for name, (lo, hi, unit) in self.beyond.items())


def length_text(mm: float) -> str:
    """A length [mm] as '12.3 µm' below 1 mm, '40.3 mm' from 1 mm."""
    return f"{mm:.1f} mm" if abs(mm) >= 1.0 else f"{mm * 1e3:.1f} µm"


def measured_box(campaign: Campaign) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) (n,) [m, rad]: the range each axis was commanded over in ``campaign``."""
    return campaign.q.min(axis=0), campaign.q.max(axis=0)


def _after(campaign: Campaign, q: np.ndarray, tool: np.ndarray) -> tuple[Campaign, Features]:
    """The rows (q, tool) as measured right after ``campaign``: times continue from its
    last row at its median time per row, the temperature stays at its last reading, the
    approach directions follow from its last command. Readings are zeros (placeholders)."""
    extra = {}
    if campaign.time is not None:
        t = np.asarray(campaign.time, float)
        dt = float(np.median(np.diff(t))) if len(t) > 1 else 15.0
        extra["time"] = t[-1] + dt * np.arange(1, len(q) + 1)
    if campaign.temperature is not None:
        extra["temperature"] = np.full(len(q), float(campaign.temperature[-1]))
    new = Campaign(campaign.axis_names, q, tool, np.zeros((len(q), 3)), extra, "discriminating plan")
    feats = Features.from_campaign(new)
    feats.direction = approach_directions(np.vstack([campaign.q[-1:], q]))[1:]
    feats.row = len(campaign) + np.arange(len(q))
    return new, feats


def _whitened(model: ErrorModel, camp: Campaign, feats: Features, jacobian: bool = True
              ) -> tuple[np.ndarray, np.ndarray | None]:
    """(w (N,3): the whitened residuals of ``camp``'s readings under ``model``; H (N,3,P):
    the whitened Jacobian of the readings over theta = [E_0, b], scaled so that H H^T is
    the model's own prediction covariance there (``cov_`` = L L^T, H = J L)): the one
    likelihood at the fitted solution (noise of the reading there and the machine's
    positioning noise). Without ``jacobian``: (w, None)."""
    lik = Likelihood(model, camp, model.noise_, setup=model.setup_, features=feats)
    ev = lik.evaluate(lik.theta_of(model), jacobian=jacobian)
    if not jacobian:
        return np.where(ev.valid, ev.w, 0.0), None
    n = model.cov_.shape[0]
    val, vec = np.linalg.eigh(model.cov_)
    root = vec * np.sqrt(np.clip(val, 0.0, None))  # cov_ = root root^T (semi-definite: terms removed are 0)
    N = len(ev.J)
    H = ((ev.J[..., :n] / lik.sigma[:n]).reshape(-1, n) @ root).reshape(N, 3, n)   # one product, not N small ones
    return np.where(ev.valid, ev.w, 0.0), np.where(ev.valid[..., None], H, 0.0)


class _Pair:
    """Two candidates' difference over the pool as a Gaussian process: the whitened
    difference of their predicted readings ``mu`` (3N,) and its covariance
    s I + H_a H_a^T + H_b H_b^T (``scatter`` s: a reading's whitened variance about the
    right model, 1 for noise alone, more where the model misfits; H: both models' own
    uncertainty: a difference one of them can absorb by refitting its uncertain terms
    counts less), conditioned row by row on
    the rows taken (incremental Cholesky); ``gain(rows)`` is what a reading adds to the
    chi-square between the two after those taken."""

    def __init__(self, d: np.ndarray, Ha: np.ndarray, Hb: np.ndarray, scatter: float = 1.0):
        self.H = np.concatenate([Ha, Hb], axis=-1).reshape(-1, Ha.shape[-1] + Hb.shape[-1])
        self.mu = d.ravel().copy()
        self.scatter = scatter
        self.var = scatter + np.einsum("rp,rp->r", self.H, self.H)
        self.L = np.empty((len(self.mu), 48))   # the Cholesky factor's rows taken so far, as columns: the first k
        self.k = 0

    def gains(self) -> np.ndarray:
        """(N,) per point the sum of its three rows' conditional gains mu^2 / var."""
        g = np.divide(self.mu ** 2, self.var, out=np.zeros_like(self.mu), where=self.var > 1e-12)
        return g.reshape(-1, 3).sum(axis=1)

    def take(self, point: int) -> float:
        """Condition on the three rows of ``point`` (the factor's rank-3 update: the point's
        covariance columns in one product over H, less what the rows taken explain); returns their joint gain."""
        rows = slice(3 * point, 3 * point + 3)
        cols = self.H @ self.H[rows].T - self.L[:, :self.k] @ self.L[rows, :self.k].T   # (3N, 3)
        gain, start = 0.0, self.k
        for j, r in enumerate(range(3 * point, 3 * point + 3)):
            v = float(self.var[r])
            if v <= 1e-12:
                continue
            col = cols[:, j].copy()
            col[r] += self.scatter
            col -= self.L[:, start:self.k] @ self.L[r, start:self.k]   # the rows of this point taken before r
            col /= np.sqrt(v)
            gain += float(self.mu[r]) ** 2 / v
            self.mu -= col * (self.mu[r] / np.sqrt(v))
            self.var = np.maximum(self.var - col ** 2, 0.0)
            if self.k == self.L.shape[1]:
                self.L = np.hstack([self.L, np.empty_like(self.L)])
            self.L[:, self.k] = col
            self.k += 1
        return gain


def _choose(pairs: list[_Pair], n_min: int, n_max: int) -> tuple[np.ndarray, np.ndarray]:
    """(points, their gains): greedily the point whose reading adds most to the chi-square
    of the hardest pair (the smallest over the pairs), given the points taken: ``n_min``
    at least, then up to ``n_max`` while a point still adds more than 1 (the noise)."""
    taken, gains = [], []
    for _ in range(n_max):
        g = np.min([p.gains() for p in pairs], axis=0)
        g[taken] = -np.inf
        k = int(np.argmax(g))
        if len(taken) >= n_min and g[k] <= 1.0:
            break
        taken.append(k)
        gains.append(min(p.take(k) for p in pairs))
    return np.array(taken, int), np.array(gains)


def discriminating_plan(models: dict[str, ErrorModel], campaign: Campaign, *, n_min: int = 15, n_max: int = 40,
                        n_pool: int = 2000, seed: int = 0, scatter: float = 1.0,
                        inside: bool = True) -> Discrimination:
    """Commands that tell the fitted ``models`` {label: model, all fitted to ``campaign``}
    apart (module docstring): ``n_min`` to ``n_max`` points from ``n_pool`` candidates
    inside the campaign's measured range per axis (:func:`measured_box`; ``inside`` False:
    over the machine's travel, the plan's :attr:`Discrimination.beyond` naming the axes it
    leaves the measured range on), each with every target holder the campaign's tracker rows used.
    ``scatter``: a reading's whitened variance about the right model (1: the noise alone;
    the held-out chi2 per equation of the fitted model when it misfits beyond the noise)."""
    if len(models) < 2:
        raise InputError("models: a discriminating plan needs at least two candidate models")
    if not (1 <= n_min <= n_max):
        raise InputError(f"n_min {n_min}, n_max {n_max}: need 1 <= n_min <= n_max")
    labels, fitted = list(models), list(models.values())
    machine = fitted[0].machine
    on = campaign.instrument == "tracker"
    if not on.any():
        raise InputError(f"{campaign.source}: no tracker rows to take the target holders from")
    box = measured_box(campaign)
    lo, hi = box if inside else (machine.lower, machine.upper)
    holders = np.unique(np.round(campaign.tool[on], 9))
    cmds = candidate_commands(machine, n_pool, lo, hi, seed)
    pool, tool = np.repeat(cmds, len(holders), axis=0), np.tile(holders, len(cmds))  # every holder at every command
    camp, feats = _after(campaign, pool, tool)
    pairs = _pairs(fitted, camp, feats, max(float(scatter), 1.0))
    took, gain = _choose(pairs, n_min, n_max)
    q, tool, gain = pool[took], tool[took], gain
    order = []
    for h in holders:  # one holder after the other, each in a short tour
        k = np.flatnonzero(tool == h)
        try:
            k = k[route.order_points(q[k], route.axis_speeds(machine))]
        except InputError:  # no velocity limits in the URDF: the greedy order
            pass
        order += list(k)
    q, tool, gain = q[order], tool[order], gain[order]
    camp, feats = _after(campaign, q, tool)
    y = np.stack([m.predict_tip(q, tool, "tracker", feats) for m in fitted])
    tol = 1e-9 + 1e-6 * np.abs(box[1] - box[0])
    out = (q < box[0] - tol).any(axis=0) | (q > box[1] + tol).any(axis=0)
    beyond = {}
    for k in np.flatnonzero(out):
        ax = machine.axes[k]
        beyond[ax.name] = (float(ax.to_user(box[0][k])), float(ax.to_user(box[1][k])), ax.unit)
    return Discrimination(labels, q, tool, y, gain, camp.extra.get("time", feats.time), camp.temperature,
                          beyond=beyond)


def _pairs(models: list[ErrorModel], camp: Campaign, feats: Features, scatter: float) -> list[_Pair]:
    """Every pair of candidate models over the pool ``camp`` (its readings are not used)."""
    y = [m.predict_tip(camp.q, camp.tool, "tracker", feats) for m in models]

    def reading(k):  # the rows read as candidate k predicts them
        return Campaign(camp.axis_names, camp.q, camp.tool, y[k], camp.extra, camp.source)
    H = [_whitened(m, reading(k), feats)[1] for k, m in enumerate(models)]
    out = []
    for i in range(len(models)):
        for j in range(i + 1, len(models)):
            out.append(_Pair(_whitened(models[i], reading(j), feats, jacobian=False)[0], H[i], H[j], scatter))
    return out
