"""Campaign simulator: measurement designs and simulated laser-tracker campaigns.

The default design is Paper I's: 295 random commands measured with a 214.88 mm
tool, then the same commands with a 312.86 mm tool (rows in that time order),
plus 35 quasi-random validation commands with the short tool. Exclusion zones
(boxes in axis space, as for line-of-sight and collision avoidance in Paper I
Fig. 6) remove commands. A seeded RNG makes the same files for the same seed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.stats import qmc

from vecpin.measurement.campaign import MAX_ID, Campaign, min_rows, read_campaign, write_campaign
from vecpin.errors import InputError, VecpinError
from vecpin.fileio import OutputSet
from vecpin.kinematics.machine import Machine
from vecpin.simulation.effects import EffectSpec
from vecpin.planning.zones import check_zone_axes, parse_zone, zone_bounds  # noqa: F401  (parse_zone re-exported)
from vecpin.simulation.truth import TrueMachine

PAPER_I_TOOLS_MM = (214.88, 312.86)
DRIFT_LEVELS_OFF_S = 3 * 86400.0  # s: the simulated workshop's temperature drift stops after three days
SIMULATION_BYTES_PER_ROW = 3000  # peak memory of a simulation per row (measured: 2.9 GB for 1,000,000 rows)
MAX_ROWS = 1_300_000  # rows one simulation holds: about 4 GB at the peak


@dataclass
class Design:
    """What to measure. ``exclusion_zones``: list of {axis: (lo, hi)} in mm/deg; a
    command inside every interval of a zone is not measured. ``method``: "random",
    "sobol" or "halton" for the identification commands (validation is always Halton).
    ``seconds_per_point`` (settle + measure) and ``feed_m_per_s`` (moves) make ``time``."""

    n_commands: int = 295
    tools_mm: tuple[float, ...] = PAPER_I_TOOLS_MM
    n_validation: int = 35
    method: str = "random"
    exclusion_zones: list[dict[str, tuple[float, float]]] = field(default_factory=list)
    seconds_per_point: float = 15.0
    feed_m_per_s: float = 0.1
    repeat_points: int = 0   # after the campaign: this many commands, each measured ...
    repeat_times: int = 0    # ... this many times, in a new random order each sequence (eq. 22)
    stations: int = 1        # tracker positions; every command is measured from each
    ballbar_points: int = 0  # ball bar rows on a sphere about one pivot (eq. 63-64)
    ballbar_radius_mm: float = 254.0
    ballbar_sigma_mm: float = 0.0025

    def check(self, machine: Machine, planned_rows: int | None = None, files: bool = False) -> None:
        """Refuse, before any work, a design that is too large to hold or, with ``files``,
        whose files vecpin could not read back (names the ``vecpin simulate`` option).
        ``planned_rows``: the rows of a plan measured instead of drawn commands."""
        need = min_rows(machine.n_axes) if files else 1
        _whole("--validation", self.n_validation, need, f"a campaign of a {machine.n_axes}-axis machine needs at "
               f"least {need} rows" if files else "validation commands")
        _whole("--stations", self.stations, 1, "tracker positions", MAX_ID + 1)
        _whole("--ballbar", self.ballbar_points, 0, "ball bar rows")
        tools = np.asarray(self.tools_mm, float)
        if tools.size == 0 or not np.all(np.isfinite(tools)) or np.any(tools < 0) or np.any(tools > 10_000):
            raise InputError(f"--tools {' '.join(f'{t:g}' for t in tools)}: tool lengths are mm from the gauge line, "
                             "0 .. 10000 (e.g. 214.88 312.86)")
        if np.all(tools < 1.0):
            raise InputError(f"--tools {' '.join(f'{t:g}' for t in tools)}: every length is below 1 mm; tool lengths "
                             "are mm (e.g. 214.88 312.86), not metres")
        if self.repeat_points or self.repeat_times:
            if int(self.repeat_points) != self.repeat_points or int(self.repeat_times) != self.repeat_times or \
                    self.repeat_points < 1 or self.repeat_times < 2:
                raise InputError(f"--repeat {self.repeat_points:g} {self.repeat_times:g}: POINTS >= 1 commands, each "
                                 "measured TIMES >= 2 times")
        for zone in self.exclusion_zones:
            check_zone_axes(machine, zone, "--exclude")
        if self.method not in ("random", "sobol", "halton"):
            raise InputError(f"--method {self.method}: random, sobol or halton")
        if planned_rows is None:
            _whole("--points", self.n_commands, 1, "commands")
            per_station = self.n_commands * len(tools)
            if files and per_station < need:
                raise InputError(f"--points {self.n_commands}: {per_station} rows ({self.n_commands} commands x "
                                 f"{len(tools)} tools), but a campaign of a {machine.n_axes}-axis machine needs at "
                                 f"least {need}; give --points {math.ceil(need / len(tools))} or more")
            repeats = min(self.repeat_points, self.n_commands) * self.repeat_times
        else:
            per_station, repeats = planned_rows, 0
        rows = per_station * self.stations + self.ballbar_points + repeats + self.n_validation
        if rows > MAX_ROWS:
            raise InputError(f"the design has {rows:,} rows (--points x --tools x --stations, --repeat, --ballbar, "
                             f"--validation); vecpin simulates at most {MAX_ROWS:,} rows at once (these would need "
                             f"about {rows * SIMULATION_BYTES_PER_ROW / 1e9:.0f} GB of memory); simulate fewer")


def _whole(option: str, value, lowest: int, what: str, highest: int | None = None) -> None:
    if int(value) != value or value < lowest or (highest is not None and value > highest):
        top = f" .. {highest}" if highest is not None else " or more"
        raise InputError(f"{option} {value}: a whole number {lowest}{top} ({what})")


def design_commands(machine: Machine, n: int, rng: np.random.Generator, method: str = "random",
                    exclusion_zones=(), scramble_seed: int | None = None) -> np.ndarray:
    """n commands [m, rad] over the axis limits, outside every exclusion zone."""
    zones = [_zone_si(machine, z) for z in exclusion_zones]
    out = np.empty((0, machine.n_axes))
    for _attempt in range(50):
        m = max(2 * (n - len(out)), 16)
        if method == "random":
            u = rng.random((m, machine.n_axes))
        elif method in ("sobol", "halton"):
            seed = scramble_seed if scramble_seed is not None else int(rng.integers(2**31))
            eng = qmc.Sobol(machine.n_axes, seed=seed) if method == "sobol" else qmc.Halton(machine.n_axes, seed=seed)
            u = eng.random(2 ** math.ceil(math.log2(m))) if method == "sobol" else eng.random(m)
        else:
            raise VecpinError(f"unknown design method '{method}' (random, sobol, halton)")
        q = machine.lower + u * (machine.upper - machine.lower)
        keep = np.ones(len(q), bool)
        for lo, hi in zones:
            keep &= ~np.all((q >= lo) & (q <= hi), axis=1)
        out = np.vstack([out, q[keep]])
        if len(out) >= n:
            return out[:n]
    raise InputError("--exclude: the exclusion zones leave (almost) no room for commands; make them smaller")


def _zone_si(machine: Machine, zone: dict[str, tuple[float, float]]):
    """(low, high) [m, rad] of an exclusion zone (see :func:`vecpin.planning.zones.zone_bounds`)."""
    return zone_bounds(machine, zone)


def _more_instruments(campaign: Campaign, truth: TrueMachine, design: Design, rng, seed) -> Campaign:
    """Append rows of further tracker stations (same commands) and of a ball bar."""
    from vecpin.measurement.tracker import TrackerNoise
    m = truth.machine
    parts = [campaign]
    n = len(campaign)
    for s in range(1, design.stations):
        if len(truth.stations) < s:
            from vecpin.simulation.truth import place_tracker
            truth.stations.append(place_tracker(m, rng, truth.tracker.noise, 2.0, side=2 * np.pi * s / design.stations))
        xyz = truth.measure(campaign.q, campaign.tool, rng, station=s)
        parts.append(Campaign(m.axis_names, campaign.q, campaign.tool, xyz, {}, campaign.source,
                              station=np.full(n, s)))
    if design.ballbar_points:
        tool = design.tools_mm[0] * 1e-3
        q, pivot = ballbar_commands(m, design.ballbar_points, design.ballbar_radius_mm * 1e-3, rng, tool)
        r = truth.measure_radius(q, np.full(len(q), tool), pivot, design.ballbar_sigma_mm * 1e-3, rng)
        parts.append(Campaign(m.axis_names, q, np.full(len(q), tool), np.full((len(q), 3), np.nan), {}, campaign.source,
                              np.full(len(q), "ballbar", dtype=object), np.zeros(len(q), int), r, np.zeros(len(q), int)))
        truth.pivot = pivot
    t_end = campaign.time[-1]
    out = Campaign(m.axis_names, np.vstack([p.q for p in parts]), np.concatenate([p.tool for p in parts]),
                   np.vstack([p.xyz for p in parts]), {}, campaign.source,
                   np.concatenate([p.instrument for p in parts]), np.concatenate([p.station for p in parts]),
                   np.concatenate([p.radius for p in parts]), np.concatenate([p.pivot for p in parts]))
    t = np.r_[campaign.time, t_end + 15.0 * np.arange(1, len(out) - n + 1)]
    out.extra = {"time": t, "temperature": np.r_[campaign.temperature, np.full(len(out) - n, campaign.temperature[-1])]}
    return out


@dataclass
class Simulation:
    """A simulated campaign: truth, identification and validation campaigns (noisy),
    and the noise-free validation positions (tracker frame)."""

    truth: TrueMachine
    campaign: Campaign
    validation: Campaign
    validation_truth: Campaign
    compensated: Campaign | None = None        # the validation commands run through the tables (noisy)
    compensated_truth: Campaign | None = None  # the same, noise-free

    def write(self, out_dir: str | Path) -> dict[str, Path]:
        """campaign.csv, validation.csv, validation_truth.csv and truth.json, committed together."""
        with OutputSet(out_dir) as out:
            return self.write_into(out)

    def write_into(self, out: OutputSet) -> dict[str, Path]:
        """The files of :meth:`write` staged into ``out`` (a larger result's set); each
        campaign file is read back first: a file vecpin would refuse is never written."""
        m = self.truth.machine
        names = {"campaign": "campaign.csv", "validation": "validation.csv",
                 "validation_truth": "validation_truth.csv", "truth": "truth.json"}
        if self.compensated is not None:
            names |= {"validation_compensated": "validation_compensated.csv",
                      "validation_compensated_truth": "validation_compensated_truth.csv"}
        write_campaign(out.path(names["campaign"]), self.campaign, m)
        write_campaign(out.path(names["validation"]), self.validation, m)
        write_campaign(out.path(names["validation_truth"]), self.validation_truth, m)
        if self.compensated is not None:
            write_campaign(out.path(names["validation_compensated"]), self.compensated, m)
            write_campaign(out.path(names["validation_compensated_truth"]), self.compensated_truth, m)
        self.truth.save(out.path(names["truth"]))
        for key, fname in names.items():
            if fname.endswith(".csv"):
                _read_back(out.path(fname), m)
        return {k: out.final(v) for k, v in names.items()}


def _read_back(path: Path, machine: Machine) -> None:
    """A simulated file that vecpin would refuse to read is not written (the whole set is
    dropped): say why, so the options can be changed."""
    try:
        read_campaign(path, machine)
    except VecpinError as exc:
        raise InputError(f"the simulated {path.name} would not be readable ({exc}); change the simulation "
                         "options") from None


def ballbar_commands(machine: Machine, n: int, radius: float, rng: np.random.Generator, tool: float,
                     pivot: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Commands [m, rad] putting the nominal tool tip on a sphere of ``radius`` [m] about
    ``pivot`` (upper hemisphere, eq. 63), with random orientations of the rotary axes
    (eq. 64 by nominal inverse kinematics: the first three axes translate along x, y, z)."""
    lin = [a for a in machine.axes[:3] if a.kind == "linear"]
    if len(lin) < 3 or [tuple(a.direction) for a in lin] != [(1.0, 0, 0), (0, 1.0, 0), (0, 0, 1.0)]:
        raise VecpinError("ball bar designs need a machine whose first three axes are X, Y, Z translations")
    if pivot is None:  # the table centre, low in Z, where the whole hemisphere is reachable
        q_mid = (machine.lower + machine.upper) / 2
        q_mid[3:] = 0.0
        pivot = machine.tool_tip(q_mid[None], tool)[0] - np.array([0.0, 0.0, 0.35 * radius])
    out = []
    for _ in range(200):
        m = 4 * n
        a1 = rng.uniform(0, 2 * np.pi, m)
        a2 = np.arccos(rng.uniform(np.cos(np.radians(75)), 1.0, m))  # from the vertical, upper part of the sphere
        p = pivot + radius * np.c_[np.cos(a1) * np.sin(a2), np.sin(a1) * np.sin(a2), np.cos(a2)]
        q = np.zeros((m, machine.n_axes))
        for a in machine.axes[3:]:
            span = min(a.upper, np.radians(40)) - max(a.lower, -np.radians(40))
            q[:, a.index] = max(a.lower, -np.radians(40)) + rng.random(m) * span
        offset = machine.tool_tip(q, tool)  # tip with the linear axes at zero
        q[:, :3] = p - offset
        ok = np.all((q >= machine.lower) & (q <= machine.upper), axis=1)
        out += list(q[ok])
        if len(out) >= n:
            return np.array(out[:n]), pivot
    raise VecpinError("could not place the ball bar sphere inside the axis limits")


def measurement_times(q: np.ndarray, machine: Machine, design: Design, start: float = 0.0) -> np.ndarray:
    """Time stamps [s] of rows measured in order: settle/measure time plus moves at feed."""
    lin = [a.index for a in machine.axes if a.kind == "linear"]
    moves = np.r_[0.0, np.linalg.norm(np.diff(q[:, lin], axis=0), axis=1)] if lin else np.zeros(len(q))
    return start + np.cumsum(design.seconds_per_point + moves / design.feed_m_per_s)


def workshop_temperature(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Air temperature [°C]: 20 °C, a slow daily swing, a drift of 0.2 °C per 8 h that levels
    off after three days (a workshop does not warm for ever: a very long simulated campaign
    stays readable) and 0.02 °C sensor noise."""
    phase = rng.uniform(0, 2 * math.pi)
    drift = 0.2 * np.minimum(t, DRIFT_LEVELS_OFF_S) / 28800
    return 20.0 + 0.6 * np.sin(2 * math.pi * t / 86400 + phase) + drift + rng.normal(0, 0.02, len(t))


def simulate(machine: Machine, seed: int = 0, design: Design | None = None, truth: TrueMachine | None = None,
             effects: list | None = None, plan: tuple[np.ndarray, np.ndarray] | None = None, tables=None,
             tracker_position: np.ndarray | None = None, **truth_options) -> Simulation:
    """Simulate a campaign on ``machine`` (a random :class:`TrueMachine` from ``seed``
    unless ``truth`` is given). ``effects``: effects acting on the true machine
    (instances of :mod:`vecpin.models.effects` classes, or :class:`EffectSpec`), scaled
    to their strength on this campaign; the validation files carry them too (except
    gross errors).

    ``plan``: (commands (N,n) [m, rad], tool lengths (N,) [m]) measured in that order
    instead of the design's commands (a plan's template measured as if for real).
    ``tables``: a :class:`~vecpin.compensation.tables.TableSet`; the validation commands
    are then also run on the true machine through the tables (compensated command =
    command + table increments, eq. 15) and measured: ``compensated`` (noisy) and
    ``compensated_truth`` (noise-free). The rows keep the programmed commands; the
    controller's gauge-line change belongs to the tables, not to the files. The other
    outputs are the same with or without ``tables``. ``tracker_position`` (3,) [m],
    machine frame: where the tracker stands (as planned), keeping its random heading."""
    from vecpin.measurement.features import Features
    design = design or Design()
    if int(seed) != seed or seed < 0:
        raise InputError(f"--seed {seed}: a whole number >= 0")
    design.check(machine, None if plan is None else len(plan[1]))
    mean = truth_options.get("mean_error_mm")
    if mean is not None and not (np.isfinite(mean) and 0 < mean <= 100):
        raise InputError(f"--mean-error {mean}: the mean volumetric error of the true machine, mm > 0 (e.g. 0.65)")
    if tracker_position is not None and not np.all(np.isfinite(tracker_position)):
        raise InputError("--tracker: three finite numbers, mm")
    rng = np.random.default_rng(int(seed))
    truth = truth or TrueMachine.random(machine, rng, **truth_options)
    if tracker_position is not None:
        from vecpin.measurement.tracker import Tracker
        R = truth.tracker.rotation
        truth.tracker = Tracker(R, -R @ np.asarray(tracker_position, float), truth.tracker.noise)
    if effects:
        truth.effects = [e.build(machine) if isinstance(e, EffectSpec) else e for e in effects]
    tools = np.asarray(design.tools_mm, float) * 1e-3
    if plan is not None:
        qs, tool = np.atleast_2d(np.asarray(plan[0], float)), np.asarray(plan[1], float)
        if len(qs) != len(tool) or qs.shape[1:] != (machine.n_axes,):
            raise VecpinError("a plan gives one command per row (N, n axes) and one tool length per row")
        tools = tool[:1]  # the validation run uses the plan's first holder
    else:
        q = design_commands(machine, design.n_commands, rng, design.method, design.exclusion_zones)
        qs = np.vstack([q] * len(tools))
        tool = np.repeat(tools, len(q))
    if plan is None and design.repeat_points and design.repeat_times:
        pick = q[rng.choice(len(q), min(design.repeat_points, len(q)), replace=False)]
        seqs = [pick[rng.permutation(len(pick))] for _ in range(design.repeat_times)]
        qs = np.vstack([qs] + seqs)
        tool = np.r_[tool, np.full(len(pick) * design.repeat_times, tools[0])]
    t = measurement_times(qs, machine, design)
    extra = {"time": t, "temperature": workshop_temperature(t, rng)}
    feats = Features.from_campaign(Campaign(machine.axis_names, qs, tool, np.zeros((len(qs), 3)), extra))
    if truth.effects:
        truth.calibrate_effects(qs, tool, feats)
    campaign = Campaign(machine.axis_names, qs, tool, truth.measure(qs, tool, rng, feats), extra, f"simulated seed {seed}")
    if design.stations > 1 or design.ballbar_points:
        campaign = _more_instruments(campaign, truth, design, rng, seed)
    qv = design_commands(machine, design.n_validation, rng, "halton", design.exclusion_zones)
    tv = np.full(len(qv), tools[0])
    times_v = measurement_times(qv, machine, design, start=t[-1] + 600.0)
    extra_v = {"time": times_v, "temperature": workshop_temperature(times_v, rng)}
    feats_v = Features.from_campaign(Campaign(machine.axis_names, qv, tv, np.zeros((len(qv), 3)), extra_v))
    clean = [e for e in truth.effects if not e.flags_rows]
    all_effects, truth.effects = truth.effects, clean
    validation = Campaign(machine.axis_names, qv, tv, truth.measure(qv, tv, rng, feats_v), extra_v,
                          f"simulated seed {seed}, validation")
    exact = Campaign(machine.axis_names, qv, tv, truth.measure(qv, tv, None, feats_v), dict(extra_v),
                     f"simulated seed {seed}, noise-free")
    comp = comp_exact = None
    if tables is not None:  # after everything else: the other outputs do not change
        qc = tables.apply(qv)
        times_c = measurement_times(qv, machine, design, start=times_v[-1] + 600.0)
        extra_c = {"time": times_c, "temperature": workshop_temperature(times_c, rng)}
        feats_c = Features.from_campaign(Campaign(machine.axis_names, qc, tv, np.zeros((len(qv), 3)), extra_c))
        comp = Campaign(machine.axis_names, qv, tv, truth.measure(qc, tv, rng, feats_c), extra_c,
                        f"simulated seed {seed}, validation with the tables")
        comp_exact = Campaign(machine.axis_names, qv, tv, truth.measure(qc, tv, None, feats_c), dict(extra_c),
                              f"simulated seed {seed}, validation with the tables, noise-free")
    truth.effects = all_effects
    return Simulation(truth, campaign, validation, exact, comp, comp_exact)
