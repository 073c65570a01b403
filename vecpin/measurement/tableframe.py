"""The tool tip relative to the table, measured: tool rows seen from the table nests.

On a machine with a table branch a floor tracker reads the tool in the base frame, where
the table axes do not move it; what a part sees is the tip relative to the table. At
every command of a run the tracker reads the tool's reflector and the reflectors in the
table nests. The nests' positions on the table (the workpiece frame: from the fit, or
re-fitted from the run) registered on their readings at that command give the table's
pose in the tracker frame at that command (the tracker pose registered on the nests:
Kabsch, three or more nests not on a line), and the tool reading taken back through it
is the measured tip relative to the table. A point read several times in a row at one
command (the same tool point or nest, the machine standing still: a table machine's
validation run reads each :data:`~vecpin.planning.nests.VALIDATION_READS` times) counts
as the mean of those readings (:func:`repeated_readings`). The mean divides the tracker's
noise variance by the number of readings, not the machine's positioning noise: the axes
stand where they stopped for every reading of a standstill (:func:`standstills`), so the
noise netted out (:func:`net_of_noise`) draws the tracker's noise per reading and the
axes' once per standstill. No machine model enters: the figures judged
from it (``vecpin evaluate``, ``vecpin verify``) compare it with the nominal or the
modelled tip relative to the workpiece after the best rigid registration (where the part
sits is not observable and does not matter, as for the simulated truth).

The checks a table campaign needs before a fit (:func:`table_campaign_notes`): nest rows
at all, at least three nests, not on a line, and nests that stayed put (the distances
between nests read at the same command do not depend on the machine's errors: a table
is rigid, so a step in them is a nest that moved); after the fit, a step in one nest's
residuals (:func:`moved_nest_after_fit`) finds the moves that hardly change a distance.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.errors import CampaignFileError
from vecpin.measurement.registration import kabsch, rigid_registration, spans_plane
from vecpin.units import MM_PER_M

KEY_DIGITS = 9           # commands equal to 1e-9 m / rad are the same command
MIN_NESTS = 3            # nests a command needs for the table's pose
MOVED_NEST_MM = 0.02     # a step in a nest's distances to the others larger than this (and the noise) is a move
LINE_SHARE = 0.05        # nests spread across their line by less than this share of their length are on a line
NEST_SHAPE_MM = 0.05     # fitted nests that differ from a run's own nest shape by more than this are re-fitted


@dataclass
class TableTips:
    """Tool rows seen from the table: ``rows`` (indices into the campaign of the tool rows
    judged), ``tip`` (N,3) [m] each row's reading in the workpiece frame of ``nests``,
    ``unjudged`` (tool rows whose command had fewer than three nests read, or nests on a
    line), ``commands`` (commands judged), ``nests`` {id: (3,) [m]} used, ``refitted``
    (True: the nests' shape came from the run itself)."""

    rows: np.ndarray
    tip: np.ndarray
    unjudged: np.ndarray
    commands: int
    nests: dict
    refitted: bool


def command_keys(campaign) -> np.ndarray:
    """(N,) integer id of each row's (station, command): rows read at the same pose."""
    k = np.c_[campaign.station, np.round(campaign.q * 10**KEY_DIGITS)]
    return np.unique(k, axis=0, return_inverse=True)[1].ravel()


def standstills(campaign) -> np.ndarray:
    """(N,) id of the standstill each row is read at: consecutive rows at the same (station,
    command), the machine not moving between them."""
    k = np.c_[campaign.station, np.round(campaign.q * 10**KEY_DIGITS)]
    return np.cumsum(np.r_[True, np.any(k[1:] != k[:-1], axis=1)]) - 1 if len(k) else np.zeros(0, int)


def standstill_draws(still: np.ndarray, sigma: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(N, n) positioning noise [m, rad] of every row: one draw of 1-sigma ``sigma`` (n,)
    per standstill (``still``: :func:`standstills`), shared by every reading there."""
    return (rng.standard_normal((int(still.max(initial=-1)) + 1, len(sigma))) * sigma)[still]


def repeated_readings(campaign) -> tuple[np.ndarray, np.ndarray]:
    """((N,) bool: the row starts a run, (N,3) [m] each row's reading averaged over its
    run): a run is consecutive rows reading the same point (instrument, target, tool point,
    holder) at one standstill (see the module text)."""
    n = len(campaign)
    if not n:
        return np.zeros(0, bool), np.zeros((0, 3))
    key = np.c_[standstills(campaign), np.round(campaign.tool * 10**KEY_DIGITS), campaign.point]
    same = np.r_[False, np.all(key[1:] == key[:-1], axis=1) & (campaign.instrument[1:] == campaign.instrument[:-1])
                 & (campaign.target[1:] == campaign.target[:-1])]
    run = np.cumsum(~same) - 1
    mean = np.zeros((run[-1] + 1, 3))
    np.add.at(mean, run, campaign.xyz)
    return ~same, (mean / np.bincount(run)[:, None])[run]


def _groups(campaign, nest_ids=None):
    """[(tool rows, nest rows)] of every (station, command) with tool rows and nest rows."""
    key = command_keys(campaign)
    nest = campaign.instrument == "nest"
    if nest_ids is not None:
        nest &= np.isin(campaign.target, list(nest_ids))
    tool = campaign.instrument == "tracker"
    out = []
    order = np.argsort(key, kind="stable")
    bounds = np.flatnonzero(np.diff(key[order])) + 1
    for g in np.split(order, bounds):
        t, n = g[tool[g]], g[nest[g]]
        if len(n):
            _, first = np.unique(campaign.target[n], return_index=True)
            out.append((t, n[first]))  # one reading per nest, in the order of the nest ids
    return out


def _by_nests(campaign, groups) -> dict:
    """{nest ids read: ([tool rows of each command], nest rows (G,k))}: the commands that
    read the same nests, stacked."""
    out = {}
    for t, n in groups:
        tools, nests = out.setdefault(tuple(str(x) for x in campaign.target[n]), ([], []))
        tools.append(t)
        nests.append(n)
    return {ids: (tools, np.array(nests)) for ids, (tools, nests) in out.items()}


def nest_shape(campaign, start: dict | None = None, iterations: int = 20) -> dict:
    """The nests' positions {id: (3,) [m]} up to a rigid motion, from the run alone
    (generalised Procrustes: every command's nest readings registered on the mean shape,
    which is then their mean), starting from ``start`` (e.g. the fitted nests) or from the
    command with the most nests read."""
    xyz = repeated_readings(campaign)[1]  # a nest read several times in a row: its mean
    batches = {ids: b for ids, b in _by_nests(campaign, _groups(campaign)).items()
               if len(ids) >= MIN_NESTS and spans_plane(xyz[b[1][0]])}
    if not batches:
        return {}
    ids_all = sorted({i for ids in batches for i in ids})
    if start and all(i in start for i in ids_all):
        shape = {i: np.asarray(start[i], float) for i in ids_all}
    else:
        ids0 = max(batches, key=len)
        shape = dict(zip(ids0, xyz[batches[ids0][1][0]]))
    for _ in range(iterations):
        total, count = {}, {}
        for ids, (_, rows) in batches.items():
            if any(i not in shape for i in ids):
                continue
            Q = xyz[rows]
            R, t = kabsch(np.array([shape[i] for i in ids]), Q)
            local = np.einsum("gji,gkj->gki", R, Q - t[:, None])  # R^T (Q - t): each reading on the table
            for a, i in enumerate(ids):
                total[i] = total.get(i, 0.0) + local[:, a].sum(axis=0)
                count[i] = count.get(i, 0) + len(rows)
        new = {i: total[i] / count[i] for i in total}
        change = max((np.abs(new[i] - shape[i]).max() for i in new if i in shape), default=np.inf)
        shape = new
        if change < 1e-10:
            break
    return shape


def _shape_error(a: dict, b: dict) -> float:
    """Largest distance [m] between two nest shapes after their best rigid fit."""
    ids = sorted(set(a) & set(b))
    if len(ids) < MIN_NESTS:
        return np.inf
    P, Q = np.array([a[i] for i in ids]), np.array([b[i] for i in ids])
    R, t = rigid_registration(P, Q)
    return float(np.linalg.norm(Q - (P @ R.T + t), axis=1).max())


def table_nests(runs: list, fitted: dict | None = None) -> tuple[dict, bool]:
    """(nests {id: (3,) [m]}, re-fitted?) for judging ``runs`` (campaigns of one table):
    the fitted nests when they name every nest of the runs and keep their shape there,
    else the shape re-fitted from the runs together."""
    from vecpin.measurement.campaign import Campaign
    nest_runs = [r.subset(r.nest_rows) for r in runs if len(r.nest_rows)]
    if not nest_runs:
        return {}, False
    both = nest_runs[0] if len(nest_runs) == 1 else Campaign(
        list(nest_runs[0].axis_names), np.vstack([r.q for r in nest_runs]), np.concatenate([r.tool for r in nest_runs]),
        np.vstack([r.xyz for r in nest_runs]), {}, nest_runs[0].source, np.concatenate([r.instrument for r in nest_runs]),
        np.concatenate([r.station + 10_000 * k for k, r in enumerate(nest_runs)]),  # each run's commands apart
        target=np.concatenate([r.target for r in nest_runs]))
    own = nest_shape(both, fitted)
    if fitted and set(own) <= set(fitted) and _shape_error(fitted, own) * MM_PER_M < NEST_SHAPE_MM:
        return {i: np.asarray(fitted[i], float) for i in own}, False
    return own, True


def registers_table(campaign) -> bool:
    """Does the campaign read :data:`MIN_NESTS` or more nests (two miss the turn about their line)?"""
    return len(set(np.asarray(campaign.target, dtype=object)[np.asarray(campaign.nest_rows, int)])) >= MIN_NESTS


def table_tips(campaign, nests: dict, refitted: bool = False) -> TableTips:
    """The tool rows of ``campaign`` in the workpiece frame of ``nests`` (see the module
    text): each command's table pose registered on the nests read at it; a point read
    several times in a row counts as the mean of its readings, on the row of its first."""
    rows, tips, unjudged, commands = [], [], [], 0
    start, xyz = repeated_readings(campaign)
    groups = [(t[start[t]], n) for t, n in _groups(campaign, nests) if len(t)]
    for ids, (tools, nest_rows) in _by_nests(campaign, groups).items():
        P = np.array([nests[i] for i in ids])
        if len(ids) < MIN_NESTS or not spans_plane(P):
            unjudged += tools
            continue
        R, tr = kabsch(P, xyz[nest_rows])
        g = np.repeat(np.arange(len(tools)), [len(t) for t in tools])  # each tool row's command
        t_rows = np.concatenate(tools)
        rows.append(t_rows)
        tips.append(np.einsum("gji,gj->gi", R[g], xyz[t_rows] - tr[g]))
        commands += len(tools)
    tool = np.flatnonzero((campaign.instrument == "tracker") & start)
    missing = np.setdiff1d(tool, np.concatenate(rows + unjudged) if rows or unjudged else np.zeros(0, int))
    rows_a = np.concatenate(rows) if rows else np.zeros(0, int)
    order = np.argsort(rows_a)
    return TableTips(rows_a[order], np.vstack(tips)[order] if tips else np.zeros((0, 3)),
                     np.sort(np.concatenate(unjudged + [missing])).astype(int), commands, dict(nests), refitted)


def _axis_jitter(machine, campaign, tips: TableTips, axis_sigma: np.ndarray, rng) -> np.ndarray:
    """(N,3) [m] each row's reading moved by the machine's positioning noise (1-sigma
    ``axis_sigma`` (n,) [m, rad] on the commands, drawn once per standstill: every reading
    there, of the tool and of the nests, sees the same axis positions, :func:`standstills`),
    in the tracker frame of each station (its rotation from the nominal points registered
    on the readings); zero on rows of nests not in ``tips``."""
    q = campaign.q
    dq = standstill_draws(standstills(campaign), np.asarray(axis_sigma, float), rng)
    d = np.zeros((len(q), 3))
    nominal = np.full((len(q), 3), np.nan)
    tool = np.flatnonzero(campaign.instrument == "tracker")
    nest = np.flatnonzero((campaign.instrument == "nest") & np.isin(campaign.target, list(tips.nests)))
    if len(tool):
        pt = campaign.point[tool]
        at = [machine.tool_tip(x[tool], campaign.tool[tool], frame="base", point=pt) for x in (q, q + dq)]
        nominal[tool], d[tool] = at[0], at[1] - at[0]
    if len(nest):
        P = np.array([tips.nests[str(t)] for t in campaign.target[nest]])
        at = [machine.workpiece_points(x[nest], P, jacobian=False).xyz for x in (q, q + dq)]
        nominal[nest], d[nest] = at[0], at[1] - at[0]
    for st in np.unique(campaign.station):
        rows = np.flatnonzero((campaign.station == st) & np.isfinite(nominal[:, 0]))
        if len(rows) >= 3 and spans_plane(nominal[rows]):
            d[rows] = d[rows] @ rigid_registration(nominal[rows], campaign.xyz[rows])[0].T
    return d


def _noise_draws(campaign, tips: TableTips, tracker_noise, draws: int, seed: int, axis=None) -> np.ndarray:
    """(draws, N) squared displacement [m^2] of each judged row's measured tip relative to
    the table when the run's readings (tool and nests) get the tracker's noise again
    (:class:`~vecpin.measurement.tracker.TrackerNoise`, in the tracker's spherical
    coordinates) and, with ``axis`` = (machine, axis_sigma), the machine's positioning
    noise (:func:`_axis_jitter`); NaN where a draw judges other rows."""
    from vecpin.measurement.tracker import Tracker
    tracker, rng = Tracker(noise=tracker_noise), np.random.default_rng(seed)
    out = np.full((draws, len(tips.rows)), np.nan)
    for k in range(draws):
        c = campaign.subset(np.arange(len(campaign)))
        c.xyz = tracker.add_noise(campaign.xyz, rng)
        if axis is not None:
            c.xyz = c.xyz + _axis_jitter(axis[0], campaign, tips, axis[1], rng)
        again = table_tips(c, tips.nests)
        if np.array_equal(again.rows, tips.rows):
            out[k] = np.sum((again.tip - tips.tip) ** 2, axis=1)
    return out


def tip_noise(campaign, tips: TableTips, tracker_noise, draws: int = 10, seed: int = 0) -> np.ndarray:
    """(N,) mean displacement [m] of each judged row's measured tip relative to the table
    when the run's readings (tool and nests) get the tracker's noise again
    (:class:`~vecpin.measurement.tracker.TrackerNoise`, in the tracker's spherical
    coordinates): the noise the nest registration gives the measured tip. A model whose
    error is below it cannot be told apart on this run."""
    return np.sqrt(_noise_draws(campaign, tips, tracker_noise, draws, seed)).mean(axis=0)


@dataclass
class NetOfNoise:
    """The model's error relative to the table with the measurement noise taken out [mm]:
    ``rms`` its estimated root mean square and ``sd`` the standard uncertainty of that
    estimate; ``measured_rms`` the RMS of the judged residuals (model error and noise),
    ``noise_rms`` the noise's expected RMS contribution after the registration; ``rows``;
    ``ms_sd`` [mm^2] the standard uncertainty of the mean squared error it comes from."""

    rms: float
    sd: float
    measured_rms: float
    noise_rms: float
    rows: int
    ms_sd: float = 0.0

    @property
    def resolved(self) -> bool:
        """True when the estimate is at least twice its uncertainty."""
        return bool(self.rms >= 2 * self.sd)

    def line(self) -> str:
        how = (f"(measured RMS {self.measured_rms:.4f} mm over {self.rows} rows, from which the noise's expected "
               f"{self.noise_rms:.4f} mm RMS, the tracker's and the axes' noise through the nest registration, is "
               "subtracted in quadrature; ± one standard uncertainty from the spread over the rows and the noise draws)")
        if self.resolved:
            return f"model error net of the measurement noise: {self.rms:.4f} ± {self.sd:.4f} mm RMS {how}"
        return (f"model error net of the measurement noise: not resolved by this run, {self.rms:.4f} ± {self.sd:.4f} mm "
                f"RMS, below {self.rms + 2 * self.sd:.4f} mm at two standard uncertainties {how}; more validation "
                "commands resolve it (more readings of each point at its standstill take out only the tracker's "
                "share of the noise)")


def net_of_noise(residual: np.ndarray, campaign, tips: TableTips, noise, machine, draws: int = 40,
                 seed: int = 1, removed: int = 6) -> NetOfNoise:
    """The model error net of the measurement noise from ``residual`` (N,3) [m], the
    judged rows' measured minus modelled tip relative to the table after the rigid
    registration (workpiece frame; the rows of ``tips`` of ``campaign``). A measured
    residual is the model error plus the noise of the measured tip: per row its covariance
    Σ_i from ``draws`` copies of the run given the noise of ``noise`` (a
    :class:`~vecpin.measurement.noise.NoiseModel`: the tracker's, and the positioning noise
    of ``machine``'s axes on every reading) again. With the noise independent of the
    error, E|r_i|^2 = |e_i|^2 + f tr Σ_i, where f = 1 - k / (3N) is the share of the
    noise a registration of ``removed`` = k degrees of freedom on N points leaves (6: the best
    rigid motion; 4: the part's set-up, a translation and a rotation about the spindle). The mean of |r_i|^2 - f tr Σ_i is then
    an unbiased estimate of the mean squared model error (the figure the truth of a
    simulated machine gives without noise), its uncertainty the spread of that difference
    over the rows and of tr Σ over the draws; the RMS and its uncertainty by the delta method."""
    r2 = np.sum(np.asarray(residual, float) ** 2, axis=1)
    n2 = _noise_draws(campaign, tips, noise.tracker, draws, seed, (machine, noise.axis_sigma))
    n2 = n2[np.all(np.isfinite(n2), axis=1)]
    n = len(r2)
    f = max(1.0 - removed / (3 * n), 0.0)
    noise_sq = f * n2.mean(axis=0)                        # (N,) f tr Σ_i
    d = r2 - noise_sq
    ms = float(d.mean())
    var = float(d.var(ddof=1)) / n + f**2 * float(n2.mean(axis=1).var(ddof=1)) / len(n2)
    rms, sd_ms = np.sqrt(max(ms, 0.0)), np.sqrt(var)
    sd = min(sd_ms / (2 * rms), np.sqrt(sd_ms)) if rms > 0 else np.sqrt(sd_ms)  # the delta method, capped near zero
    return NetOfNoise(rms * MM_PER_M, float(sd) * MM_PER_M, float(np.sqrt(r2.mean())) * MM_PER_M,
                      float(np.sqrt(noise_sq.mean())) * MM_PER_M, n, float(sd_ms) * MM_PER_M**2)


def check_nest_rows(machine, campaign) -> None:
    """Nest rows on a machine without a table branch are refused (nothing carries them)."""
    nest = campaign.nest_rows
    if len(nest) and not machine.has_workpiece:
        raise CampaignFileError(campaign.source, f"{len(nest)} nest row(s), but machine '{machine.name}' has no table "
                                "branch (no 'workpiece' link) to carry a nest; a floor tracker sees its tool tips "
                                "directly: delete the nest rows or give the machine with its table",
                                row=int(campaign.lines[nest[0]]), column="instrument")


def table_campaign_notes(machine, campaign) -> list[str]:
    """Why a table machine's campaign cannot identify its table axes, one note each (empty:
    nothing found): no nest rows, fewer than three nests, nests on a line, a nest that
    moved (see the module text), parts of a table axis' travel where the table's pose was
    never measured (:func:`unseen_travel_notes`). Names the file and the rows."""
    check_nest_rows(machine, campaign)
    if not machine.has_workpiece:
        return []
    src, table = campaign.source, ", ".join(machine.table_axes)
    nest = campaign.nest_rows
    if not len(nest):
        return [f"{src}: no nest rows, so the table axes ({table}) are not seen: a floor tracker reading the tool "
                "does not see the table move, and their terms cannot be identified; read reflectors in three or "
                "more nests on the table at each command ('instrument' = nest)"]
    ids = sorted(set(campaign.target[nest].tolist()))
    first = f"rows {campaign.lines[nest[0]]}..{campaign.lines[nest[-1]]}"
    if len(ids) < MIN_NESTS:
        return [f"{src}: the nest rows ({first}) read only {len(ids)} nest(s) ({', '.join(ids)}): the table's pose "
                f"needs three or more nests, not on a line, so the table axes ({table}) are only partly seen"]
    out = []
    groups = [n for _, n in _groups(campaign) if len(n) >= MIN_NESTS]
    if groups and all(on_a_line(campaign.xyz[n]) for n in groups):
        out.append(f"{src}: the nests {', '.join(ids)} ({first}) lie on a line: a turn of the table about that line "
                   f"is not seen, so the table axes ({table}) are only partly seen; put a nest off the line")
    out += _moved_nests(campaign)
    return out + unseen_travel_notes(machine, campaign)


TRAVEL_BINS = 10  # a table axis' travel judged in tenths


def unseen_travel_notes(machine, campaign) -> list[str]:
    """A note per table axis with tenths of its travel (inside the commands' range) where
    no command read three nests from one station: the table's pose is not measured there,
    so the model's terms of that axis and its tables are extrapolated from the rest."""
    groups = [n for _, n in _groups(campaign) if len(n) >= MIN_NESTS]
    if not groups:
        return []
    q_seen = campaign.q[[n[0] for n in groups]]
    out = []
    for name in machine.table_axes:
        a = machine.axis(name)
        lo, hi = campaign.q[:, a.index].min(), campaign.q[:, a.index].max()
        edges = lo + (hi - lo) * np.arange(TRAVEL_BINS + 1) / TRAVEL_BINS
        if hi - lo < 1e-9 * a.travel:
            continue
        b = np.clip(((q_seen[:, a.index] - lo) / (hi - lo) * TRAVEL_BINS).astype(int), 0, TRAVEL_BINS - 1)
        blind = np.setdiff1d(np.arange(TRAVEL_BINS), b)
        if not len(blind):
            continue
        where = ", ".join(f"{a.to_user(edges[k]):.1f}..{a.to_user(edges[k + 1]):.1f}" for k in blind)
        out.append(f"{campaign.source}: the table's pose (three nests read at one command) is not measured over "
                   f"{100 * len(blind) / TRAVEL_BINS:.0f} % of the commanded travel of {name} ({where} {a.unit}): the "
                   f"model's {name} terms and its tables are carried there from the rest of the travel (interpolated or "
                   "extrapolated); read the nests there "
                   "(vecpin plan places nests, and a second tracker station, for the line of sight)")
    return out


def _step(series: np.ndarray) -> tuple[int, np.ndarray, float]:
    """The best single step in a series (m, k) of vectors: (first row after it, mean after
    minus mean before, robust noise of one value about the two means)."""
    m = len(series)
    cut = np.arange(max(2, m // 10), m - max(2, m // 10))
    c = np.cumsum(series, axis=0)
    step = (c[-1] - c[cut - 1]) / (m - cut)[:, None] - c[cut - 1] / cut[:, None]  # mean after minus before
    k = int(cut[np.argmax(np.linalg.norm(step, axis=1) * np.sqrt(cut * (m - cut)))])
    rest = np.r_[series[:k] - series[:k].mean(axis=0), series[k:] - series[k:].mean(axis=0)]
    return k, series[k:].mean(axis=0) - series[:k].mean(axis=0), 1.4826 * float(np.median(np.abs(rest)))


def moved_nest_after_fit(campaign, residual: np.ndarray) -> list[str]:
    """A note on the nest whose residuals after the fit (``residual`` (N,3) [m], measured
    minus modelled, every row) step during the campaign by more than :data:`MOVED_NEST_MM`
    and ten standard errors, twice as much as any other nest's (a drift moves them all):
    the moves the distances between nests do not show (:func:`table_campaign_notes`)."""
    found = []
    for j in sorted(set(campaign.target[campaign.nest_rows].tolist())):
        rows = np.sort(campaign.nest_rows[campaign.target[campaign.nest_rows] == j])
        if len(rows) < 20:
            continue
        k, change, noise = _step(residual[rows])
        size = float(np.linalg.norm(change))
        found.append((size / max(noise * np.sqrt(1 / k + 1 / (len(rows) - k)), 1e-12), size, j, rows[k]))
    found.sort(reverse=True)
    if not found or found[0][1] * MM_PER_M <= MOVED_NEST_MM or found[0][0] < 10:
        return []
    if len(found) > 1 and found[0][1] < 2 * found[1][1]:
        return []
    _, size, j, row = found[0]
    return [f"{campaign.source}: nest {j} moved at row {campaign.lines[row]}: from there its residuals after the fit "
            f"step by {size * MM_PER_M:.3f} mm; a nest must stay put for the whole campaign: re-seat it and measure "
            "again, or give the rows after the move another nest id"]


def on_a_line(points: np.ndarray) -> bool:
    """Points whose spread across their line is under :data:`LINE_SHARE` of their spread along it."""
    sv = np.linalg.svd(points - points.mean(0), compute_uv=False)
    return bool(sv[1] < LINE_SHARE * sv[0])


def _moved_nests(campaign) -> list[str]:
    """A note on the nest whose distances to the other nests (read at the same commands)
    step during the campaign by more than :data:`MOVED_NEST_MM` and eight standard errors
    of the step. A nest moving square to the lines to the others (straight up, with nests
    at one height) changes no distance and is not seen here."""
    groups = _groups(campaign)
    ids = sorted(set(campaign.target[campaign.nest_rows].tolist()))
    out = []
    for j in ids:
        series, rows = [], []
        for _, n in groups:
            tgt = {str(campaign.target[r]): r for r in n}
            if j not in tgt or len(tgt) < 2:
                continue
            others = [i for i in ids if i != j]
            d = [np.linalg.norm(campaign.xyz[tgt[j]] - campaign.xyz[tgt[i]]) if i in tgt else np.nan for i in others]
            series.append(d)
            rows.append(tgt[j])
        if len(series) < 20:
            continue
        order = np.argsort(rows)
        D, rows = np.array(series)[order], np.array(rows)[order]
        D = np.nan_to_num(D - np.nanmedian(D, axis=0))  # change of this nest's distance to each other nest
        m = len(D)
        k, change, noise = _step(D)
        jump = float(np.linalg.norm(change))
        if jump * MM_PER_M > MOVED_NEST_MM and jump > 8 * noise * np.sqrt(1 / k + 1 / (m - k)):
            out.append((jump, j, int(campaign.lines[rows[k]]), noise))
    if not out:
        return []
    # a moved nest changes its distance to every other nest, each other nest only the one to it
    jump, j, row, noise = max(out)
    return [f"{campaign.source}: nest {j} moved at row {row}: from there its distances to the other nests change by "
            f"{jump * MM_PER_M:.3f} mm (noise {noise * MM_PER_M:.4f} mm a reading), but a table is rigid; a nest must "
            "stay put for the whole campaign: re-seat it and measure again, or give the rows after the move another "
            "nest id"]


__all__ = ["TableTips", "table_tips", "tip_noise", "NetOfNoise", "net_of_noise", "moved_nest_after_fit", "table_nests", "nest_shape", "table_campaign_notes", "check_nest_rows",
           "command_keys", "unseen_travel_notes"]
