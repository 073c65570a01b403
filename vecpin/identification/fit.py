"""Maximum-likelihood identification with the implicit-loop structure (Paper I eq.
11-12; Section 3 eq. 49-59).

Each measured row i closes the loop ``h(x_i) = h(T_m E_0 F(q_i + v_i, b) p_Tl) + ξ_i``
with axis noise ``v_i ~ N(0, Σ_v)`` and instrument noise ``ξ_i ~ N(0, Σ_ξ)``
(``h`` the identity or the spherical map). Eliminating ``v_i`` and ``ξ_i`` at the
current linearisation, exactly as the ILM's orthogonal decomposition (eq. 56-59)
does, leaves for every row the residual ``r_i`` with covariance
``C_i = H A_i Σ_v A_i^T H^T + Σ_ξ`` (``A_i = d y / d q``). The estimator
minimises ``χ² = Σ r_i^T C_i^{-1} r_i + b^T Σ_b^{-1} b`` by damped Gauss-Newton on
the whitened, prior-scaled problem (the normalised variables ψ of eq. 52), with
Pinocchio's analytic Jacobians; rows may carry different instruments later.

The tracker frame is registered automatically (rigid fit of the nominal tips,
:mod:`vecpin.registration`) and the small correction ``E_0`` (eq. 10) is estimated
with the model. Redundant parameters are found from the prior-scaled sensitivity at
the measured poses by QR in priority order and removed; the report lists them.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy import linalg

from vecpin.measurement.campaign import Campaign
from vecpin.errors import VecpinError
from vecpin.models import ErrorModel
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.registration import register
from vecpin.measurement.stats import residual_stats
from vecpin.kinematics.so3 import exp3, right_jacobian, skew

E0_NAMES = ("E0.dx", "E0.dy", "E0.dz", "E0.ex", "E0.ey", "E0.ez")
E0_PRIORS = np.array([1e-2, 1e-2, 1e-2, 1e-2, 1e-2, 1e-2])  # m, rad: weak
REDUNDANT_RATIO = 1e-7    # |R_kk| / |column k|: below, a term is a combination of earlier ones
WEAK_RATIO = 1e-3         # below, the design barely tells the term from earlier ones
INSENSITIVE = 1e-9        # column norm relative to the largest: the term does not move the tool tip


@dataclass
class Setup:
    """The tracker pose: ``p_tracker = R (exp3(eps0) p + delta0) + t`` (station 0).

    ``stations``: other tracker positions, {id: (R, t, e)} with e their small correction;
    ``pivots``: ball bar centre sockets, {id: centre (3,) [m], machine frame}."""

    R: np.ndarray
    t: np.ndarray
    e0: np.ndarray = field(default_factory=lambda: np.zeros(6))  # (dx, dy, dz [m], ex, ey, ez [rad])
    stations: dict = field(default_factory=dict)
    pivots: dict = field(default_factory=dict)

    def pose(self, station: int = 0):
        return (self.R, self.t, self.e0) if station == 0 else self.stations[station]

    def to_tracker(self, p: np.ndarray, station: int = 0) -> np.ndarray:
        R, t, e = self.pose(station)
        return (p @ exp3(e[3:]).T + e[:3]) @ R.T + t


@dataclass
class FitReport:
    """What a fit tells: χ² against its band, residuals, conditioning, removed terms."""

    model: str
    order: int
    instrument: str
    n_rows: int
    n_equations: int
    n_parameters: int
    removed: list[str]
    weak: list[str]
    effective_parameters: float
    chi2: float
    chi2_expected: float
    chi2_sigma: float
    condition_number: float
    iterations: int
    converged: bool
    seconds: float
    residuals_mm: dict
    warnings: list[str]
    tool_lengths_mm: list[float] = field(default_factory=list)

    @property
    def chi2_band(self) -> tuple[float, float]:
        return (self.chi2_expected - 3 * self.chi2_sigma, self.chi2_expected + 3 * self.chi2_sigma)

    @property
    def chi2_in_band(self) -> bool:
        lo, hi = self.chi2_band
        return lo <= self.chi2 <= hi

    def to_dict(self) -> dict:
        d = dict(self.__dict__)
        d["chi2_band"] = list(self.chi2_band)
        d["chi2_in_band"] = self.chi2_in_band
        return d

    def summary(self) -> str:
        lo, hi = self.chi2_band
        verdict = "in band" if self.chi2_in_band else ("ABOVE band: misfit or noise model too optimistic"
                                                        if self.chi2 > hi else "BELOW band: noise model too pessimistic")
        lines = [f"{self.model} model, order {self.order}, {self.instrument} instrument noise: {self.n_rows} rows, "
                 f"{self.n_parameters} parameters ({len(self.removed)} redundant removed, "
                 f"{self.effective_parameters:.1f} effective), {self.iterations} iterations in {self.seconds:.2f} s",
                 f"chi2 = {self.chi2:.1f}, expected {self.chi2_expected:.1f} ± {self.chi2_sigma:.1f} "
                 f"(3σ band {lo:.1f} .. {hi:.1f}): {verdict}",
                 f"condition number (prior-scaled, kept terms): {self.condition_number:.3g}"]
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)


def _in_tracker(tip, J_b, J_q, R, t, e, P: int, e_col: int, b_cols: slice, jacobian: bool = True):
    """Machine-frame tips into a tracker frame ``R (exp3(e_rot) p + e_trans) + t``; with
    ``jacobian`` also d y / d theta (N,3,P) (pose correction at ``e_col``, model
    parameters at ``b_cols``) and d y / d q (N,3,n)."""
    R0 = exp3(e[3:])
    y = (tip @ R0.T + e[:3]) @ R.T + t
    if not jacobian:
        return y, None, None
    RR = R @ R0
    dy = np.zeros((len(y), 3, P))
    dy[:, :, e_col:e_col + 3] = R
    dy[:, :, e_col + 3:e_col + 6] = -np.einsum("ij,pjk,kl->pil", RR, skew(tip), right_jacobian(e[3:]))
    dy[:, :, b_cols] = np.einsum("ij,pjk->pik", RR, J_b)
    return y, dy, np.einsum("ij,pjk->pik", RR, J_q)


def _whiten(r, H, S, A, axis_sigma, dy, sigma):
    """Per-row whitening with C = H A Σ_v A^T H^T + Σ_ξ (the axis and instrument noise
    eliminated at the linearisation): residuals w and d w / d psi, rows flattened."""
    HA = H @ A
    C = np.einsum("pij,j,pkj->pik", HA, axis_sigma**2, HA) + S
    L = np.linalg.cholesky(C)
    w = np.linalg.solve(L, r[..., None])[..., 0]
    Jw = -np.linalg.solve(L, H @ dy) * sigma
    return w.ravel(), Jw.reshape(w.size, -1)


def predict_tracker(model: ErrorModel, q: np.ndarray, tool: np.ndarray, theta: np.ndarray, setup: Setup,
                    features=None, jacobian: bool = True):
    """Modelled measurements in the tracker frame y (N,3) [m]; with ``jacobian`` also
    d y / d theta (N,3,P+6) and d y / d q (N,3,n). theta = [E_0, b]."""
    e0, b = theta[:6], theta[6:]
    mt = model.tool_tip(q, tool, b, jacobian=jacobian, features=features)
    y, dy, dq = _in_tracker(mt.tip, mt.J_b, mt.J_q, setup.R, setup.t, e0, 6 + model.n_parameters, 0,
                            slice(6, None), jacobian)
    tracker_effects = [(e, sl) for e, sl in model.effect_slices() if "tracker" in e.kinds]
    D_tr = [(sl, e.tracker(y, features)) for e, sl in tracker_effects]
    grad = sum((e.tracker_gradient(y, features, b[sl]) for e, sl in tracker_effects), np.zeros((len(y), 3, 3)))
    for sl, D in D_tr:
        y = y + np.einsum("pik,k->pi", D, b[sl])
    if not jacobian:
        return y, None, None
    if tracker_effects:
        M = np.eye(3) + grad  # the tracker effects move with the point they act on
        dy, dq = M @ dy, M @ dq
    for sl, D in D_tr:
        dy[:, :, 6 + sl.start:6 + sl.stop] = D
    return y, dy, dq


class _Problem:
    """The whitened, prior-scaled least-squares problem of one fit."""

    def __init__(self, model: ErrorModel, campaign: Campaign, noise: NoiseModel, setup: Setup, features=None):
        self.model, self.campaign, self.noise, self.setup = model, campaign, noise, setup
        self.features = features
        self.sigma = np.r_[E0_PRIORS, model.priors]  # prior standard deviations of theta = [e0, b]

    def predict(self, theta: np.ndarray):
        """Tracker-frame tool tips y (N,3) [m], d y / d theta (N,3,P+6) and d y / d q (N,3,n)."""
        c = self.campaign
        return predict_tracker(self.model, c.q, c.tool, theta, self.setup, self.features)

    def evaluate(self, theta: np.ndarray):
        """Whitened residuals w (3N,), d w / d psi (3N, P+6) with psi = theta / sigma
        (the covariance C_i held at this linearisation, as the ILM does), and y."""
        y, dy, A = self.predict(theta)
        r, H, S = self.noise.residuals(self.campaign.xyz, y)
        w, Jw = _whiten(r, H, S, A, self.noise.axis_sigma, dy, self.sigma)
        return w, Jw, y


def sphere_centre(p: np.ndarray) -> np.ndarray:
    """Least-squares centre of points on a sphere (algebraic fit, |p|^2 = 2 p.o + c)."""
    A = np.c_[2 * p, np.ones(len(p))]
    sol = np.linalg.lstsq(A, np.sum(p * p, axis=1), rcond=None)[0]
    return sol[:3]


class _MixedProblem:
    """Rows of several instruments in one likelihood (Section 3.4.2): tracker rows of any
    station (3 equations each, or 1 range equation in multilateration mode) and ball bar
    rows (1 equation: the radius, eq. 45-47, about an unknown pivot). Unknowns beyond
    [E_0, b]: a pose correction per extra station and a centre correction per pivot."""

    def __init__(self, model: ErrorModel, campaign: Campaign, noise: NoiseModel, setup: Setup, features=None):
        self.model, self.campaign, self.noise, self.setup, self.features = model, campaign, noise, setup, features
        trk = campaign.tracker_rows
        self.groups = {int(s): trk[campaign.station[trk] == s] for s in np.unique(campaign.station[trk])}
        self.extra_stations = [s for s in sorted(self.groups) if s != 0]
        self.pivot_ids = sorted(int(p) for p in np.unique(campaign.pivot[campaign.ballbar_rows]))
        self.extra_names = [f"station{s}.{c}" for s in self.extra_stations for c in ("dx", "dy", "dz", "ex", "ey", "ez")] + \
                           [f"pivot{k}.{c}" for k in self.pivot_ids for c in ("x", "y", "z")]
        nb = 6 + model.n_parameters
        self.sl_station = {s: slice(nb + 6 * k, nb + 6 * k + 6) for k, s in enumerate(self.extra_stations)}
        off = nb + 6 * len(self.extra_stations)
        self.sl_pivot = {p: slice(off + 3 * k, off + 3 * k + 3) for k, p in enumerate(self.pivot_ids)}
        self.sigma = np.r_[E0_PRIORS, model.priors, np.full(6 * len(self.extra_stations), 1e-2),
                           np.full(3 * len(self.pivot_ids), 1e-2)]
        if 0 not in self.groups:
            raise VecpinError(f"{campaign.source}: tracker station 0 has no rows; it anchors the machine frame")

    def evaluate(self, theta: np.ndarray):
        m, c, noise = self.model, self.campaign, self.noise
        P = len(theta)
        b = theta[6:6 + m.n_parameters]
        mt = m.tool_tip(c.q, c.tool, b, jacobian=True, features=self.features)
        ws, Js = [], []
        y_all = np.full((len(c), 3), np.nan)
        for s, rows in self.groups.items():
            if s == 0:
                R, t, e_sl = self.setup.R, self.setup.t, slice(0, 6)
            else:
                R, t, _ = self.setup.stations[s]
                e_sl = self.sl_station[s]
            y, dy, A = _in_tracker(mt.tip[rows], mt.J_b[rows], mt.J_q[rows], R, t, theta[e_sl], P, e_sl.start,
                                   slice(6, 6 + m.n_parameters))
            y_all[rows] = y
            x = c.xyz[rows]
            if noise.instrument == "range":  # multilateration: the interferometer range only
                Rm, Ry = np.linalg.norm(x, axis=1), np.linalg.norm(y, axis=1)
                u = y / Ry[:, None]
                r = (Rm - Ry)[:, None]
                H = u[:, None, :]
                S = noise.tracker.sigma_range(Rm)[:, None, None] ** 2
            else:
                r, H, S = noise.residuals(x, y)
            w, Jw = _whiten(r, H, S, A, noise.axis_sigma, dy, self.sigma)
            ws.append(w)
            Js.append(Jw)
        bb = c.ballbar_rows
        if bb.size:
            centres = np.array([self.setup.pivots[p] + theta[self.sl_pivot[p]] for p in c.pivot[bb]])
            d = mt.tip[bb] - centres
            dist = np.linalg.norm(d, axis=1)
            u = d / dist[:, None]
            r = c.radius[bb] - dist
            dr = np.zeros((bb.size, P))
            dr[:, 6:6 + m.n_parameters] = np.einsum("pi,pik->pk", u, mt.J_b[bb])
            for k, p in enumerate(c.pivot[bb]):
                dr[k, self.sl_pivot[p]] = -u[k]
            uA = np.einsum("pi,pik->pk", u, mt.J_q[bb])
            var = np.einsum("pk,k,pk->p", uA, noise.axis_sigma**2, uA) + noise.ballbar_sigma**2
            sd = np.sqrt(var)
            ws.append(r / sd)
            Js.append(-(dr / sd[:, None]) * self.sigma)
        return np.concatenate(ws), np.concatenate(Js), y_all


def find_redundant(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Columns of J (prior-scaled sensitivity) that earlier columns already explain.

    QR without pivoting keeps the given priority order: |R_kk| / |a_k| is the sine of
    the angle between column k and the span of the columns before it. Columns far
    smaller than the largest (e.g. a rotation about the tool axis) move nothing. Returns
    (redundant mask, ratio per column)."""
    norms = np.linalg.norm(J, axis=0)
    active = norms > INSENSITIVE * norms.max()  # a term that does not move the tool tip at all
    ratio = np.zeros(J.shape[1])
    Rm = linalg.qr(J[:, active], mode="r", check_finite=False)[0]
    k = min(Rm.shape)
    diag = np.abs(np.diag(Rm[:k, :k]))
    r_active = np.zeros(active.sum())
    r_active[:k] = diag / norms[active][:k]
    ratio[active] = r_active
    return ratio < REDUNDANT_RATIO, ratio


