"""The one likelihood: every measured row of every instrument, for one model.

Each row i closes the loop ``h(x_i) = h(T_s E_s F(q_i + v_i, b) p_Tl) + ξ_i`` (Paper I
eq. 11-12; Section 3 eq. 49-59) with the machine's positioning noise
``v_i ~ N(0, Σ_v)`` and the instrument's noise ``ξ_i ~ N(0, Σ_ξ)``. Eliminating
``v_i`` and ``ξ_i`` at the current linearisation, exactly as the ILM's orthogonal
decomposition does (eq. 56-59), leaves per row the residual ``r_i`` with covariance
``C_i = (dr/dq) Σ_v (dr/dq)^T + Σ_ξ``; whitening by ``C_i^{-1/2}`` and scaling the
unknowns by their prior standard deviations (``ψ = θ / σ``, eq. 52) turns the
maximum-likelihood problem into ``min |w(ψ)|² + |ψ|²``.

The instruments (:mod:`vecpin.measurement.instruments`) supply each row's equations;
this module stacks them (three per row, padded) for the fit
(:mod:`vecpin.identification.fit`), the cross-validation of model choices
(:mod:`vecpin.identification.crossval`) and the diagnosis alike.

The unknowns are ``θ = [E_0 (6), b (model parameters), the instruments' own
(other stations' pose corrections, ball bar pivots)]``, SI.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy import linalg

from vecpin.errors import IdentifiabilityError
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.instruments import instrument_for
from vecpin.measurement.instruments.tracker import E0_NAMES, POSE_PRIOR
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.registration import register
from vecpin.measurement.setup import Setup, to_station

E0_PRIORS = np.full(6, POSE_PRIOR)
CHUNK_ROWS = 20000  # rows per piece when normal equations are accumulated


class ParametricModel(Protocol):
    """What the likelihood needs of a model (see :class:`vecpin.models.ErrorModel`)."""

    machine: object
    effects: list
    n_parameters: int
    parameter_names: list[str]

    @property
    def priors(self) -> np.ndarray: ...

    def tool_tip(self, q, tool, b, jacobian: bool = True, features=None): ...

    def tracker_terms(self, y, features, b): ...


@dataclass
class Block:
    """Rows of one instrument that share unknowns (one station, one pivot)."""

    instrument: object
    rows: np.ndarray
    unknowns: slice  # its own unknowns in theta


@dataclass
class Evaluation:
    """The stacked problem at one theta (per campaign row, three equations padded).

    w (N,3) whitened residual; J (N,3,P) dw/dψ; valid (N,3) real equations;
    metric (N,3) residual [m] (point difference, or range / radius in column 0),
    A (N,3,P) d metric / d ψ; with ``operators``: Gw (N,3,3) dw / d point (machine
    frame), Gy (N,3,3) dw / d point (instrument frame), Gm, Gmy likewise for the metric;
    y (N,3) predicted points in the instrument frame (NaN for rows without one)."""

    w: np.ndarray
    J: np.ndarray | None
    valid: np.ndarray
    metric: np.ndarray
    A: np.ndarray | None
    y: np.ndarray
    Gw: np.ndarray | None = None
    Gy: np.ndarray | None = None
    Gm: np.ndarray | None = None
    Gmy: np.ndarray | None = None

    @property
    def n_equations(self) -> int:
        return int(self.valid.sum())

    def flat(self):
        """(w (3N,), J (3N,P)) for least squares (padded equations are zero)."""
        return self.w.ravel(), None if self.J is None else self.J.reshape(self.w.size, -1)


class Likelihood:
    """The whitened, prior-scaled least-squares problem of ``model`` on ``campaign``.

    ``setup``: the tracker poses and pivots; registered from the nominal kinematics when
    None (station 0's rows anchor the frame). ``instrument``: how tracker rows are read
    ("cartesian", "spherical", "range"; default ``noise.instrument``)."""

    def __init__(self, model: ParametricModel, campaign: Campaign, noise: NoiseModel, setup: Setup | None = None,
                 features=None, instrument: str | None = None):
        self.model, self.campaign, self.noise, self.features = model, campaign, noise, features
        tracker = instrument or noise.instrument
        nominal = model.machine.tool_tip(campaign.q, campaign.tool)
        if setup is None:
            setup = self._register(campaign, nominal)
        self.setup = setup
        nb = 6 + model.n_parameters
        extras, sigma = [], [E0_PRIORS, np.asarray(model.priors, float)]
        self.blocks: list[Block] = []
        kinds = {"tracker": tracker, "ballbar": "ballbar"}
        for kind in np.unique(campaign.instrument):
            inst = instrument_for(kinds.get(kind, kind), noise)
            rows = np.flatnonzero(campaign.instrument == kind)
            for _, g in sorted(inst.groups(campaign, rows).items()):
                own = inst.unknowns(campaign, g, nominal[g], setup)
                if own and own[0].startswith("E0."):
                    sl = slice(0, 6)
                else:
                    start = nb + sum(len(s) for s in sigma[2:])
                    sl = slice(start, start + len(own))
                    extras += own
                    sigma.append(inst.priors(own))
                self.blocks.append(Block(inst, g, sl))
        self.extra_names = extras
        self.names = list(E0_NAMES) + list(model.parameter_names) + extras
        self.sigma = np.concatenate(sigma)
        self.n_model = model.n_parameters
        self._tracker_effects = bool(getattr(model, "effects", None)) and any(
            "tracker" in e.kinds for e in model.effects)

    @staticmethod
    def _register(campaign: Campaign, nominal: np.ndarray) -> Setup:
        trk = campaign.tracker_rows
        r0 = trk[campaign.station[trk] == 0]
        if r0.size < 3:
            raise IdentifiabilityError(f"{campaign.source}: tracker station 0 needs at least 3 rows; it anchors the "
                                       "machine frame")
        return Setup(*register(nominal[r0], campaign.xyz[r0]))

    @property
    def n_unknowns(self) -> int:
        return self.sigma.size

    def theta_of(self, model) -> np.ndarray:
        """The unknowns of a fitted model (its E_0, parameters and station corrections;
        pivot corrections are folded into the setup, so zero)."""
        theta = np.zeros(self.n_unknowns)
        theta[:6] = model.e0_
        theta[6:6 + self.n_model] = model.b_
        for blk in self.blocks:
            if blk.unknowns.start >= 6 + self.n_model and blk.instrument.row_kind == "tracker":
                s = int(self.campaign.station[blk.rows[0]])
                theta[blk.unknowns] = self.setup.stations[s][2]
        return theta

    def evaluate(self, theta: np.ndarray, jacobian: bool = True, operators: bool = False) -> Evaluation:
        """The stacked problem at ``theta`` (SI), every row at once."""
        N, P = len(self.campaign), self.n_unknowns
        w, metric = np.zeros((N, 3)), np.zeros((N, 3))
        valid = np.zeros((N, 3), bool)
        y_all = np.full((N, 3), np.nan)
        J = np.zeros((N, 3, P)) if jacobian else None
        A = np.zeros((N, 3, P)) if jacobian else None
        ops = {k: np.zeros((N, 3, 3)) for k in ("Gw", "Gy", "Gm", "Gmy")} if operators else None
        for rows, pc in self._pieces(theta, jacobian, operators):
            w[rows], metric[rows], valid[rows] = pc["w"], pc["metric"], pc["valid"]
            if pc["y"] is not None:
                y_all[rows] = pc["y"]
            if jacobian:
                J[rows], A[rows] = pc["J"], pc["A"]
            if operators:
                for k in ops:
                    ops[k][rows] = pc[k]
        return Evaluation(w, J, valid, metric, A, y_all, **(ops or {}))

    def normal_equations(self, theta: np.ndarray, jacobian: bool = True, chunk: int = CHUNK_ROWS):
        """(chi2 = |w|^2, G = J^T J, g = J^T w, equations) at ``theta``, accumulated over
        blocks of at most ``chunk`` rows: memory does not grow with rows x unknowns.
        Without ``jacobian`` G and g are None (a trial point's chi2 only)."""
        P = self.n_unknowns
        chi2, n_eq = 0.0, 0
        G = np.zeros((P, P)) if jacobian else None
        g = np.zeros(P) if jacobian else None
        for rows, pc in self._pieces(theta, jacobian, False, chunk):
            wf = pc["w"].ravel()
            chi2 += float(wf @ wf)
            n_eq += int(pc["valid"].sum())
            if jacobian:
                Jf = pc["J"].reshape(wf.size, P)
                G += Jf.T @ Jf
                g += Jf.T @ wf
        return chi2, G, g, n_eq

    def predicted_points(self, theta: np.ndarray, chunk: int = CHUNK_ROWS) -> np.ndarray:
        """(N,3) predicted instrument-frame points [m] (NaN on rows without one)."""
        y = np.full((len(self.campaign), 3), np.nan)
        for rows, pc in self._pieces(theta, False, False, chunk):
            if pc["y"] is not None:
                y[rows] = pc["y"]
        return y

    def r_factor(self, theta: np.ndarray, chunk: int = CHUNK_ROWS) -> np.ndarray:
        """R of the QR decomposition of the whitened Jacobian J (rows stacked), accumulated
        piece by piece (R^T R = J^T J with the numerics of QR, for the redundancy test)."""
        R = np.zeros((0, self.n_unknowns))
        for rows, pc in self._pieces(theta, True, False, chunk):
            stacked = np.vstack([R, pc["J"].reshape(-1, self.n_unknowns)])
            R = linalg.qr(stacked, mode="r", check_finite=False)[0][:self.n_unknowns]
        return R

    def _pieces(self, theta: np.ndarray, jacobian: bool, operators: bool, chunk: int | None = None):
        """(rows, arrays of those rows) for every block of rows sharing an instrument's
        unknowns, in pieces of at most ``chunk`` rows."""
        c, m = self.campaign, self.model
        P = self.n_unknowns
        b = theta[6:6 + self.n_model]
        bsl = slice(6, 6 + self.n_model)
        sig2 = self.noise.axis_sigma**2
        for blk in self.blocks:
            parts = [blk.rows] if not chunk else np.array_split(blk.rows, max(1, -(-len(blk.rows) // chunk)))
            for rows in parts:
                feats = self.features.subset(rows) if self.features is not None else None
                # d tip / d q is needed for the positioning noise even when no Jacobian is asked
                mt = m.tool_tip(c.q[rows], c.tool[rows], b, jacobian=True, features=feats)
                stash = {}
                terms = None
                if self._tracker_effects and blk.instrument.row_kind == "tracker":
                    def terms(y, _rows, feats=feats, stash=stash):
                        shift, D, grad = m.tracker_terms(y, feats, b)
                        stash["D"] = D
                        return shift, grad
                eq = blk.instrument.equations(c, rows, mt.tip, self.setup, theta[blk.unknowns], terms)
                Aq = eq.dr_dp @ mt.J_q
                L = np.linalg.cholesky(np.einsum("pij,j,pkj->pik", Aq, sig2, Aq) + eq.S)
                pc = {"w": np.linalg.solve(L, eq.r[..., None])[..., 0], "metric": eq.metric,
                      "valid": np.broadcast_to(eq.valid, (len(rows), 3)), "y": eq.y}
                if jacobian:
                    D = np.zeros((len(rows), 3, P))
                    D[:, :, bsl] = eq.dr_dp @ mt.J_b
                    D[:, :, blk.unknowns] += eq.dr_du
                    Dm = np.zeros_like(D)
                    Dm[:, :, bsl] = eq.dmetric_dp @ mt.J_b
                    Dm[:, :, blk.unknowns] += eq.dmetric_du
                    if "D" in stash:  # tracker-frame effect columns
                        D[:, :, bsl] += eq.dr_dy @ stash["D"]
                        Dm[:, :, bsl] += -stash["D"] if eq.valid.all() else eq.dr_dy @ stash["D"]
                    pc["J"] = np.linalg.solve(L, D) * self.sigma
                    pc["A"] = Dm * self.sigma
                if operators:
                    pc["Gw"] = np.linalg.solve(L, eq.dr_dp)
                    pc["Gm"] = eq.dmetric_dp
                    pc["Gy"] = np.linalg.solve(L, eq.dr_dy) if eq.dr_dy is not None else np.zeros((len(rows), 3, 3))
                    pc["Gmy"] = ((-np.eye(3) if eq.valid.all() else eq.dr_dy) if eq.dr_dy is not None
                                 else np.zeros((len(rows), 3, 3)))
                yield rows, pc


def predict_tracker(model: ParametricModel, q: np.ndarray, tool: np.ndarray, theta: np.ndarray, setup: Setup,
                    features=None, jacobian: bool = True):
    """Modelled station-0 tracker readings y (N,3) [m]; with ``jacobian`` also
    d y / d theta (N,3,P+6) and d y / d q (N,3,n). theta = [E_0, b]."""
    e0, b = theta[:6], theta[6:]
    mt = model.tool_tip(q, tool, b, jacobian=jacobian, features=features)
    y, RR, de = to_station(mt.tip, setup.R, setup.t, e0, jacobian)
    if not jacobian:
        if getattr(model, "effects", None) and any("tracker" in e.kinds for e in model.effects):
            y = y + model.tracker_terms(y, features, b)[0]
        return y, None, None
    dy = np.concatenate([de, np.einsum("ij,pjk->pik", RR, mt.J_b)], axis=-1)
    dq = np.einsum("ij,pjk->pik", RR, mt.J_q)
    if getattr(model, "effects", None) and any("tracker" in e.kinds for e in model.effects):
        shift, D, grad = model.tracker_terms(y, features, b)
        y = y + shift
        M = np.eye(3) + grad
        dy, dq = M @ dy, M @ dq
        dy[:, :, 6:] += D
    return y, dy, dq
