"""Maximum-likelihood identification of a model's parameters from a campaign.

The tracker frame is registered automatically (rigid fit of the nominal tips, station
0's rows) and the small correction ``E_0`` (eq. 10) is estimated with the model.
Redundant parameters are found from the prior-scaled sensitivity at the measured
poses (:mod:`.redundancy`) and removed (when an axis stood still in every row, only those no
design could identify: :func:`_columns_to_fit`); the likelihood (:mod:`.likelihood`) is
minimised by the bounded damped Gauss-Newton of :mod:`.solver`; the report
(:mod:`.report`) gives χ² against its expectation, conditioning and residuals.
"""
from __future__ import annotations

import time
from typing import Callable

import numpy as np
from scipy import linalg

from vecpin.errors import IdentifiabilityError, VecpinError
from vecpin.identification.likelihood import Likelihood, ParametricModel
from vecpin.identification.redundancy import WEAK_RATIO, active_columns
from vecpin.identification.report import FitReport, describe_counts, unknown_counts
from vecpin.identification.solver import gauss_newton
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.campaignchecks import stood_still
from vecpin.measurement.features import Features
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.registration import check_campaign_frames, check_registration
from vecpin.measurement.setup import Setup
from vecpin.measurement.stats import residual_stats
from vecpin.units import MM_PER_M


