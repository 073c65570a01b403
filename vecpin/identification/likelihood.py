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

Each instrument says which machine point its rows measure (a point on the tool: the
tip of one tool point, or a target off the tool axis; or a point fixed on the table: a
nest); the model predicts that point in the base frame, and the Jacobians chain:
``dr/dθ = dr/dp (dp/db, dp/d(target offset or nest position)) + dr/du``.

The unknowns are ``θ = [E_0 (6), b (model parameters), the instruments' own (other
stations' pose corrections, ball bar pivots, tool-target offsets, nest positions)]``,
SI. Unknowns are named; blocks of rows that name the same unknown (the nest rows and
the tool rows of one tracker station, one target seen from two stations) share it.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np
from scipy import linalg

from vecpin.identification.redundancy import redundant_from_r
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.instruments import instrument_for
from vecpin.measurement.instruments.points import PointRequest, initial_setup, nominal_points
from vecpin.measurement.instruments.tracker import E0_NAMES, POSE_PRIOR, STATION_ADVICE
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.setup import POSE_NAMES, Setup, station_reading
from vecpin.threads import _can_fork, side_by_side, workers_wanted

E0_PRIORS = np.full(6, POSE_PRIOR)
CHUNK_ROWS = 20000  # rows per piece when normal equations are accumulated
SHARED_ROWS = 100_000   # a larger campaign's normal equations: its pieces shared out between the cores (forked)


class ParametricModel(Protocol):
    """What the likelihood needs of a model (see :class:`vecpin.models.ErrorModel`)."""

    machine: object
    effects: list
    n_parameters: int
    parameter_names: list[str]

    @property
    def priors(self) -> np.ndarray: ...

    def tool_tip(self, q, tool, b, jacobian: bool = True, features=None, *, frame="base", point=0, offset=None): ...

    def workpiece_points(self, q, p_wp, b, jacobian: bool = True, features=None): ...

    def tracker_terms(self, y, features, b): ...


@dataclass
class Block:
    """Rows of one instrument that share unknowns (one station, one pivot).

    ``unknowns``: indices in theta of the block's unknowns, the instrument's own first
    (``first`` of them: what its equations differentiate), then those of the points its
    rows measure (target offsets, nest positions); ``request``: which points; ``by_pose``:
    the rows' places sorted by pose (set when the rows are taken in pieces)."""

    instrument: object
    rows: np.ndarray
    unknowns: np.ndarray
    first: int
    request: PointRequest
    by_pose: np.ndarray | None = None


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

    ``setup``: the tracker poses, pivots, nests and targets; placed from the nominal
    kinematics when None (station 0's rows anchor the frame), completed where it lacks
    a station, nest or target of this campaign. ``instrument``: how tracker (and nest)
    rows are read ("cartesian", "spherical", "range"; default ``noise.instrument``)."""

    def __init__(self, model: ParametricModel, campaign: Campaign, noise: NoiseModel, setup: Setup | None = None,
                 features=None, instrument: str | None = None):
        self.model, self.campaign, self.noise, self.features = model, campaign, noise, features
        tracker = instrument or noise.instrument
        machine = model.machine
        self.setup = setup = initial_setup(machine, campaign, None if setup is None else setup.copy())
        names = list(E0_NAMES) + list(model.parameter_names)
        index = {n: k for k, n in enumerate(names)}
        extra_sigma: list[float] = []
        self.blocks: list[Block] = []
        self.nominal = np.full((len(campaign), 3), np.nan)  # machine-frame points at the start (no model)
        kinds = {"tracker": tracker, "ballbar": "ballbar"}
        for kind in _kinds(campaign.instrument):
            inst = instrument_for(kinds.get(kind, kind), noise)
            if hasattr(inst, "read_with"):  # nest rows are read as the tracker rows are
                inst.read_with(instrument_for(tracker, noise))
            rows = np.flatnonzero(campaign.instrument == kind)
            for _, g in sorted(inst.groups(campaign, rows).items()):
                req, point_names = inst.request(campaign, g, setup)
                nominal = nominal_points(machine, campaign.q[g], req)
                self.nominal[g] = nominal
                own = inst.unknowns(campaign, g, nominal, setup)
                if req.unknown is not None:
                    req.unknown = np.where(req.unknown >= 0, req.unknown + len(own), -1)
                block_names = own + point_names
                priors = inst.priors(block_names) if block_names else np.zeros(0)
                idx = []
                for name, prior in zip(block_names, priors):
                    if name not in index:
                        index[name] = len(names)
                        names.append(name)
                        extra_sigma.append(float(prior))
                    idx.append(index[name])
                self.blocks.append(Block(inst, g, np.array(idx, int), len(own), req))
        self.n_model = model.n_parameters
        self.index = index
        self.names = names
        self.extra_names = names[6 + self.n_model:]
        self.sigma = np.concatenate([E0_PRIORS, np.asarray(model.priors, float), np.array(extra_sigma)])
        self._tracker_effects = bool(getattr(model, "effects", None)) and any(
            "tracker" in e.kinds for e in model.effects)

    @property
    def n_unknowns(self) -> int:
        return self.sigma.size

    def _extras(self):
        """(index, kind, id, component) of every instrument unknown: kind "station",
        "pivot", "nest" or "target"."""
        for name in self.extra_names:
            head, comp = name.rsplit(".", 1)
            for kind in ("station", "pivot", "nest", "target"):
                if head.startswith(kind):
                    yield self.index[name], kind, head[len(kind):], comp
                    break

    def theta_of(self, model) -> np.ndarray:
        """The unknowns of a fitted model (its E_0, parameters and station corrections;
        pivot, nest and target corrections are folded into the setup, so zero)."""
        theta = np.zeros(self.n_unknowns)
        theta[:6] = model.e0_
        theta[6:6 + self.n_model] = model.b_
        for k, kind, key, comp in self._extras():
            if kind == "station":
                theta[k] = self.setup.stations[int(key)][2][POSE_NAMES.index(comp)]
        return theta

    def fold(self, theta: np.ndarray, cov: np.ndarray | None = None) -> Setup:
        """A new setup with the fitted instrument unknowns put in: E_0, station corrections;
        pivots, nests and targets moved by their corrections (with their standard
        deviations [m] from ``cov``, the covariance of theta, in ``setup.std``)."""
        setup = replace(self.setup.copy(), e0=theta[:6].copy())
        for k, kind, key, comp in self._extras():
            if kind == "station":
                R_, t_, e = setup.stations[int(key)]
                e = np.array(e, float)
                e[POSE_NAMES.index(comp)] = theta[k]
                setup.stations[int(key)] = (R_, t_, e)
                continue
            store = {"pivot": setup.pivots, "nest": setup.nests, "target": setup.targets}[kind]
            ident = int(key) if kind == "pivot" else key
            v = np.array(store[ident], float)
            v["xyz".index(comp)] += theta[k]
            store[ident] = v
            if cov is not None and kind in ("nest", "target"):
                setup.std[f"{kind}{key}.{comp}"] = float(np.sqrt(max(cov[k, k], 0.0)))
        z = [(key, k) for k, kind, key, comp in self._extras() if kind == "nest" and comp == "z"]
        if cov is not None and z:   # the nests' heights covary (a shift of them all): the table's face needs it
            idx = [k for _, k in z]
            setup = replace(setup, nest_z_cov={"ids": [key for key, _ in z], "cov": cov[np.ix_(idx, idx)].copy()})
        return setup

    def sensitivity(self, model) -> tuple[np.ndarray, np.ndarray]:
        """What a model kind's columns share at every row's starting point (no errors):
        (tool direction (N,3): the gauge line's column, zero on nest rows; the model's
        ``sensitivity``, per row from its request). Used by the model choice."""
        c = self.campaign
        T = np.zeros((len(c), 3))
        S = None
        for blk in self.blocks:
            req, rows = blk.request, blk.rows
            if req.kind == "workpiece":
                Tb, Sb = model.workpiece_sensitivity(c.q[rows], req.p_wp)
            else:
                Tb, Sb = model.sensitivity(c.q[rows], req.tool, frame="base", point=_one(req.point),
                                           offset=req.offset if np.any(req.offset) else None)
            if S is None:
                S = np.zeros((len(c),) + Sb.shape[1:])
            T[rows], S[rows] = Tb, Sb
        return T, S

    def evaluate(self, theta: np.ndarray, jacobian: bool = True, operators: bool = False,
                 chunk: int = CHUNK_ROWS) -> Evaluation:
        """The stacked problem at ``theta`` (SI), every row, computed in pieces of at most
        ``chunk`` rows (the model's Jacobians of one piece at a time)."""
        N, P = len(self.campaign), self.n_unknowns
        w, metric = np.zeros((N, 3)), np.zeros((N, 3))
        valid = np.zeros((N, 3), bool)
        y_all = np.full((N, 3), np.nan)
        J = np.zeros((N, 3, P)) if jacobian else None
        A = np.zeros((N, 3, P)) if jacobian else None
        ops = {k: np.zeros((N, 3, 3)) for k in ("Gw", "Gy", "Gm", "Gmy")} if operators else None
        for rows, pc in self._pieces(theta, jacobian, operators, chunk):
            w[rows], metric[rows], valid[rows] = pc["w"], pc["metric"], pc["valid"]
            if pc["y"] is not None:
                y_all[rows] = pc["y"]
            if jacobian:
                J[rows], A[rows] = pc["J"], pc["A"]
            if operators:
                for k in ops:
                    ops[k][rows] = pc[k]
        return Evaluation(w, J, valid, metric, A, y_all, **(ops or {}))

    def normal_equations(self, theta: np.ndarray, jacobian: bool = True, chunk: int = CHUNK_ROWS,
                         with_r: bool = False):
        """(chi2 = |w|^2, G = J^T J, g = J^T w, equations) at ``theta``, accumulated over
        blocks of at most ``chunk`` rows: memory does not grow with rows x unknowns.
        Without ``jacobian`` G and g are None (a trial point's chi2 only). ``with_r``: also
        the R factor of :meth:`redundancy`'s QR test, from the same pass (a fifth item). The
        predicted points of the pass are kept for :meth:`predicted_points` at the same theta."""
        n = workers_wanted()
        # the pieces shared out between forked copies (never threads: the machine's Pinocchio data is one object)
        if not with_r and n > 1 and len(self.campaign) > SHARED_ROWS and _can_fork():
            self._pose_orders(chunk)
            parts = side_by_side(lambda k: self._normal_sums(theta, jacobian, chunk, (k, n)), range(n), processes=True)
            self._keep_points(theta, chunk, [p[1] for p in parts])
            parts = [p[0] for p in parts]
            chi2, n_eq = sum(p[0] for p in parts), sum(p[3] for p in parts)
            if not jacobian:
                return chi2, None, None, n_eq
            return chi2, sum(p[1] for p in parts), sum(p[2] for p in parts), n_eq
        sums, points = self._normal_sums(theta, jacobian, chunk, None, with_r)
        self._keep_points(theta, chunk, [points])
        return sums

    def _keep_points(self, theta: np.ndarray, chunk: int, parts: list) -> None:
        """Keep the predicted points (N,3) [m] of a pass at ``theta`` from its parts' (rows, points),
        those of the last two passes (the solver's last point is often the one before its last trial)."""
        y = np.full((len(self.campaign), 3), np.nan)
        for rows, points in (p for p in parts if p is not None):
            y[rows] = points
        self._points = [(theta.copy(), chunk, y)] + getattr(self, "_points", [])[:1]

    def _normal_sums(self, theta: np.ndarray, jacobian: bool, chunk: int, share: tuple[int, int] | None,
                     with_r: bool = False):
        """(:meth:`normal_equations` over every piece of rows (``share`` (k, n): the k-th of every
        n), (rows, their predicted points) of the pieces or None (no row has a point))."""
        P = self.n_unknowns
        chi2, n_eq = 0.0, 0
        G = np.zeros((P, P)) if jacobian else None
        g = np.zeros(P) if jacobian else None
        order, R = self.priority(), np.zeros((0, P))
        taken, ys = [], []
        for rows, pc in self._pieces(theta, jacobian, False, chunk, metric=False, share=share):
            if pc["y"] is not None:
                taken.append(rows)
                ys.append(pc["y"])
            wf = pc["w"].ravel()
            chi2 += float(wf @ wf)
            n_eq += int(pc["valid"].sum())
            if jacobian:
                Jf = pc["J"].reshape(wf.size, P)
                G += Jf.T @ Jf
                g += Jf.T @ wf
                if with_r:
                    R = linalg.qr(np.vstack([R, Jf[:, order]]), mode="r", check_finite=False)[0][:P]
        points = (np.concatenate(taken), np.concatenate(ys)) if taken else None
        return ((chi2, G, g, n_eq, R) if with_r else (chi2, G, g, n_eq)), points

    def predicted_points(self, theta: np.ndarray, chunk: int = CHUNK_ROWS) -> np.ndarray:
        """(N,3) predicted instrument-frame points [m] (NaN on rows without one); those of
        one of :meth:`normal_equations`' last two passes when it was at ``theta`` (the same numbers)."""
        for kept in getattr(self, "_points", []):
            if kept[1] == chunk and np.array_equal(kept[0], theta):
                return kept[2].copy()
        y = np.full((len(self.campaign), 3), np.nan)
        for rows, pc in self._pieces(theta, False, False, chunk):
            if pc["y"] is not None:
                y[rows] = pc["y"]
        return y

    def priority(self) -> np.ndarray:
        """Column order of the redundancy test (earlier columns are kept): E_0, then the
        target offsets and nest positions, then the other tracker stations' poses, then
        the model parameters and the other instrument unknowns. A target's offset cannot be
        told from the constant error transform after the last axis before it (nor a nest's
        position from the table's), and it is the offset a metrologist asks for: the
        offsets win, the constant terms they explain are removed.

        The stations come before the model because of the gauge: a rigid motion of the
        whole machine (every modelled point, tool and table alike) with the same motion of
        every tracker station changes no reading. With one station E_0 carries that
        motion and the model's terms that would repeat it are removed; with several, the
        stations' poses together carry it and the model loses the same terms, so the
        machine frame is fixed by the same rule with one station or several. Placed after
        the model (as before), a station's pose lost the test against the model's constant
        terms and was removed or called barely identifiable, although its rows determine
        it (tests/test_station_gauge.py)."""
        points = [self.index[n] for n in self.extra_names if n.startswith(("target", "nest"))]
        stations = [self.index[n] for n in self.extra_names if n.startswith("station")]
        first = set(points) | set(stations)
        rest = [k for k in range(6, self.n_unknowns) if k not in first]
        return np.r_[np.arange(6), np.array(points, int), np.array(stations, int), np.array(rest, int)].astype(int)

    def station_warnings(self, keep: np.ndarray, ratio: np.ndarray, weak_ratio: float) -> list[str]:
        """What the fit says of a tracker station (other than 0) whose pose its rows do not
        determine: some of its unknowns removed (``keep`` False) or below ``weak_ratio`` in
        the redundancy test (``ratio``, :meth:`redundancy`, stations before the model), with
        what the campaign must add. Empty when every station's pose is determined."""
        out = []
        c = self.campaign
        for s in sorted({int(n[len("station"):].split(".")[0]) for n in self.extra_names if n.startswith("station")}):
            cols = [self.index[f"station{s}.{comp}"] for comp in POSE_NAMES]
            bad = [POSE_NAMES[j] for j, k in enumerate(cols) if not keep[k] or ratio[k] < weak_ratio]
            if not bad:
                continue
            rows = c.station == s
            tool, nest = int(np.sum(rows & (c.instrument == "tracker"))), int(np.sum(rows & (c.instrument == "nest")))
            commands = len(np.unique(np.round(c.q[rows], 9), axis=0))
            out.append(f"{c.source}: tracker station {s} (station column): its rows do not determine its pose ("
                       f"{', '.join(bad)} of dx, dy, dz, ex, ey, ez; {tool} tool and {nest} nest readings at {commands} "
                       "commands): the fit holds those near the rigid registration of its rows, and what the station "
                       f"reads of the machine is partly lost. {STATION_ADVICE}")
        return out

    def redundancy(self, theta: np.ndarray, norms: np.ndarray, chunk: int = CHUNK_ROWS, R: np.ndarray | None = None):
        """(redundant mask, ratio per unknown) of the QR test in :meth:`priority` order
        (:func:`vecpin.identification.redundancy.redundant_from_r`), in theta's order.
        ``R``: the R factor at ``theta`` when the caller has it (:meth:`normal_equations`)."""
        order = self.priority()
        if R is None:
            R = np.zeros((0, self.n_unknowns))
            for rows, pc in self._pieces(theta, True, False, chunk, metric=False):
                stacked = np.vstack([R, pc["J"].reshape(-1, self.n_unknowns)[:, order]])
                R = linalg.qr(stacked, mode="r", check_finite=False)[0][:self.n_unknowns]
        red_p, ratio_p = redundant_from_r(R, norms[order])
        red, ratio = np.empty_like(red_p), np.empty_like(ratio_p)
        red[order], ratio[order] = red_p, ratio_p
        return red, ratio

    def _pose_orders(self, chunk: int | None) -> None:
        """Each block taken in pieces: its rows' places sorted by pose (``Block.by_pose``)."""
        for blk in self.blocks:
            if chunk and len(blk.rows) > chunk and blk.by_pose is None:
                blk.by_pose = np.lexsort(self.campaign.q[blk.rows].T[::-1])

    def _pieces(self, theta: np.ndarray, jacobian: bool, operators: bool, chunk: int | None = None,
                metric: bool = True, share: tuple[int, int] | None = None):
        """(rows, arrays of those rows) for every block of rows sharing an instrument's
        unknowns, in pieces of at most ``chunk`` rows; ``metric``: with ``jacobian``, also
        d metric / d ψ (``A``; the normal equations do not need it); ``share`` (k, n): the
        k-th piece of every n only."""
        c, m = self.campaign, self.model
        P = self.n_unknowns
        b = theta[6:6 + self.n_model]
        bsl = slice(6, 6 + self.n_model)
        sig2 = self.noise.axis_sigma**2
        piece = -1
        for blk in self.blocks:
            n = len(blk.rows)
            if chunk and n > chunk:   # pieces of rows sorted by pose: a pose's rows (every tool's) in one piece,
                self._pose_orders(chunk)   # its kinematics computed once (FrameProbes.jacobians)
                parts = np.array_split(blk.by_pose, max(1, -(-n // chunk)))
            else:
                parts = [np.arange(n)]
            u = theta[blk.unknowns]
            own = blk.unknowns[:blk.first]
            for pos in parts:
                piece += 1
                if share is not None and piece % share[1] != share[0]:
                    continue
                rows = blk.rows[pos]
                feats = self.features.subset(rows) if self.features is not None else None
                # d point / d q is needed for the positioning noise even when no Jacobian is asked
                p, J_b, J_q, dp_du = model_point(m, c.q[rows], blk.request.take(pos), u, b, feats, jacobian)
                stash = {}

                def terms(y, _rows, feats=feats, stash=stash):
                    shift, D, grad = m.tracker_terms(y, feats, b)
                    stash["D"] = D
                    return shift, grad
                moved = self._tracker_effects and blk.instrument.row_kind in ("tracker", "nest")
                eq = blk.instrument.equations(c, rows, p, self.setup, u[:blk.first], terms if moved else None)
                Aq = eq.dr_dp @ J_q
                L = np.linalg.cholesky((Aq * sig2) @ np.swapaxes(Aq, 1, 2) + eq.S)
                pc = {"w": forward(L, eq.r), "metric": eq.metric,
                      "valid": np.broadcast_to(eq.valid, (len(rows), 3)), "y": eq.y}
                if jacobian:
                    D = np.zeros((len(rows), 3, P))
                    D[:, :, bsl] = eq.dr_dp @ J_b
                    D[:, :, own] += eq.dr_du
                    Dm = np.zeros_like(D) if metric else np.zeros((len(rows), 3, 0))
                    if metric:
                        Dm[:, :, bsl] = eq.dmetric_dp @ J_b
                        Dm[:, :, own] += eq.dmetric_du
                    if dp_du is not None:  # target offsets, nest positions: through the point
                        D[:, :, blk.unknowns] += eq.dr_dp @ dp_du
                        if metric:
                            Dm[:, :, blk.unknowns] += eq.dmetric_dp @ dp_du
                    if "D" in stash:  # tracker-frame effect columns
                        D[:, :, bsl] += eq.dr_dy @ stash["D"]
                        if metric:
                            Dm[:, :, bsl] += -stash["D"] if eq.valid.all() else eq.dr_dy @ stash["D"]
                    pc["J"] = forward(L, D) * self.sigma
                    pc["A"] = Dm * self.sigma if metric else None
                if operators:
                    pc["Gw"] = forward(L, eq.dr_dp)
                    pc["Gm"] = eq.dmetric_dp
                    pc["Gy"] = forward(L, eq.dr_dy) if eq.dr_dy is not None else np.zeros((len(rows), 3, 3))
                    pc["Gmy"] = ((-np.eye(3) if eq.valid.all() else eq.dr_dy) if eq.dr_dy is not None
                                 else np.zeros((len(rows), 3, 3)))
                yield rows, pc


def forward(L: np.ndarray, X: np.ndarray) -> np.ndarray:
    """``L^-1 X`` row by row for lower-triangular L (n,3,3) and X (n,3) or (n,3,k): forward
    substitution written out (a batched general solve factorises every 3 x 3 again)."""
    L0, L1, L2 = (L[:, :, j].reshape((len(L), 3) + (1,) * (X.ndim - 2)) for j in range(3))
    x0 = X[:, 0] / L0[:, 0]
    x1 = (X[:, 1] - L0[:, 1] * x0) / L1[:, 1]
    x2 = (X[:, 2] - L0[:, 2] * x0 - L1[:, 2] * x1) / L2[:, 2]
    return np.stack([x0, x1, x2], axis=1)


def _kinds(instrument: np.ndarray) -> np.ndarray:
    """np.unique of the rows' instruments (one instrument in every row: no sort of a million names)."""
    return instrument[:1] if len(instrument) and np.all(instrument == instrument[0]) else np.unique(instrument)


def _one(point: np.ndarray):
    """A tool point index array as one int when every row has the same (a cheaper call)."""
    point = np.asarray(point)
    return int(point[0]) if point.size and np.all(point == point[0]) else point


def model_point(model: ParametricModel, q: np.ndarray, req: PointRequest, u: np.ndarray, b: np.ndarray,
                features=None, parameters: bool = True):
    """The model's prediction of the requested points in the base frame: (p (n,3) [m],
    d p / d b (n,3,P), d p / d q (n,3,n_axes), d p / d u (n,3,U) or None), u the block's
    unknowns (target offset or nest position corrections among them). Without
    ``parameters`` d p / d b may be None (a model without row effects skips it)."""
    local, cols = req.with_unknowns(u)
    if req.kind == "workpiece":
        wp = model.workpiece_points(q, local, b, True, features)
        p, J_b, J_q, J_local = wp.xyz, wp.J_b, wp.J_q, wp.J_p
    else:
        mt = model.tool_tip(q, req.tool, b, True if parameters else "q", features, frame="base", point=_one(req.point),
                            offset=local if np.any(local) else None)
        p, J_b, J_q, J_local = mt.tip, mt.J_b, mt.J_q, mt.rotation
    if cols is None:
        return p, J_b, J_q, None
    dp_du = np.zeros((len(q), 3, len(u)))
    r = np.flatnonzero(cols[:, 0] >= 0)
    for j in range(3):  # d p / d (local coordinate j) = column j of the frame's rotation
        dp_du[r, :, cols[r, j]] = J_local[r, :, j]
    return p, J_b, J_q, dp_du


def predict_tracker(model: ParametricModel, q: np.ndarray, tool: np.ndarray, theta: np.ndarray, setup: Setup,
                    features=None, jacobian: bool = True, *, point=0, offset=None):
    """Modelled station-0 tracker readings y (N,3) [m] of the tool tips (tool point
    ``point``, target ``offset`` [m] in the tool link frame); with ``jacobian`` also
    d y / d theta (N,3,P+6) and d y / d q (N,3,n). theta = [E_0, b]."""
    e0, b = theta[:6], theta[6:]
    mt = model.tool_tip(q, tool, b, jacobian=jacobian, features=features, frame="base", point=point, offset=offset)
    D = []

    def terms(y):
        shift, d_b, grad = model.tracker_terms(y, features, b)
        D.append(d_b)
        return shift, grad
    moved = getattr(model, "effects", None) and any("tracker" in e.kinds for e in model.effects)
    y, dy_dp, dy_de = station_reading(mt.tip, setup.R, setup.t, e0, terms if moved else None)
    if not jacobian:
        return y, None, None
    dy = np.concatenate([dy_de, dy_dp @ mt.J_b], axis=-1)
    if D:
        dy[:, :, 6:] += D[0]
    return y, dy, dy_dp @ mt.J_q
