"""Campaign simulator: measurement designs and simulated laser-tracker campaigns.

The default design is Paper I's: 295 random commands measured with a 214.88 mm
tool, then the same commands with a 312.86 mm tool (rows in that time order),
plus 35 quasi-random validation commands with the short tool. Exclusion zones
(boxes in axis space, as for line-of-sight and collision avoidance in Paper I
Fig. 6) remove commands. A seeded RNG makes the same files for the same seed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from vecpin.measurement.campaign import Campaign, read_campaign, write_campaign
from vecpin.errors import InputError, VecpinError
from vecpin.fileio import OutputSet
from vecpin.kinematics.machine import Machine
from vecpin.simulation.design import Design, design_commands
from vecpin.simulation.effects import EffectSpec
from vecpin.planning.nests import VALIDATION_READS, nest_positions  # the one placement, shared with planning
from vecpin.simulation.temperature import Hall
from vecpin.simulation.truth import TrueMachine
from vecpin.measurement.features import Features
from vecpin.measurement.tableframe import standstill_draws, standstills
from vecpin.measurement.plantemplate import PlanTemplate
from vecpin.planning.ncprogram import READ_DWELL_S, check_read_dwell
from vecpin.planning.programroute import rereads
from vecpin.planning.timing import reread_times
from vecpin.units import M_PER_MM

DRIFT_LEVELS_OFF_S = 3 * 86400.0  # s: the simulated workshop's temperature drift stops after three days


@dataclass
class Rows:
    """What each simulated row measures: commands q [m, rad], tool [m], tool ``point``,
    ``target`` id, ``instrument`` ("tracker" or "nest"), target ``offset`` (N,3) [m]
    (tool link frame), ``nest`` position (N,3) [m] (workpiece frame, nest rows) and the
    tracker ``station`` (N,) it is read from (a plan read from several stations)."""

    q: np.ndarray
    tool: np.ndarray
    point: np.ndarray
    target: np.ndarray
    instrument: np.ndarray
    offset: np.ndarray
    nest: np.ndarray
    station: np.ndarray

    @classmethod
    def tips(cls, q, tool, point=0) -> "Rows":
        n = len(q)
        return cls(q, np.asarray(tool, float), np.broadcast_to(point, (n,)).astype(int), np.full(n, "", dtype=object),
                   np.full(n, "tracker", dtype=object), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n, int))

    def take(self, idx) -> "Rows":
        return Rows(*(a[idx] for a in self.__dict__.values()))

    def __add__(self, other: "Rows") -> "Rows":
        return Rows(*(np.concatenate([a, b]) for a, b in zip(self.__dict__.values(), other.__dict__.values())))

    def measure(self, truth, rng, features=None, station: int | None = None,
                standstill: np.ndarray | None = None) -> np.ndarray:
        """Tracker readings (N,3) [m] of every row (tool tips, targets, nests), each from
        its own ``station`` or, given, from that one. The axes' positioning noise is drawn
        per row, or with ``standstill`` ((N,) id of the standstill each row is read at)
        once per standstill, shared by every reading there; the tracker's noise per row."""
        xyz = np.empty((len(self.q), 3))
        on = np.full(len(self.q), station) if station is not None else self.station
        f = (lambda sel: features.subset(np.flatnonzero(sel))) if features is not None else (lambda sel: None)
        dq = None
        if standstill is not None and rng is not None:
            dq = standstill_draws(standstill, truth.repeatability, rng)
        pick = (lambda sel: None if dq is None else dq[sel])
        for s in np.unique(on):
            nest = (self.instrument == "nest") & (on == s)
            tool = (self.instrument != "nest") & (on == s)
            if tool.any():
                xyz[tool] = truth.measure(self.q[tool], self.tool[tool], rng, f(tool), int(s), point=self.point[tool],
                                          offset=self.offset[tool] if np.any(self.offset) else None, dq=pick(tool))
            if nest.any():
                xyz[nest] = truth.measure(self.q[nest], self.tool[nest], rng, f(nest), int(s), nest=self.nest[nest],
                                          dq=pick(nest))
        return xyz