def _structural_redundancy(model: ErrorModel, campaign: Campaign, noise: NoiseModel, P: int) -> tuple:
    """Redundant terms judged on a rich quasi-random design (1000 commands, the campaign's
    tools) instead of the measured poses: only what no design could identify."""
    from scipy.stats import qmc
    m = model.machine
    u = qmc.Halton(m.n_axes, seed=0).random(1000)
    q = m.lower + u * (m.upper - m.lower)
    tools = campaign.tool_lengths()
    qq = np.repeat(q, len(tools), axis=0)
    tt = np.tile(tools, len(q))
    nominal = m.tool_tip(qq, tt)
    ref = Campaign(m.axis_names, qq, tt, nominal, {}, "reference design")
    cart = NoiseModel(noise.axis_sigma, "cartesian", noise.cartesian_sigma)
    J = _Problem(model, ref, cart, Setup(np.eye(3), np.zeros(3))).evaluate(np.zeros(6 + model.n_parameters))[1]
    red, ratio = find_redundant(J)
    extra = P - red.size
    return np.r_[red, np.zeros(extra, bool)], np.r_[ratio, np.ones(extra)]


def fit(model: ErrorModel, campaign: Campaign, noise: NoiseModel | None = None, *, max_iter: int = 30,
        tol: float = 1e-9, remove_redundant: bool = True, underdetermined: bool = False,
        progress: Callable[[str], None] | None = None):
    """Identify ``model``'s parameters from ``campaign``; returns (theta, setup, cov, report).

    theta = [E_0 (6), b (P), station corrections, pivot corrections] SI; cov is the
    covariance of theta (zeros for removed terms). ``underdetermined``: accept fewer
    equations than parameters, the priors Σ_b deciding what the data cannot (Section
    3.5.2 fits 50 tracker points this way); redundancy is then judged on a reference
    design, so only structurally redundant terms are removed."""
    t0 = time.perf_counter()
    if list(campaign.axis_names) != model.machine.axis_names:
        raise VecpinError(f"{campaign.source}: axes {campaign.axis_names} do not match machine "
                          f"'{model.machine.name}' ({', '.join(model.machine.axis_names)})")
    noise = noise or NoiseModel.default(model.machine)
    mixed = campaign.mixed or noise.instrument == "range"
    features = None
    if model.effects:
        from vecpin.measurement.features import Features
        features = Features.from_campaign(campaign)
        for e in model.effects:
            e.prepare(campaign, features)
    nominal = model.machine.tool_tip(campaign.q, campaign.tool)
    if mixed:
        if model.effects and any("tracker" in e.kinds for e in model.effects):
            raise VecpinError("tracker-frame effects are not supported with several stations or ball bar rows")
        trk = campaign.tracker_rows
        st = campaign.station[trk]
        r0 = trk[st == 0]
        if r0.size < 3:
            raise VecpinError(f"{campaign.source}: tracker station 0 needs at least 3 rows")
        R, t = register(nominal[r0], campaign.xyz[r0])
        setup = Setup(R, t)
        for s in np.unique(st):
            if s != 0:
                rs = trk[st == s]
                Rs, ts = register(nominal[rs], campaign.xyz[rs])
                setup.stations[int(s)] = (Rs, ts, np.zeros(6))
        for p in np.unique(campaign.pivot[campaign.ballbar_rows]):
            rows = campaign.ballbar_rows[campaign.pivot[campaign.ballbar_rows] == p]
            setup.pivots[int(p)] = sphere_centre(nominal[rows])
        prob = _MixedProblem(model, campaign, noise, setup, features)
    else:
        R, t = register(nominal, campaign.xyz)
        setup = Setup(R, t)
        prob = _Problem(model, campaign, noise, setup, features)
    P = len(prob.sigma)
    theta = np.zeros(P)
    w, J, _ = prob.evaluate(theta)
    keep = np.ones(P, bool)
    ratio = np.ones(P)
    if remove_redundant:
        red, ratio = _structural_redundancy(model, campaign, noise, P) if underdetermined else find_redundant(J)
        keep = ~red
    names = list(E0_NAMES) + model.parameter_names + list(getattr(prob, "extra_names", []))
    n_active = int(np.sum(np.linalg.norm(J, axis=0) > INSENSITIVE * np.linalg.norm(J, axis=0).max()))
    if not underdetermined and (n_active >= w.size or keep.sum() >= w.size):  # more unknowns than equations
        raise VecpinError(f"{campaign.source}: {len(campaign)} rows give {w.size} equations for {n_active} parameters "
                          f"of a {model.kind} model of order {model.order}; measure more points or lower the order")
    psi = np.zeros(P)
    chi2 = w @ w
    lam = 1e-6
    converged = False
    it = 0
    for it in range(1, max_iter + 1):
        Ja = J[:, keep]
        Nm = Ja.T @ Ja + np.eye(keep.sum())
        g = Ja.T @ w + psi[keep]
        while True:
            try:
                step = -linalg.solve(Nm + lam * np.diag(np.diag(Nm)), g, assume_a="pos", check_finite=False)
            except linalg.LinAlgError:
                lam *= 10
                continue
            trial = psi.copy()
            trial[keep] += step
            w_new, J_new, _ = prob.evaluate(trial * prob.sigma)
            chi2_new = w_new @ w_new + trial @ trial
            if chi2_new <= chi2 + psi @ psi or lam > 1e6:
                break
            lam *= 10
        decrease = (chi2 + psi @ psi) - chi2_new
        psi, w, J = trial, w_new, J_new
        chi2 = w @ w
        lam = max(lam / 10, 1e-9)
        if progress:
            progress(f"iteration {it}: chi2 {chi2 + psi @ psi:.6g}, step {np.abs(step).max():.3g}")
        if abs(decrease) <= tol * max(chi2_new, 1.0) or np.abs(step).max() < 1e-10:
            converged = True
            break
    theta = psi * prob.sigma
    setup.e0 = theta[:6].copy()
    if mixed:
        for s_, sl in prob.sl_station.items():
            R_, t_, _ = setup.stations[s_]
            setup.stations[s_] = (R_, t_, theta[sl].copy())
        for p_, sl in prob.sl_pivot.items():
            setup.pivots[p_] = setup.pivots[p_] + theta[sl]
    Ja = J[:, keep]
    JtJ = Ja.T @ Ja
    Nm = JtJ + np.eye(keep.sum())
    Ninv = linalg.inv(Nm)
    cov = np.zeros((P, P))
    sk = prob.sigma[keep]
    cov[np.ix_(keep, keep)] = Ninv * np.outer(sk, sk)
    p_eff = float(np.trace(Ninv @ JtJ))
    dof = max(w.size - p_eff, 1.0)
    sv = linalg.svdvals(Ja)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
    weak = [names[k] for k in np.flatnonzero(keep & (ratio < WEAK_RATIO))]
    warnings = []
    if weak:
        warnings.append(f"{len(weak)} terms are barely identifiable with this design (held by their priors): "
                        + ", ".join(weak[:12]) + (" ..." if len(weak) > 12 else ""))
    if not converged:
        warnings.append(f"did not converge in {max_iter} iterations")
    if mixed:
        y = prob.evaluate(theta)[2]
        trk = campaign.tracker_rows
        stats_ = residual_stats(campaign.xyz[trk] - y[trk], campaign.tool[trk])
    else:
        y = predict_tracker(model, campaign.q, campaign.tool, theta[:6 + model.n_parameters], setup, features,
                            jacobian=False)[0]
        stats_ = residual_stats(campaign.xyz - y, campaign.tool)
    report = FitReport(model.kind, model.order, noise.instrument, len(campaign), int(w.size), P,
                       [names[k] for k in np.flatnonzero(~keep)], weak, p_eff, float(chi2 + psi @ psi),
                       dof, float(np.sqrt(2 * dof)), cond, it, converged, time.perf_counter() - t0,
                       stats_, warnings, [float(L * 1e3) for L in campaign.tool_lengths()])
    return theta, setup, cov, report