def structural_redundancy(model: ParametricModel, tools: np.ndarray, noise: NoiseModel, n: int = 1000):
    """Redundant terms judged on a rich quasi-random design (``n`` commands x ``tools``)
    instead of the measured poses: only what no design could identify. The design
    measures what a full campaign of this machine would: the tool tips of every tool
    point and, on a machine with a workpiece (table axes), :data:`REFERENCE_NESTS` points
    fixed on the table (nests, positions unknown as in a real campaign): without them
    the table axes would move nothing and all their terms would be removed.
    Returns (redundant mask, ratio) over [E_0, b]."""
    m = model.machine
    from scipy.stats import qmc   # imported here: scipy.stats takes 0.5 s to import and a fit uses it only when underdetermined
    u = qmc.Halton(m.n_axes, seed=0).random(n)
    q = m.lower + u * (m.upper - m.lower)
    tools = np.atleast_1d(np.asarray(tools, float))
    parts = []  # (q, tool, point, instrument, nest id, base-frame point) per block of rows
    for k in range(len(getattr(m, "tool_links", ())) or 1):
        qq, tt = np.repeat(q, len(tools), axis=0), np.tile(tools, len(q))
        parts.append((qq, tt, np.full(len(qq), k), "tracker", "", m.tool_tip(qq, tt, frame="base", point=k)))
    if getattr(m, "has_workpiece", False):
        for nid, p_wp in reference_nests(m).items():
            parts.append((q, np.full(len(q), tools[0]), np.zeros(len(q), int), "nest", nid,
                          m.workpiece_points(q, p_wp, jacobian=False).xyz))
    ref = Campaign(m.axis_names, np.vstack([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
                   np.vstack([p[5] for p in parts]), {}, "reference design",
                   np.concatenate([np.full(len(p[0]), p[3], dtype=object) for p in parts]),
                   point=np.concatenate([p[2] for p in parts]),
                   target=np.concatenate([np.full(len(p[0]), p[4], dtype=object) for p in parts]))
    cart = NoiseModel(noise.axis_sigma, "cartesian", noise.cartesian_sigma)
    lik = Likelihood(model, ref, cart, Setup(np.eye(3), np.zeros(3)), instrument="cartesian")
    theta = np.zeros(lik.n_unknowns)
    _, G, _, _ = lik.normal_equations(theta)
    red, ratio = lik.redundancy(theta, np.sqrt(np.diag(G)))  # nest positions before the table's constant terms
    k = 6 + lik.n_model
    return red[:k], ratio[:k]


#: an axis that stood still in every row: terms collinear only there are held by their priors, not removed by
#: their order (benchmarks/bench_still_joint.py sets it False for the figures before)
STILL_BY_PRIORS = True
STILL_REFERENCE = 300   # commands of the reference design that judges redundancy then (more with more unknowns)
REFERENCE_NESTS = 4  # table points of the reference design on a machine with a workpiece


def reference_nests(machine) -> dict[str, np.ndarray]:
    """{id: (3,) [m]} :data:`REFERENCE_NESTS` points fixed in the workpiece frame for the
    reference design: on a circle of 40 % of the table's reach (half the span of the tool
    tips relative to the workpiece, at most 0.3 m), at different heights (20-80 mm), so
    that no three lie on a line through a table axis."""
    from scipy.stats import qmc
    q = machine.lower + qmc.Halton(machine.n_axes, seed=1).random(256) * (machine.upper - machine.lower)
    rel = machine.tool_tip(q, 0.2, frame="workpiece")
    reach = max(min(0.3, 0.2 * float(np.ptp(rel[:, :2], axis=0).min())), 0.05)
    out = {}
    for k in range(REFERENCE_NESTS):
        a = 2 * np.pi * (k + 0.3 * (k % 2)) / REFERENCE_NESTS
        out[f"ref{k + 1}"] = np.array([reach * np.cos(a), reach * np.sin(a), 0.02 + 0.02 * k])
    return out


def _check_units_and_frame(lik: Likelihood, campaign: Campaign) -> None:
    """Refuse unit mistakes, mirrored frames and mistyped rows before fitting (the
    likelihood's starting points: nominal tool tips, targets and nests)."""
    trk = np.flatnonzero(campaign.instrument != "ballbar")
    nominal = lik.nominal[trk]
    for s in np.unique(campaign.station[trk]):
        sel = campaign.station[trk] == s
        check_registration(nominal[sel], campaign.xyz[trk][sel], campaign.source, campaign.lines[trk][sel])


def measured_range(machine, campaign: Campaign) -> dict:
    """{axis: [lowest, highest] command} [mm or deg] the campaign measured."""
    return {a.name: [float(a.to_user(campaign.q[:, a.index].min())), float(a.to_user(campaign.q[:, a.index].max()))]
            for a in machine.axes}


def fit(model: ParametricModel, campaign: Campaign, noise: NoiseModel | None = None, *, max_iter: int = 30,
        tol: float = 1e-9, remove_redundant: bool = True, underdetermined: bool = False,
        progress: Callable[[str], None] | None = None, points: dict | None = None):
    """Identify ``model``'s parameters from ``campaign``; returns (theta, setup, cov, report).
    ``points``: a dict that receives "y", the fitted instrument-frame points (N,3) [m] of
    every row (NaN where none), and "folded", True when the setup folds instrument unknowns
    other than station poses into positions (the points of the folded setup may then differ
    from these in the last digits).

    theta = [E_0 (6), b (P), the instruments' unknowns] SI; cov is the covariance of
    theta (zeros for removed terms). ``underdetermined``: accept fewer equations than
    parameters, the priors Σ_b deciding what the data cannot (Section 3.5.2 fits 50
    tracker points this way); when the campaign is short of equations, redundancy is then
    judged on a reference design, so only structurally redundant terms are removed. A
    campaign with enough equations is fitted the same with or without it."""
    t0 = time.perf_counter()
    if list(campaign.axis_names) != model.machine.axis_names:
        raise VecpinError(f"{campaign.source}: axes {campaign.axis_names} do not match machine "
                          f"'{model.machine.name}' ({', '.join(model.machine.axis_names)})")
    noise = noise or NoiseModel.default(model.machine)
    features = None
    if model.effects:
        features = Features.from_campaign(campaign)
        for e in model.effects:
            e.prepare(campaign, features)
    check_campaign_frames(model.machine, campaign)  # tool-tip rows, before the tracker pose is registered
    lik = Likelihood(model, campaign, noise, features=features)
    _check_units_and_frame(lik, campaign)
    P = lik.n_unknowns

    def normal_equations(psi, jacobian):
        return lik.normal_equations(psi * lik.sigma, jacobian)

    # the solver starts from these (psi = 0), the redundancy test takes R of the same pass
    chi2_0, G0, g0, n_eq, *R0 = lik.normal_equations(np.zeros(P), with_r=remove_redundant)
    keep, ratio = _columns_to_fit(model, campaign, noise, lik, G0, n_eq, remove_redundant, underdetermined,
                                  R0[0] if R0 else None)
    # trial steps evaluated with their Jacobians (the same steps and result, an accepted step one pass over
    # the rows instead of two: worth it at every campaign size)
    sol = gauss_newton(normal_equations, P, keep, max_iter=max_iter, tol=tol, progress=progress,
                       start=(chi2_0, G0, g0), eager=True)
    theta = sol.psi * lik.sigma
    JtJ = sol.G[np.ix_(keep, keep)]
    Ninv = linalg.inv(JtJ + np.eye(keep.sum()))
    cov = np.zeros((P, P))
    sk = lik.sigma[keep]
    cov[np.ix_(keep, keep)] = Ninv * np.outer(sk, sk)
    p_eff = float(np.trace(Ninv @ JtJ))
    dof = max(n_eq - p_eff, 1.0)
    ev = np.clip(linalg.eigvalsh(JtJ), 0.0, None)
    cond = float(np.sqrt(ev[-1] / ev[0])) if ev[0] > 0 else float("inf")
    names = lik.names
    weak = [names[k] for k in np.flatnonzero(keep & (ratio < WEAK_RATIO))]
    warnings = lik.station_warnings(keep, ratio, WEAK_RATIO)  # a station's pose: what to read from it
    terms = [n for n in weak if not n.startswith("station")]
    if terms:
        warnings.append(f"{len(terms)} terms are barely identifiable with this design (held by their priors): "
                        + ", ".join(terms[:12]) + (" ..." if len(terms) > 12 else ""))
    if not sol.converged:
        warnings.append(f"did not converge in {max_iter} iterations")
    trk = campaign.tracker_rows
    predicted = lik.predicted_points(theta)
    stats_ = residual_stats(campaign.xyz[trk] - predicted[trk], campaign.tool[trk])
    if points is not None:
        points.update(y=predicted, folded=any(not n.startswith("station") for n in lik.extra_names))
    setup = lik.fold(theta, cov)  # the instruments' unknowns into the setup
    instrument = noise.instrument
    report = FitReport(getattr(model, "kind", "model"), getattr(model, "order", -1), instrument, len(campaign), n_eq, P,
                       [names[k] for k in np.flatnonzero(~keep)], weak, p_eff, float(sol.objective),
                       dof, float(np.sqrt(2 * dof)), cond, sol.iterations, sol.converged, time.perf_counter() - t0,
                       stats_, warnings, [float(L * MM_PER_M) for L in campaign.tool_lengths()],
                       measured_range(model.machine, campaign), unknown_counts(names, lik.n_model),
                       model.label() if hasattr(model, "label") else "")
    return theta, setup, cov, report


def _columns_to_fit(model, campaign: Campaign, noise: NoiseModel, lik: Likelihood, G0: np.ndarray, n_eq: int,
                    remove_redundant: bool, underdetermined: bool, R0: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """(columns kept, each one's identifiability ratio): redundant terms removed (on the
    campaign, or on a reference design when ``underdetermined`` and short of equations or when
    an axis stood still in every row and the equations allow);
    refused when the kept columns outnumber the equations and not ``underdetermined``."""
    P = lik.n_unknowns
    norms = np.sqrt(np.diag(G0))
    keep = np.ones(P, bool)
    ratio = np.ones(P)
    active = active_columns(norms)
    n_active = int(active.sum())
    if remove_redundant:
        short = underdetermined and n_active >= n_eq
        rows_matter = any(not e.geometric for e in getattr(model, "effects", ()))   # the design has no rows' history
        if (short or (STILL_BY_PRIORS and stood_still(model.machine, campaign))) and not rows_matter:
            # short of equations (changed only by `underdetermined`), or an axis stood still: terms that only the
            # design cannot tell apart are held by their priors (the posterior mean, as the model choice's folds fit
            # them), not removed by their place in the order; only what no design could identify is removed
            n_ref = 1000 if short else min(1000, max(STILL_REFERENCE, P))   # rows enough for every term
            red, r_model = structural_redundancy(model, campaign.tool_lengths(), noise, n_ref)
            if short:
                extra = P - red.size
                red, ratio = np.r_[red, np.zeros(extra, bool)], np.r_[r_model, np.ones(extra)]
            else:   # the stations' and instruments' unknowns (after the model's) as the campaign tells them
                own, own_ratio = lik.redundancy(np.zeros(P), norms, R=R0)
                red, ratio = np.r_[red, own[red.size:]], np.r_[r_model, own_ratio[red.size:]]
                if (~red).sum() >= n_eq:   # too few equations for that: as a moving design
                    red, ratio = own, own_ratio
        else:
            red, ratio = lik.redundancy(np.zeros(P), norms, R=R0)
        keep = ~red
    if not underdetermined and (n_active >= n_eq or keep.sum() >= n_eq):
        counts = unknown_counts(lik.names, lik.n_model, active)
        raise IdentifiabilityError(
            f"{campaign.source}: {len(campaign)} rows give {n_eq} equations for {n_active} unknowns "
            f"({describe_counts(counts)}, of the {getattr(model, 'kind', '')} model): use fewer model terms "
            "(a lower `order` or a fixed `basis` chebyshev), measure more points, or fit with `underdetermined` to let "
            "the priors decide the rest")
    return keep, ratio