def design_rows(machine: Machine, design: Design, q: np.ndarray, tools: np.ndarray, seed: int):
    """(Rows, nests {id: (3,)}, targets {id: (3,)}): every command with every tool (or
    every target) at every tool point, then every command at every table nest."""
    points = range(len(machine.tool_links)) if design.all_points else range(1)
    targets = {f"T{k + 1}": np.asarray(v, float) * M_PER_MM for k, v in enumerate(design.targets_mm)}
    rows = None
    for p in points:
        if targets:
            for tid, off in targets.items():
                r = Rows.tips(q, np.zeros(len(q)), p)
                r.target[:], r.offset[:] = tid, off
                rows = r if rows is None else rows + r
        else:
            for t in tools:
                r = Rows.tips(q, np.full(len(q), t), p)
                rows = r if rows is None else rows + r
    nests = nest_positions(machine, design.n_nests(machine), seed)
    return _and_nests(rows, q, tools[0], nests), nests, targets


def _and_nests(rows: Rows, q: np.ndarray, tool: float, nests: dict) -> Rows:
    """``rows``, then every command q at every table nest {id: (3,) [m], workpiece frame}."""
    for nid, pos in nests.items():
        r = Rows.tips(q, np.full(len(q), tool))
        r.instrument[:], r.target[:], r.nest[:] = "nest", nid, pos
        rows = rows + r
    return rows


def validation_rows(q: np.ndarray, tool: float, nests: dict, reads: int = VALIDATION_READS) -> Rows:
    """The validation run: at every command the tool (tool length ``tool`` [m]), then every
    table nest {id: (3,) [m], workpiece frame}, each read ``reads`` times in a row when
    there are nests (as a plan's validation run), the table standing still between them:
    the rows that judge the tip relative to the table (:mod:`vecpin.measurement.tableframe`)."""
    rows = _and_nests(Rows.tips(q, np.full(len(q), tool)), q, tool, nests)
    order = np.arange(len(rows.q)).reshape(1 + len(nests), len(q)).T.ravel()  # command by command
    return rows.take(np.repeat(order, reads if nests else 1))


def _more_instruments(campaign: Campaign, rows: Rows, truth: TrueMachine, design: Design, rng, seed) -> Campaign:
    """Append rows of further tracker stations (same rows) and of a ball bar."""
    m = truth.machine
    parts = [campaign]
    n = len(campaign)
    t_end, temp_end = campaign.time[-1], campaign.temperature[-1]
    for s in range(1, design.stations):
        if len(truth.stations) < s:
            from vecpin.simulation.truth import place_tracker
            truth.stations.append(place_tracker(m, rng, truth.tracker.noise, 2.0, side=2 * np.pi * s / design.stations))
        # the program runs again for this station, later: its rows carry their own time, temperature and
        # approach directions, so row-dependent effects (thermal, backlash, a tracker step) act on them too
        extra = {"time": t_end + 15.0 * np.arange(n * (s - 1) + 1, n * s + 1), "temperature": np.full(n, temp_end)}
        feats = Features.from_campaign(Campaign(m.axis_names, campaign.q, campaign.tool, np.zeros((n, 3)), extra))
        xyz = rows.measure(truth, rng, feats, station=s)
        parts.append(Campaign(m.axis_names, campaign.q, campaign.tool, xyz, {}, campaign.source,
                              campaign.instrument, np.full(n, s), point=campaign.point, target=campaign.target))
    if design.ballbar_points:
        tool = design.tools_mm[0] * M_PER_MM
        q, pivot = ballbar_commands(m, design.ballbar_points, design.ballbar_radius_mm * M_PER_MM, rng, tool)
        r = truth.measure_radius(q, np.full(len(q), tool), pivot, design.ballbar_sigma_mm * M_PER_MM, rng)
        parts.append(Campaign(m.axis_names, q, np.full(len(q), tool), np.full((len(q), 3), np.nan), {}, campaign.source,
                              np.full(len(q), "ballbar", dtype=object), np.zeros(len(q), int), r, np.zeros(len(q), int)))
        truth.pivot = pivot
    out = Campaign(m.axis_names, np.vstack([p.q for p in parts]), np.concatenate([p.tool for p in parts]),
                   np.vstack([p.xyz for p in parts]), {}, campaign.source,
                   np.concatenate([p.instrument for p in parts]), np.concatenate([p.station for p in parts]),
                   np.concatenate([p.radius for p in parts]), np.concatenate([p.pivot for p in parts]),
                   point=np.concatenate([p.point for p in parts]), target=np.concatenate([p.target for p in parts]),
                   targets=dict(campaign.targets))
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
    nests: dict = field(default_factory=dict)    # true nest positions {id: (3,) [m], workpiece frame}
    targets: dict = field(default_factory=dict)  # true target offsets {id: (3,) [m], tool link frame}

    def write(self, out_dir: str | Path) -> dict[str, Path]:
        """campaign.csv, validation.csv, validation_truth.csv and truth.json (and targets.csv:
        the true target offsets, a known-targets file), committed together."""
        with OutputSet(out_dir) as out:
            return self.write_into(out)

    def write_into(self, out: OutputSet) -> dict[str, Path]:
        """The files of :meth:`write` staged into ``out`` (a larger result's set); each
        campaign file is read back first: a file vecpin would refuse is never written."""
        from vecpin.measurement.campaign import write_targets
        m = self.truth.machine
        names = {"campaign": "campaign.csv", "validation": "validation.csv",
                 "validation_truth": "validation_truth.csv", "truth": "truth.json"}
        if self.targets:
            names["targets"] = "targets.csv"
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
        if self.targets:
            write_targets(out.path(names["targets"]), self.targets)
        for key, fname in names.items():
            if fname.endswith(".csv") and key != "targets":
                _read_back(out.path(fname), m)
        return {k: out.final(v) for k, v in names.items()}


