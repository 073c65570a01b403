"""What a design tells about a model: whitened parameter Jacobians, the linearised
covariance of the identified parameters, and the predicted validation error.

The quantities are those of the fit (:mod:`vecpin.identification.fit`) at the nominal
machine (``b = 0``, ``E_0 = 0``): for a command ``q`` and tool length ``L`` the
tracker reading ``y = exp(e) F(q, b) + d`` (tracker frame aligned with the machine
frame; a rotation does not change the information) has the Jacobian ``[I, -[p]x, J_b]``
with respect to ``theta = [d, e, b]``; the row covariance is
``C = J_q Σ_v J_q^T + Σ_ξ`` with the machine's positioning noise ``Σ_v`` and the
tracker's noise ``Σ_ξ`` (Cartesian, or the spherical model mapped to Cartesian from
the tracker position). In the prior-scaled variables ``psi = theta / sigma`` the
normal matrix is ``N = W^T W + I`` (W: whitened, scaled rows) and the covariance of
theta is ``diag(sigma) N^-1 diag(sigma)``, exactly as the fit reports it.

Terms that no design can identify (redundant on a rich quasi-random reference
design, :func:`vecpin.identification.fit.find_redundant`) are left out: their prior
alone holds them, whatever is measured.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg

from vecpin.errors import InputError
from vecpin.identification.likelihood import E0_PRIORS, Likelihood
from vecpin.identification.redundancy import find_redundant
from vecpin.kinematics.machine import Machine
from vecpin.kinematics.so3 import skew
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.instruments.points import POINT_PRIOR
from vecpin.measurement.instruments.tracker import E0_NAMES, POSE_PRIOR
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.setup import POSE_NAMES, Setup
from vecpin.measurement.tracker import cartesian_to_spherical, spherical_jacobian
from vecpin.models import ErrorModel
from vecpin.planning.doptimal import CandidateRows
from vecpin.models.recorded import scrambled_halton   # scipy's qmc.Halton, without scipy.stats


def instrument_covariance(noise: NoiseModel, tips: np.ndarray, tracker: np.ndarray) -> np.ndarray:
    """(N,3,3) Cartesian covariance Σ_ξ [m^2] of tracker readings of machine-frame points
    ``tips`` (N,3) [m], tracker head at ``tracker`` (3,) [m], tracker z along machine z."""
    N = len(tips)
    if noise.instrument == "cartesian":
        return np.broadcast_to(np.eye(3) * noise.cartesian_sigma ** 2, (N, 3, 3)).copy()
    p = tips - tracker
    sig = noise.tracker.sigma_spherical(cartesian_to_spherical(p)[:, 0])
    Hinv = np.linalg.inv(spherical_jacobian(p))  # d (x,y,z) / d (R, phi, theta)
    return np.einsum("nij,nj,nkj->nik", Hinv, sig ** 2, Hinv)


class Information:
    """The linearised identification problem of ``model`` with ``noise`` and a tracker
    at ``tracker`` (3,) [m] for commands measured with every tool in ``tools`` [m] and,
    on a machine with table axes, reflectors in table ``nests`` {id: (3,) [m],
    workpiece frame} read at the commands.

    The unknowns are the fit's: theta = [E_0 (6), b (the model's parameters), the nest
    positions (3 per nest, ``nest<id>.x|y|z``: unknown to the fit, found with the
    model), the pose corrections of the further tracker stations (6 per station,
    ``station<k>.dx|..|ez``, prior :data:`POSE_PRIOR`: a second set-up the fit must find)];
    ``sigma`` (P,) their prior standard deviations (SI), ``names`` (P,).
    ``stations``: where the further stations stand ((3,) [m] each, machine base frame;
    station k of a row is ``stations[k - 1]``), tracker frames parallel to the machine's."""

    def __init__(self, model: ErrorModel, noise: NoiseModel, tracker: np.ndarray, tools, keep: np.ndarray | None = None,
                 nests: dict[str, np.ndarray] | None = None, stations: list | None = None):
        self.model, self.noise = model, noise
        self.machine: Machine = model.machine
        self.tracker = np.asarray(tracker, float).reshape(3)
        self.tools = np.atleast_1d(np.asarray(tools, float))
        self.nests = {str(k): np.asarray(v, float).reshape(3) for k, v in (nests or {}).items()}
        self.nest_ids = list(self.nests)
        self.stations = [np.asarray(x, float).reshape(3) for x in (stations or [])]
        self.n_model = model.n_parameters
        nest_names = [f"nest{k}.{c}" for k in self.nest_ids for c in "xyz"]
        station_names = [f"station{k}.{c}" for k in range(1, len(self.stations) + 1) for c in POSE_NAMES]
        self.sigma = np.r_[E0_PRIORS, model.priors, np.full(len(nest_names), POINT_PRIOR),
                           np.full(len(station_names), POSE_PRIOR)]
        self.names = list(E0_NAMES) + model.parameter_names + nest_names + station_names
        self._column = {n: k for k, n in enumerate(self.names)}
        self.keep = self.structural_keep() if keep is None else np.asarray(keep, bool)

    def with_stations(self, stations: list) -> "Information":
        """The same problem with further tracker stations at ``stations`` ((3,) [m] each,
        machine base frame): their rows and pose unknowns counted, the other terms kept
        as here."""
        return Information(self.model, self.noise, self.tracker, self.tools,
                           np.r_[self.keep[:self.station_start], np.ones(6 * len(stations), bool)],
                           self.nests, stations)

    @property
    def station_start(self) -> int:
        """Index of the first further station's pose unknown (after E_0, the model and the nests)."""
        return 6 + self.n_model + 3 * len(self.nest_ids)

    @property
    def P(self) -> int:
        return len(self.sigma)

    @property
    def model_columns(self) -> slice:
        """Where the model's parameters b sit in theta."""
        return slice(6, 6 + self.n_model)

    # ------------------------------------------------------------------ rows
    def rows(self, q: np.ndarray, tools=None, nest_visible: np.ndarray | None = None) -> np.ndarray:
        """(C, 3 (T + K), P) whitened, prior-scaled Jacobian rows of commands q (C,n)
        [m, rad]: each measured with every tool (T tools), then every nest read (K
        nests); a nest reading the tracker cannot see (``nest_visible`` (C,K) False) has
        zero rows (it tells nothing)."""
        q = np.atleast_2d(np.asarray(q, float))
        tools = self.tools if tools is None else np.atleast_1d(np.asarray(tools, float))
        C, T, K = len(q), len(tools), len(self.nest_ids)
        tool_rows = self.row_blocks(np.repeat(q, T, axis=0), np.tile(tools, C)).reshape(C, 3 * T, self.P)
        if not K:
            return tool_rows
        ids = np.tile(np.array(self.nest_ids, dtype=object), C)
        nest_rows = self.nest_blocks(np.repeat(q, K, axis=0), ids).reshape(C, K, 3, self.P)
        if nest_visible is not None:
            nest_rows = nest_rows * np.asarray(nest_visible, bool)[:, :, None, None]
        return np.concatenate([tool_rows, nest_rows.reshape(C, 3 * K, self.P)], axis=1)

    def row_blocks(self, q: np.ndarray, tool: np.ndarray) -> np.ndarray:
        """(N, 3, P) whitened, prior-scaled rows of tool-tip readings (q, tool)."""
        q = np.atleast_2d(np.asarray(q, float))
        tool = np.broadcast_to(np.asarray(tool, float), (len(q),))
        return self.measurement_rows(q, tool, np.full(len(q), "tracker", dtype=object), np.full(len(q), "", dtype=object))

    def nest_blocks(self, q: np.ndarray, nest: np.ndarray) -> np.ndarray:
        """(N, 3, P) whitened, prior-scaled rows of readings of the nests ``nest`` (N,) ids."""
        q = np.atleast_2d(np.asarray(q, float))
        return self.measurement_rows(q, np.full(len(q), float(self.tools[0])), np.full(len(q), "nest", dtype=object),
                                     np.asarray(nest, dtype=object))

    def measurement_rows(self, q: np.ndarray, tool: np.ndarray, instrument: np.ndarray, target: np.ndarray,
                         station: np.ndarray | None = None) -> np.ndarray:
        """(N, 3, P) whitened, prior-scaled rows of the readings (q, tool, instrument
        "tracker" or "nest", target: the nest id on nest rows, station: the tracker station
        that reads the row, 0 when None): the fit's own likelihood
        (:mod:`vecpin.identification.likelihood`) at the nominal machine, each station's
        frame parallel to the machine's at its position (``tracker`` for station 0), nests
        at their planned positions."""
        m = self.model
        q = np.atleast_2d(np.asarray(q, float))
        N = len(q)
        if N == 0:
            return np.zeros((0, 3, self.P))
        instrument = np.asarray(instrument, dtype=object)
        target = np.asarray(target, dtype=object)
        station = np.zeros(N, int) if station is None else np.asarray(station, int)
        if station.max(initial=0) > len(self.stations):
            raise InputError(f"station {station.max()}: the plan has {len(self.stations)} further tracker stations")
        nest = instrument == "nest"
        unknown = sorted(set(target[nest]) - set(self.nest_ids))
        if unknown:
            raise InputError(f"nest '{unknown[0]}' is not one of the plan's nests ({', '.join(self.nest_ids) or 'none'})")
        xyz = np.empty((N, 3))
        if (~nest).any():
            xyz[~nest] = m.machine.tool_tip(q[~nest], tool[~nest], frame="base")
        if nest.any():
            p_wp = np.array([self.nests[k] for k in target[nest]])
            xyz[nest] = m.machine.workpiece_points(q[nest], p_wp, jacobian=False).xyz
        where = np.array([self.tracker] + self.stations)[station]
        camp = Campaign(m.machine.axis_names, q, np.asarray(tool, float), xyz - where, {}, "plan",
                        instrument.copy(), station.copy(), target=target.copy())
        setup = Setup(np.eye(3), -self.tracker, nests=dict(self.nests),
                      stations={k: (np.eye(3), -x, np.zeros(6)) for k, x in enumerate(self.stations, 1)})
        lik = Likelihood(m, camp, self.noise, setup)
        J = -lik.evaluate(np.zeros(lik.n_unknowns)).J  # d (whitened prediction) / d psi
        out = np.zeros((N, 3, self.P))
        cols = np.array([self._column[n] for n in lik.names])
        out[:, :, cols] = J
        return out

    def kept_rows(self, q: np.ndarray, nest_visible: np.ndarray | None = None, chunk: int = 2000) -> CandidateRows:
        """:meth:`rows` over the counted terms only, float32, computed in chunks and stored
        by groups of rows over their nonzero columns (:class:`CandidateRows`): the
        D-optimal choice's candidates (20,868 of a trunnion's order-6 6-DoF model with three
        nests, 15 rows x 186 terms each, in 0.13 GB)."""
        k = np.flatnonzero(self.keep)

        def chunks():
            for a in range(0, len(q), chunk):
                vis = None if nest_visible is None else nest_visible[a:a + chunk]
                yield self.rows(q[a:a + chunk], nest_visible=vis)[:, :, k].astype(np.float32)
        return CandidateRows(chunks(), len(q))

    def compact_rows(self, q: np.ndarray, tool: np.ndarray, instrument: np.ndarray, target: np.ndarray,
                     station: np.ndarray | None = None, chunk: int = 3000) -> np.ndarray:
        """(P, P) rows with the same ``W^T W`` as :meth:`measurement_rows` of the readings
        (everything the covariance, the posterior and log det N depend on), summed in
        chunks: a plan of 10,000 commands with table nests scores in little memory."""
        G = np.zeros((self.P, self.P))
        station = np.zeros(len(q), int) if station is None else np.asarray(station, int)
        for a in range(0, len(q), chunk):
            W = self.measurement_rows(q[a:a + chunk], tool[a:a + chunk], instrument[a:a + chunk],
                                      target[a:a + chunk], station[a:a + chunk]).reshape(-1, self.P)
            G += W.T @ W
        w, V = np.linalg.eigh(G)
        return np.sqrt(np.clip(w, 0.0, None))[:, None] * V.T

    def structural_keep(self, n_reference: int = 1000) -> np.ndarray:
        """Terms identifiable by some design: not redundant on a rich quasi-random design
        of ``n_reference`` commands with every tool and every nest read (as the
        underdetermined fit judges), in the likelihood's priority order (E_0, the nest
        positions, then the model: a constant table error that a nest's position explains
        is left out, not the nest's position). The reference design is read from the first
        station; a further station's pose is counted (its planned rows read points station
        0 reads: the fit determines it, :meth:`Likelihood.priority`)."""
        m = self.machine
        u = scrambled_halton(m.n_axes, n_reference, seed=0)
        q = m.lower + u * (m.upper - m.lower)
        W = self.rows(q).reshape(-1, self.P)
        order = self.priority()
        red_p, _ = find_redundant(W[:, order])
        red = np.empty_like(red_p)
        red[order] = red_p
        red[self.station_start:] = False
        return ~red

    def priority(self) -> np.ndarray:
        """Column order of the redundancy test: E_0, the nest positions, the further
        stations' poses, the model (the fit's order, :meth:`Likelihood.priority`)."""
        extra = np.arange(6 + self.n_model, self.P)
        return np.r_[np.arange(6), extra, np.arange(6, 6 + self.n_model)].astype(int)

    def table_terms(self) -> np.ndarray:
        """(P,) the model terms only a reading of the table sees: those a dense design of
        tool-tip readings alone cannot identify but one with the nests can (on a machine
        without table axes: none)."""
        if not self.nest_ids:
            return np.zeros(self.P, bool)
        tools_only = Information(self.model, self.noise, self.tracker, self.tools)
        out = np.zeros(self.P, bool)
        out[self.model_columns] = ~tools_only.keep[tools_only.model_columns] & self.keep[self.model_columns]
        return out

    # ------------------------------------------------------------------ covariance
    def normal(self, W: np.ndarray) -> np.ndarray:
        """N = W^T W + I over the kept terms, W (..., P) stacked rows."""
        Wk = W.reshape(-1, self.P)[:, self.keep]
        return Wk.T @ Wk + np.eye(int(self.keep.sum()))

    def covariance(self, W: np.ndarray) -> np.ndarray:
        """(P,P) covariance of theta [SI^2] after measuring the rows W, as the fit reports
        it: over the counted terms (zeros for the terms no design identifies)."""
        Ninv = linalg.inv(self.normal(W))
        cov = np.zeros((self.P, self.P))
        s = self.sigma[self.keep]
        cov[np.ix_(self.keep, self.keep)] = Ninv * np.outer(s, s)
        return cov

    def posterior(self, W: np.ndarray) -> np.ndarray:
        """(P,P) covariance of theta [SI^2] over every term, prior included: a term the
        rows do not see keeps its prior. This is what a prediction must use: a term the
        fit leaves at zero because no tool-tip reading sees it (a table error, without
        nests) still moves the tool relative to the workpiece by its prior's size."""
        Wf = W.reshape(-1, self.P)
        Ninv = linalg.inv(Wf.T @ Wf + np.eye(self.P))
        return Ninv * np.outer(self.sigma, self.sigma)

    def log_det(self, W: np.ndarray) -> float:
        """log det N: the D-criterion (larger: better determined)."""
        return float(np.linalg.slogdet(self.normal(W))[1])

    # ------------------------------------------------------------------ prediction
    def predicted_errors(self, cov: np.ndarray, q: np.ndarray, tool: float, n_draws: int = 200,
                         seed: int = 0) -> "PredictedError":
        """Model error at commands q (N,n) with ``tool`` [m] that the parameter
        uncertainty ``cov`` (the covariance of theta, :meth:`posterior`) leaves: the tool
        tip relative to the workpiece (the base frame on a machine without one: what
        compensation corrects), and the validation residual one would measure there
        (adding the measurement noise of each point).

        Draws ``n_draws`` parameter errors from N(0, cov_bb) (eigen-decomposition), maps
        them through J_b to tool-tip errors and reports the mean over draws of the mean
        and the max over points [m]. Model-form error (what the model cannot describe)
        is not in it."""
        m = self.model
        q = np.atleast_2d(np.asarray(q, float))
        tl = np.full(len(q), float(tool))
        zero = np.zeros(m.n_parameters)
        out = m.tool_tip(q, tl, zero, jacobian=True, frame=self.machine.default_frame)
        base = m.tool_tip(q, tl, zero, jacobian=True, frame="base") if self.machine.has_workpiece else out
        Jb = out.J_b
        cb = cov[self.model_columns, self.model_columns]
        rng = np.random.default_rng(seed)
        w, V = np.linalg.eigh(cb)
        Lc = V * np.sqrt(np.clip(w, 0, None))
        db = rng.standard_normal((n_draws, m.n_parameters)) @ Lc.T
        # a rigid motion of all tips is the tracker's pose (or, relative to the workpiece, the
        # part's set-up), not a machine error: remove the best-fit one (small angles: t + w x p),
        # as the seed's volumetric errors are registered
        Rg = np.concatenate([np.broadcast_to(np.eye(3), (len(q), 3, 3)), -skew(out.tip - out.tip.mean(axis=0))], axis=2)
        Qr = np.linalg.qr(Rg.reshape(-1, 6))[0]                          # (3N, 6)
        Jf = Jb.reshape(-1, Jb.shape[2])
        Jb = (Jf - Qr @ (Qr.T @ Jf)).reshape(Jb.shape)
        e = np.einsum("nik,dk->dni", Jb, db)  # (draws, N, 3)
        d = np.linalg.norm(e, axis=2)
        A = base.J_q
        C = np.einsum("nij,j,nkj->nik", A, self.noise.axis_sigma ** 2, A) + \
            instrument_covariance(self.noise, base.tip, self.tracker)
        Ln = np.linalg.cholesky(C)
        noise = np.einsum("nij,dnj->dni", Ln, rng.standard_normal(e.shape))
        dm = np.linalg.norm(e + noise, axis=2)
        sd = np.sqrt(np.einsum("nik,kl,njl->nij", Jb, cb, Jb).trace(axis1=1, axis2=2))
        return PredictedError(float(d.mean()), float(d.max(axis=1).mean()), float(dm.mean()),
                              float(dm.max(axis=1).mean()), float(sd.mean()), len(q), self.machine.default_frame)


@dataclass
class PredictedError:
    """Predicted error [m] at validation commands: ``model_mean``/``model_max`` of the
    identified model's tool tip (parameter uncertainty only), ``measured_mean``/
    ``measured_max`` of the residual a validation run would show (plus measurement
    noise), ``rms_1sigma`` the mean 1-sigma 3D error; ``points`` validation commands;
    ``frame``: "workpiece" (the tool tip relative to the workpiece) or "base"."""

    model_mean: float
    model_max: float
    measured_mean: float
    measured_max: float
    rms_1sigma: float
    points: int
    frame: str = "base"


def validation_commands(machine: Machine, n: int, lower: np.ndarray, upper: np.ndarray, seed: int = 1) -> np.ndarray:
    """n quasi-random (scrambled Halton) commands in the box [lower, upper] [m, rad]."""
    u = scrambled_halton(machine.n_axes, n, seed=seed)
    return lower + u * (upper - lower)