def _read_back(path: Path, machine: Machine) -> None:
    """A simulated file that vecpin would refuse to read is not written (the whole set is
    dropped): say why, so the options can be changed."""
    try:
        read_campaign(path, machine)
    except VecpinError as exc:  # the message names the file as written, not its staging copy
        reason = str(exc).replace(str(path), path.name)
        raise InputError(f"the simulated {path.name} would not be readable ({reason}); change the simulation "
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
        pivot = machine.tool_tip(q_mid[None], tool, frame="base")[0] - np.array([0.0, 0.0, 0.35 * radius])
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
        offset = machine.tool_tip(q, tool, frame="base")  # tip with the linear axes at zero
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


def validation_times(rows: Rows, machine: Machine, design: Design, start: float, reads: int,
                     read_dwell_s: float = READ_DWELL_S) -> np.ndarray:
    """Time stamps [s] of a validation run's rows from ``start`` [s]: the first readings of
    the points as :func:`measurement_times` stamps a run of them alone, each later by the
    dwells of the further readings before it; every further reading of a point at its
    standstill (:func:`~vecpin.planning.programroute.rereads` of ``reads``) ``read_dwell_s``
    [s] after the reading before it, as the plan's NC program dwells
    (:func:`~vecpin.planning.timing.reread_times`)."""
    as_read = PlanTemplate(np.arange(1, len(rows.q) + 1), rows.q, rows.tool, instrument=rows.instrument,
                           target=rows.target, station=rows.station)
    again = rereads(as_read, reads)
    t = np.empty(len(again))
    t[~again] = measurement_times(rows.q[~again], machine, design, start) + read_dwell_s * np.cumsum(again)[~again]
    return reread_times(t, again, read_dwell_s)


def workshop_temperature(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Air temperature [°C]: 20 °C, a slow daily swing, a drift of 0.2 °C per 8 h that levels
    off after three days (a workshop does not warm for ever: a very long simulated campaign
    stays readable) and 0.02 °C sensor noise."""
    phase = rng.uniform(0, 2 * math.pi)
    drift = 0.2 * np.minimum(t, DRIFT_LEVELS_OFF_S) / 28800
    return 20.0 + 0.6 * np.sin(2 * math.pi * t / 86400 + phase) + drift + rng.normal(0, 0.02, len(t))


def _air(hall: Hall, t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The hall sensor's readings [°C] at ``t`` [s]: the hall's profile, else the default workshop."""
    return workshop_temperature(t, rng) if hall.profile is None else hall.profile.read(t, rng)


class _DriveTurn:
    """The twin drives' differential of a table set acting on the true machine, as a
    geometric tip effect: the beam turns (:meth:`TableSet.turn_tips`, base frame)."""

    geometric, flags_rows = True, False

    def __init__(self, tables, machine: Machine):
        self.tables, self.machine = tables, machine

    def simulate_command(self, q, feats):
        return np.zeros_like(q)

    def simulate_tip(self, q, tip, tool_dir, feats):
        return self.tables.turn_tips(self.machine, q, tip)

    def simulate_tracker(self, y, feats):
        return y

    def simulate_gross(self, y):
        return y


def simulate(machine: Machine, seed: int = 0, design: Design | None = None, truth: TrueMachine | None = None,
             effects: list | None = None, plan: "PlanTemplate | tuple[np.ndarray, np.ndarray] | None" = None, tables=None,
             tracker_position: np.ndarray | None = None, plan_times: np.ndarray | None = None,
             validation_commands: np.ndarray | None = None, station_positions: list | None = None,
             read_dwell_s: float = READ_DWELL_S, hall: Hall | None = None, **truth_options) -> Simulation:
    """Simulate a campaign on ``machine`` (a random :class:`TrueMachine` from ``seed``
    unless ``truth`` is given). ``effects``: effects acting on the true machine
    (instances of :mod:`vecpin.models.effects` classes, or :class:`EffectSpec`), scaled
    to their strength on this campaign; the validation files carry them too (except
    gross errors).

    ``plan``: a :class:`~vecpin.measurement.plantemplate.PlanTemplate` (its nest rows
    read reflectors at the planned nest positions, workpiece frame) or (commands (N,n)
    [m, rad], tool lengths (N,) [m]), measured in that order instead of the design's
    commands (a plan's template measured as if for real).
    ``tables``: a :class:`~vecpin.compensation.tables.TableSet`; the validation commands
    are then also run on the true machine through the tables (compensated command =
    command + table increments, eq. 15; the twin drives' differential turns their beam)
    and measured: ``compensated`` (noisy) and
    ``compensated_truth`` (noise-free). The rows keep the programmed commands; the
    controller's gauge-line change belongs to the tables, not to the files. The other
    outputs are the same with or without ``tables``. ``tracker_position`` (3,) [m],
    machine frame: where the tracker stands (as planned), keeping its random heading.
    ``plan_times`` (N,) [s]: the time stamps of the plan's rows as its NC program runs
    them (:func:`vecpin.planning.timing.row_times`) instead of the design's seconds per
    point; ``validation_commands`` (K,n) [m, rad]: the plan's validation run (inside
    its zone) instead of quasi-random commands over the whole travel.
    ``station_positions``: the tracker stations (3,) [m], machine frame, by station id,
    of a plan read from several (its template's ``station`` column; plan.json): each
    station's block of rows is read from there (station 0 there too unless
    ``tracker_position`` is given), each tracker with a random heading.
    ``read_dwell_s`` [s]: the time of every further reading of a point in the validation run
    (the plan's NC program's dwell, :func:`validation_times`).
    ``hall``: the hall's temperature profile, when the validation run starts and the
    controller's thermal terms in the run through the tables (:mod:`vecpin.simulation.temperature`).

    The stages, in the order they draw from the seeded generator: the true machine, the
    rows measured (the plan's or the design's), the identification campaign, the
    validation runs."""
    design = design or Design()
    template = plan if isinstance(plan, PlanTemplate) else None
    if template is not None:
        plan = (template.q, template.tool)
    _check_simulation(machine, seed, design, plan, truth_options.get("mean_error_mm"), tracker_position, read_dwell_s)
    hall = hall or Hall()
    hall.check()
    rng = np.random.default_rng(int(seed))
    if template is not None and np.any(template.stations != 0) and design.stations > 1:
        raise InputError(f"`stations` {design.stations}: the plan says which tracker station reads each row (its "
                         "station column); simulate it with `stations` 1")
    if station_positions is not None and tracker_position is None:
        tracker_position = station_positions[0]
    truth = _true_machine(machine, rng, truth, effects, tracker_position, truth_options)
    rows, nests, targets, tool0 = _measured_rows(machine, design, plan, template, rng, seed)
    _place_stations(truth, rows.station, station_positions, rng)
    campaign, t_end = _identification_campaign(machine, design, truth, rows, rng, seed,
                                               plan_times if plan is not None else None, targets, hall)
    qv = design_commands(machine, design.n_validation, rng, "halton", design.exclude) \
        if validation_commands is None else np.atleast_2d(np.asarray(validation_commands, float))
    reads = VALIDATION_READS if nests else 1
    runs = _validation_runs(machine, design, truth, validation_rows(qv, tool0, nests, reads), rng, seed,
                            (t_end, reads, read_dwell_s), tables, hall)
    return Simulation(truth, campaign, *runs, nests, targets)


def _check_simulation(machine: Machine, seed, design: Design, plan, mean_error_mm: float | None,
                      tracker_position: np.ndarray | None, read_dwell_s: float = READ_DWELL_S) -> None:
    """Every setting of a simulation inside its meaning, before any work (names the parameter)."""
    if int(seed) != seed or seed < 0:
        raise InputError(f"`seed` {seed}: a whole number >= 0")
    design.check(machine, None if plan is None else len(plan[1]))
    if mean_error_mm is not None and not (np.isfinite(mean_error_mm) and 0 < mean_error_mm <= 100):
        raise InputError(f"`mean_error_mm` {mean_error_mm}: the mean volumetric error of the true machine, mm > 0 "
                         "(e.g. 0.65)")
    if tracker_position is not None and not np.all(np.isfinite(tracker_position)):
        raise InputError("`tracker_position`: three finite numbers")
    check_read_dwell(read_dwell_s)


def _true_machine(machine: Machine, rng: np.random.Generator, truth: TrueMachine | None, effects: list | None,
                  tracker_position: np.ndarray | None, truth_options: dict) -> TrueMachine:
    """The true machine: ``truth`` or a random one; the tracker moved to
    ``tracker_position`` (3,) [m], machine frame, keeping its heading; ``effects`` acting on it."""
    truth = truth or TrueMachine.random(machine, rng, **truth_options)
    if tracker_position is not None:
        from vecpin.measurement.tracker import Tracker
        R = truth.tracker.rotation
        truth.tracker = Tracker(R, -R @ np.asarray(tracker_position, float), truth.tracker.noise)
    if effects:
        truth.effects = [e.build(machine) if isinstance(e, EffectSpec) else e for e in effects]
    return truth


def _place_stations(truth: TrueMachine, station: np.ndarray, positions: list | None, rng: np.random.Generator) -> None:
    """The true trackers of the stations other than 0 that rows are read from (``station``
    (N,) ids): at ``positions`` [id] (3,) [m], machine frame; a station the truth already
    has keeps its heading, a new one gets a random heading (yaw, tilt below 2 deg)."""
    from vecpin.measurement.tracker import Tracker
    from vecpin.kinematics.so3 import exp3
    for k in range(1, int(station.max(initial=0)) + 1):
        if positions is None or k >= len(positions):
            if k > len(truth.stations):
                raise InputError(f"the plan reads rows from tracker station {k + 1} (station {k} in its template), whose "
                                 "position is not given: the plan's stations_mm, in the plan.json beside its plan.csv "
                                 "(in Python, the station_positions argument)")
            continue
        if k <= len(truth.stations):
            R = truth.stations[k - 1].rotation
        else:
            tilt = rng.normal(size=3) * [1.0, 1.0, 0.0]
            R = exp3(np.radians(rng.uniform(0, 2.0)) * tilt / np.linalg.norm(tilt)) @ exp3(
                np.array([0.0, 0.0, rng.uniform(-math.pi, math.pi)]))
        tracker = Tracker(R, -R @ np.asarray(positions[k], float), truth.tracker.noise)
        if k <= len(truth.stations):
            truth.stations[k - 1] = tracker
        else:
            truth.stations.append(tracker)


def _measured_rows(machine: Machine, design: Design, plan, template: PlanTemplate | None, rng: np.random.Generator,
                   seed: int) -> tuple[Rows, dict, dict, float]:
    """The rows of the identification campaign in measurement order: the plan's (its table
    nests where it put them), or the design's commands with every tool, target and nest
    and its repeated points (eq. 22); with the nests {id: (3,) [m]}, the targets {id: (3,)
    [m]} and the holder length [m] of the validation run (the first)."""
    tools = np.asarray(design.tools_mm, float) * M_PER_MM
    if plan is not None:
        qs, tool = np.atleast_2d(np.asarray(plan[0], float)), np.asarray(plan[1], float)
        if len(qs) != len(tool) or qs.shape[1:] != (machine.n_axes,):
            raise VecpinError("a plan gives one command per row (N, n axes) and one tool length per row")
        rows, nests = Rows.tips(qs, tool), {}
        if template is not None and template.has_nests:  # the nests stand where the plan put them
            on = template.instrument == "nest"
            rows.instrument[on], rows.target[on], rows.nest[on] = "nest", template.target[on], template.nest[on]
            nests = template.nests()
        if template is not None:
            rows.station[:] = template.stations  # each block from its tracker station
        return rows, nests, {}, float(tool[0])  # the validation run uses the plan's first holder
    q = design_commands(machine, design.n_commands, rng, design.method, design.exclude)
    rows, nests, targets = design_rows(machine, design, q, tools, seed)
    if design.repeat_points and design.repeat_times:
        pick = q[rng.choice(len(q), min(design.repeat_points, len(q)), replace=False)]
        seqs = [pick[rng.permutation(len(pick))] for _ in range(design.repeat_times)]
        rows = rows + Rows.tips(np.vstack(seqs), np.full(len(pick) * design.repeat_times, tools[0]))
    return rows, nests, targets, float(tools[0])


def _identification_campaign(machine: Machine, design: Design, truth: TrueMachine, rows: Rows,
                             rng: np.random.Generator, seed: int, plan_times: np.ndarray | None,
                             targets: dict, hall: Hall) -> tuple[Campaign, float]:
    """The rows measured on the true machine: time stamps [s] (the design's seconds per
    point and feed, or ``plan_times``), workshop temperature, the effects calibrated to
    their strength on these rows; then further tracker stations and ball bar rows. With
    the time [s] of the last row of the first station."""
    qs, tool = rows.q, rows.tool
    t = measurement_times(qs, machine, design)
    if plan_times is not None:
        if len(plan_times) != len(qs):
            raise VecpinError("the plan's time stamps do not match its rows")
        t = np.asarray(plan_times, float)
    extra = {"time": t, "temperature": _air(hall, t, rng)}
    feats = Features.from_campaign(Campaign(machine.axis_names, qs, tool, np.zeros((len(qs), 3)), extra))
    if truth.effects:
        truth.calibrate_effects(qs, tool, feats)
    campaign = Campaign(machine.axis_names, qs, tool, rows.measure(truth, rng, feats), extra, f"simulated seed {seed}",
                        rows.instrument.copy(), rows.station.copy(), point=rows.point.copy(), target=rows.target.copy(),
                        targets=dict(targets) if design.known_targets else {})
    if design.stations > 1 or design.ballbar_points:
        campaign = _more_instruments(campaign, rows, truth, design, rng, seed)
    return campaign, float(t[-1])


def _validation_runs(machine: Machine, design: Design, truth: TrueMachine, vrows: Rows, rng: np.random.Generator,
                     seed: int, timed: tuple[float, int, float],
                     tables, hall: Hall) -> tuple[Campaign, Campaign, Campaign | None, Campaign | None]:
    """The validation run ``vrows`` the hall's delay (default 10 min) after the campaign's last row (``timed``: that
    row's time [s], the readings of every point and the time [s] of a further one,
    :func:`validation_times`): measured (noisy) and noise-free, without the effects that
    flag rows (gross errors); with ``tables`` the same commands again through the tables,
    noisy and noise-free. The rows of a command are read at one standstill: the axes'
    positioning noise is drawn once for them, the tracker's per reading."""
    t_end, reads, read_dwell_s = timed
    qa, tv = vrows.q, vrows.tool  # the validation commands at the tool, then at every table nest
    times_v = validation_times(vrows, machine, design, t_end + hall.validation_after_s, reads, read_dwell_s)
    extra_v = {"time": times_v, "temperature": _air(hall, times_v, rng)}
    commands = Campaign(machine.axis_names, qa, tv, np.zeros((len(qa), 3)), extra_v)
    feats_v, still = Features.from_campaign(commands), standstills(commands)
    clean = [e for e in truth.effects if not e.flags_rows]
    all_effects, truth.effects = truth.effects, clean

    def run(rows, extra, feats, noise, what):
        return Campaign(machine.axis_names, qa, tv, rows.measure(truth, noise, feats, standstill=still), dict(extra),
                        f"simulated seed {seed}, {what}", rows.instrument.copy(), target=rows.target.copy())
    validation = run(vrows, extra_v, feats_v, rng, "validation")
    exact = run(vrows, extra_v, feats_v, None, "noise-free")
    comp = comp_exact = None
    if tables is not None:  # after everything else: the other outputs do not change
        truth.effects = clean + [_DriveTurn(tables, machine)] if tables.drives else clean
        times_c = validation_times(vrows, machine, design, times_v[-1] + 600.0, reads, read_dwell_s)
        extra_c = {"time": times_c, "temperature": _air(hall, times_c, rng)}
        qt, tool_t = hall.controller(machine, tables.apply(qa), vrows.tool, times_c, extra_c["temperature"])
        crows = replace(vrows, q=qt, tool=tool_t)  # the table moves through the tables too (nest rows)
        feats_c = Features.from_campaign(Campaign(machine.axis_names, crows.q, tv, np.zeros((len(qa), 3)), extra_c))
        comp = run(crows, extra_c, feats_c, rng, "validation with the tables")
        comp_exact = run(crows, extra_c, feats_c, None, "validation with the tables, noise-free")
    truth.effects = all_effects
    return validation, exact, comp, comp_exact
