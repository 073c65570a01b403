"""A measurement plan in one call: candidates, exclusion zones and line of sight, the
D-optimal choice, the order and approach, the predicted uncertainty (Paper I Section 4,
Fig. 6; eq. 22 for repeated points).

1. Candidates: a scrambled Halton set over the axis space (inside a measurement zone if
   one is given, and far enough from the limits for the approach move), on the NC grid
   (0.001 mm, 0.001 deg).
2. Removed: candidates in an exclusion zone ("CA") and those the tracker cannot see with
   every target holder length ("LoS").
3. Chosen: greedy D-optimal on the model's whitened parameter Jacobian
   (:mod:`~vecpin.planning.doptimal`), or at random (Paper I's way, for comparison).
4. Order: a short tour for the first holder, reversed for the next; optional repeated
   points (eq. 22) measured at the start and again at the end, each sequence in a new
   random order, for short- and long-term repeatability.
5. Prediction: covariance of the parameters from all planned rows and the error it
   leaves at quasi-random validation commands (:mod:`~vecpin.planning.information`).

On a machine with table axes (a ``workpiece`` frame), reflectors in table nests
(:mod:`~vecpin.planning.nests`) are read at every command's dwell with the first holder
(the nests the tracker sees there): their rows, and the nests' unknown positions, count
in the D-optimal choice and the prediction through the fit's one likelihood.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.stats import qmc

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.plantemplate import PlanTemplate
from vecpin.models import make_model
from vecpin.planning import route
from vecpin.planning.doptimal import greedy_d_optimal
from vecpin.planning.information import Information, PredictedError, validation_commands
from vecpin.planning.nests import check_nests, nest_positions
from vecpin.planning.nestplacement import Placement, place_nests
from vecpin.planning.planchecks import EXPECTED_ERROR_MM, plan_warnings
from vecpin.planning.sightline import (DEFAULT_TARGET_CLEARANCE, DEFAULT_TOOL_RADIUS, SightLine,
                                       default_tracker_placement, side_name)
from vecpin.planning.zones import Zone, check_zone_axes, clip_to_zone, inside
from vecpin.measurement.campaign import PAPER_I_TOOLS_MM
from vecpin.units import MM_PER_M, M_PER_MM
from vecpin.threads import one_blas_thread



MAX_POINTS = 10_000         # commands of one plan
MAX_CANDIDATES = 100_000    # candidate commands the D-optimal choice scores


@dataclass
class PlanSettings:
    """What to plan (user units where a user types them).

    ``n_points``: commands, each measured with every holder length ``tools_mm`` [mm];
    ``model``/``order``/``basis``: the model the campaign is for; ``noise``: the fit's
    noise model (default: spherical tracker noise); ``tracker_mm`` (3,) [mm] machine base
    frame (default: 2 m beyond the workspace on the side the tips are seen from); ``exclude``: exclusion zones;
    ``zone``: measurement zone; ``method``: "doptimal" or "random"; ``approach``:
    below/above/both/none with distances ``approach_mm`` [mm], ``approach_deg`` [deg];
    ``repeat_points`` x ``repeat_times``: repeated points at the start and at the end;
    ``sight``: test the line of sight (``tool_radius_mm``, ``target_clearance_mm``);
    ``rapid_mm_min``/``rapid_deg_min``: rapid speeds (default: URDF velocity limits);
    ``candidates``: candidate commands (default :func:`default_candidates`); ``validation_points``:
    quasi-random commands the predicted error is judged on; ``validation_run``: the
    commands of the validation run (inside the zone, free and in sight with the first
    holder; measured with and without the tables); ``nests``: table nests read
    at every command (None: 3 on a machine with a workpiece frame, else 0) at default
    places, or ``nest_mm`` {id: (x, y, z) [mm], workpiece frame} as the user placed them;
    ``expected_error_mm``: the machine's mean uncompensated error [mm] as a tracker sees
    it (best-fit rigid motion removed), which the plan's predicted error must stay well
    below (:mod:`~vecpin.planning.planchecks`)."""

    n_points: int = 100
    tools_mm: tuple[float, ...] = PAPER_I_TOOLS_MM
    model: str = "ap"
    order: int = 4
    basis: str = "auto"
    noise: NoiseModel | None = None
    tracker_mm: tuple[float, float, float] | None = None
    exclude: list[Zone] = field(default_factory=list)
    zone: Zone | None = None
    method: str = "doptimal"
    approach: str = "below"
    approach_mm: float = 5.0
    approach_deg: float = 1.0
    repeat_points: int = 0
    repeat_times: int = 0
    sight: bool = True
    geometry: str = "auto"
    tool_radius_mm: float = DEFAULT_TOOL_RADIUS * MM_PER_M
    target_clearance_mm: float = DEFAULT_TARGET_CLEARANCE * MM_PER_M
    rapid_mm_min: float | None = None
    rapid_deg_min: float | None = None
    candidates: int | None = None
    validation_points: int = 500
    validation_run: int = 35
    seed: int = 0
    nests: int | None = None
    nest_mm: dict[str, tuple[float, float, float]] | None = None
    expected_error_mm: float = EXPECTED_ERROR_MM
    place_nests: bool = True  # default nests placed for the line of sight, a second station proposed (nestplacement)

    def nest_places(self, machine: Machine) -> dict[str, np.ndarray]:
        """{nest id: (3,) [m], workpiece frame} of the plan (checked, names the option)."""
        if self.nest_mm:
            if self.nests is not None and self.nests != len(self.nest_mm):
                raise InputError(f"--nests {self.nests} but {len(self.nest_mm)} --nest positions given: give one or "
                                 "the other (or the same count)")
            out = {k: np.asarray(v, float) * M_PER_MM for k, v in self.nest_mm.items()}
            check_nests(machine, out, "--nest")
            return out
        n = (3 if machine.has_workpiece else 0) if self.nests is None else self.nests
        check_nests(machine, {str(k): 0 for k in range(n)}, "--nests")
        return nest_positions(machine, n)

    def check(self) -> None:
        """Every option inside its meaning, before any work (names the option)."""
        if self.n_points < 1:
            raise InputError(f"--points {self.n_points}: plan at least one command")
        if self.n_points > MAX_POINTS:
            raise InputError(f"--points {self.n_points}: at most {MAX_POINTS} commands (at 15 s a point, "
                             f"{self.n_points * len(self.tools_mm) * 15 / 3600:.0f} h of tracker time); plan fewer")
        tools = np.asarray(self.tools_mm, float)
        if tools.size == 0 or not np.all(np.isfinite(tools)) or tools.min() < 0 or tools.max() > 10_000:
            raise InputError("--tools: holder lengths are mm from the gauge line, 0 .. 10000 (e.g. 214.88,312.86)")
        if len(np.unique(np.round(tools, 6))) < tools.size:
            raise InputError(f"--tools {','.join(f'{t:g}' for t in tools)}: two holders of the same length measure the "
                             "same point twice; give different lengths (they separate the tool-axis errors)")
        if self.method not in ("doptimal", "random"):
            raise InputError(f"--method '{self.method}': doptimal or random")
        if (self.repeat_points or self.repeat_times) and (self.repeat_points < 1 or self.repeat_times < 2):
            raise InputError("--repeat POINTS TIMES: POINTS >= 1 commands, each measured TIMES >= 2 times")
        if self.repeat_points > self.n_points:
            raise InputError(f"--repeat {self.repeat_points} {self.repeat_times}: the repeated points are taken from the "
                             f"planned commands, at most --points ({self.n_points})")
        if self.order < 0:
            raise InputError(f"--order {self.order}: orders are >= 0")
        if self.tracker_mm is not None and not np.all(np.isfinite(np.asarray(self.tracker_mm, float))):
            raise InputError("--tracker: three finite numbers, mm")
        if self.candidates is not None and not self.n_points <= self.candidates <= MAX_CANDIDATES:
            raise InputError(f"--candidates {self.candidates}: between --points ({self.n_points}) and "
                             f"{MAX_CANDIDATES} candidate commands")
        if not (np.isfinite(self.expected_error_mm) and self.expected_error_mm > 0):
            raise InputError(f"--expected-error {self.expected_error_mm}: the machine's mean uncompensated error, mm > 0")
        if not 1 <= self.validation_run <= MAX_POINTS:
            raise InputError(f"--validation {self.validation_run}: 1 .. {MAX_POINTS} validation commands")
        if self.seed < 0:
            raise InputError(f"--seed {self.seed}: a whole number >= 0")
        for option, v in (("--tool-radius-mm", self.tool_radius_mm), ("--target-clearance-mm", self.target_clearance_mm)):
            if not (np.isfinite(v) and v >= 0):
                raise InputError(f"{option} {v}: a length in mm >= 0")
        for option, v in (("--rapid-mm-min", self.rapid_mm_min), ("--rapid-deg-min", self.rapid_deg_min)):
            if v is not None and not (np.isfinite(v) and v > 0):
                raise InputError(f"{option} {v}: a rapid speed > 0")

    def check_model(self, machine: Machine, n_parameters: int) -> None:
        """The planned rows can determine the model: at least as many equations as unknowns."""
        rows = self.n_points * len(self.tools_mm) + self.repeat_points * self.repeat_times
        eq = 3 * rows if self.noise is None or self.noise.instrument != "range" else rows
        if n_parameters + 6 > eq:
            raise InputError(f"--order {self.order}: the {self.model} model of {machine.name} has {n_parameters + 6} "
                             f"unknowns, but {self.n_points} commands x {len(self.tools_mm)} holders give {eq} "
                             "equations; plan more --points or a lower --order")


@dataclass
class PlanScore:
    """How well a set of planned rows determines the model: ``log_det`` of the normal
    matrix, the gauge-line (T_offset) uncertainty [m], how many counted terms end below
    10 % of their prior sigma, the predicted validation error and the move time [s]."""

    label: str
    rows: int
    commands: int
    log_det: float
    t_offset_sigma: float
    well_determined: int
    counted: int
    predicted: PredictedError
    travel_s: float

    def line(self) -> str:
        p = self.predicted
        return (f"  {self.label:<28s} {self.commands:6d} {self.rows:6d} {self.log_det:10.1f} "
                f"{self.t_offset_sigma * MM_PER_M:9.4f} {self.well_determined:5d}/{self.counted:<5d} "
                f"{p.model_mean * MM_PER_M:9.4f} {p.model_max * MM_PER_M:9.4f} {p.measured_mean * MM_PER_M:9.4f} "
                f"{self.travel_s / 60:8.1f}")

    @staticmethod
    def header() -> list[str]:
        return [f"  {'plan':<28s} {'cmds':>6s} {'rows':>6s} {'log det N':>10s} {'σ T_off':>9s} {'<10% prior':>11s} "
                f"{'model mean':>9s} {'model max':>9s} {'valid mean':>9s} {'moves min':>8s}",
                f"  {'':<28s} {'':>6s} {'':>6s} {'':>10s} {'mm':>9s} {'':>11s} {'mm':>9s} {'mm':>9s} {'mm':>9s}"]


@dataclass
class Plan:
    """A planned campaign (SI inside): ``template`` (rows in measurement order),
    ``commands`` (the chosen commands, first-holder order), ``candidates`` and why
    each was removed (``removed``: '' kept, 'zone' outside the measurement zone never
    happens, 'exclusion', 'collision' (the holder runs into the machine's geometry),
    'sight'), ``sight_by`` (the solid that blocked it or that the holder runs into),
    ``tracker`` (3,) [m] (``tracker_side``: the side of the workspace a default tracker
    stands on, "" when given), ``score`` of the plan, ``information`` the linearised
    problem; ``nests`` {id: (3,) [m], workpiece frame} read at the commands,
    ``without_nests`` the score of the same commands without them and ``bare`` the
    problem without them (None on a plan without nests); ``warnings``: what makes the plan doubtful, each with its fix
    (:mod:`~vecpin.planning.planchecks`); ``validation_template``: the rows of the
    validation run (first holder, in a short order, table nests where seen)."""

    machine: Machine
    settings: PlanSettings
    template: PlanTemplate
    commands: np.ndarray
    candidates: np.ndarray
    removed: np.ndarray
    sight_by: np.ndarray
    tracker: np.ndarray
    tracker_given: bool
    steps: np.ndarray
    score: PlanScore
    information: Information
    covariance: np.ndarray
    travel_random_s: float
    geometry: str
    box: tuple[np.ndarray, np.ndarray]
    validation: np.ndarray
    nests: dict[str, np.ndarray] = field(default_factory=dict)
    without_nests: PlanScore | None = None
    bare: Information | None = None
    tracker_side: str = ""
    warnings: list[str] = field(default_factory=list)
    validation_template: PlanTemplate | None = None
    placement: Placement | None = None

    @property
    def tools(self) -> np.ndarray:
        return np.array(self.settings.tools_mm, float) * M_PER_MM

    def counts(self) -> dict[str, int]:
        return {"candidates": len(self.candidates), "exclusion": int((self.removed == "exclusion").sum()),
                "collision": int((self.removed == "collision").sum()), "sight": int((self.removed == "sight").sum()),
                "kept": int((self.removed == "").sum())}


def default_candidates(n_points: int) -> int:
    """Candidates a plan of ``n_points`` commands chooses from: 10 per command (at least
    2,000), but beyond 10,000 candidates 3 per command: 10,000 commands of an order-6
    model from 30,000 candidates take under a minute and 0.8 GB (100,000 take 2.2 min)."""
    return max(2000, min(10 * n_points, max(10_000, 3 * n_points)))


def quantise(machine: Machine, q: np.ndarray, resolution: float = 1e-3) -> np.ndarray:
    """Commands [m, rad] on the NC grid: ``resolution`` mm on linear, deg on rotary axes."""
    return machine.to_si(np.round(machine.to_user(q) / resolution) * resolution)


def candidate_commands(machine: Machine, n: int, lower: np.ndarray, upper: np.ndarray, seed: int = 0) -> np.ndarray:
    """n scrambled-Halton commands in [lower, upper] [m, rad], on the NC grid and inside."""
    u = qmc.Halton(machine.n_axes, seed=seed).random(n)
    q = quantise(machine, lower + u * (upper - lower))
    return np.clip(q, lower, upper)


def _spread(q: np.ndarray, k: int, speed: np.ndarray) -> np.ndarray:
    """k indices of q spread over the axis space (farthest-point sampling in move time)."""
    chosen = [0]
    d = route.move_times(q, q[0], speed)
    for _ in range(1, min(k, len(q))):
        j = int(np.argmax(d))
        chosen.append(j)
        d = np.minimum(d, route.move_times(q, q[j], speed))
    return np.array(chosen)


@one_blas_thread
def make_plan(machine: Machine, settings: PlanSettings | None = None,
              progress: Callable[[str], None] | None = None) -> Plan:
    """Plan a campaign for ``machine`` (see the module text)."""
    s = settings or PlanSettings()
    s.check()
    for z in s.exclude:
        check_zone_axes(machine, z, "--exclude")
    if s.zone:
        check_zone_axes(machine, s.zone, "--zone")
    nests = s.nest_places(machine)  # checked before any work
    say = progress or (lambda msg: None)
    noise = s.noise or NoiseModel.default(machine, "spherical")
    tools = np.array(s.tools_mm, float) * M_PER_MM
    if s.tracker_mm is None:
        tracker, azimuth = default_tracker_placement(machine)
        side = side_name(azimuth)
    else:
        tracker, side = np.asarray(s.tracker_mm, float) * M_PER_MM, ""
    steps = route.approach_steps(machine, s.approach_mm, s.approach_deg)
    lo, hi = clip_to_zone(machine, s.zone)
    alo, ahi = route.approach_margin(machine, s.approach, steps)
    lo, hi = np.maximum(lo, alo), np.minimum(hi, ahi)
    if np.any(hi <= lo):
        raise InputError("the measurement zone leaves no room for the approach moves: widen --zone or shorten "
                         "--approach-mm/--approach-deg")
    speed = route.axis_speeds(machine, s.rapid_mm_min, s.rapid_deg_min)

    n_cand = s.candidates or default_candidates(s.n_points)
    say(f"{n_cand} candidate commands (scrambled Halton, seed {s.seed})")
    cand = candidate_commands(machine, n_cand, lo, hi, s.seed)
    removed = np.full(len(cand), "", dtype=object)
    removed[inside(machine, cand, s.exclude)] = "exclusion"
    sight_by = np.full(len(cand), "", dtype=object)
    geometry = "not tested"
    if s.sight:
        sl = SightLine(machine, tracker, geometry=s.geometry, tool_radius=s.tool_radius_mm * M_PER_MM,
                       target_clearance=s.target_clearance_mm * M_PER_MM)
        geometry = sl.geometry
        inside_solids = sl.inside_fixed()
        if inside_solids:
            raise InputError(f"--tracker: the tracker position lies inside the machine's geometry "
                             f"({', '.join(inside_solids)}); place it where it can stand")
        test = np.flatnonzero(removed == "")
        say(f"collisions and line of sight for {len(test)} commands x {len(tools)} holder lengths ({geometry} geometry)")
        for L in tools:  # the holder in the machine's geometry: a collision, not a sight loss
            hit = sl.collisions(cand[test], L)
            new = (hit != "") & (sight_by[test] == "")
            sight_by[test[new]] = hit[new]
        removed[sight_by != ""] = "collision"
        test = np.flatnonzero(removed == "")
        for L in tools:
            res = sl.check(cand[test], L)
            hit = res.blocked & (sight_by[test] == "")
            sight_by[test[hit]] = res.by[hit]
        removed[(sight_by != "") & (removed == "")] = "sight"
    placement = None
    if s.place_nests and s.sight and len(nests) >= 3 and not s.nest_mm:
        say("table nests and tracker stations that see the table across its travel")
        placement = place_nests(machine, tracker, len(nests), tools[0], seed=s.seed, geometry=s.geometry,
                                tool_radius=s.tool_radius_mm * M_PER_MM, target_clearance=s.target_clearance_mm * M_PER_MM)
        nests = placement.nests
    nest_seen = np.ones((len(cand), len(nests)), bool)
    if s.sight and nests:
        test = np.flatnonzero(removed == "")
        say(f"line of sight for {len(test)} commands x {len(nests)} table nests")
        for k, p_wp in enumerate(nests.values()):
            nest_seen[test, k] = ~sl.check_nests(cand[test], p_wp, tools[0]).blocked
    ok = np.flatnonzero(removed == "")
    if len(ok) < s.n_points:
        raise InputError(f"only {len(ok)} of {len(cand)} candidate commands survive the exclusion zones, the "
                         f"collisions ({int((removed == 'collision').sum())}) and the line of sight; ask for fewer "
                         "--points, more --candidates, or move the tracker")

    model = make_model(s.model, machine, s.order, basis=s.basis)
    s.check_model(machine, model.n_parameters)
    say(f"{s.model} model of order {s.order}: {model.n_parameters + 6} parameters; judging redundancy")
    info = Information(model, noise, tracker, tools, nests=nests)
    if s.method == "doptimal":
        say(f"whitened Jacobian of {len(ok)} candidates" + (f" with {len(nests)} table nests" if nests else ""))
        pick, _ = greedy_d_optimal(info.kept_rows(cand[ok], nest_seen[ok]), s.n_points, progress=say)
    else:
        pick = np.random.default_rng(s.seed).choice(len(ok), s.n_points, replace=False)
    chosen = cand[ok[pick]]
    chosen_seen = nest_seen[ok[pick]]

    say("ordering the points")
    order = route.order_points(chosen, speed)
    chosen, chosen_seen = chosen[order], chosen_seen[order]
    rng = np.random.default_rng(s.seed + 1)
    passes_q, passes_t, passes_k = [], [], []
    rep_q = chosen[_spread(chosen, s.repeat_points, speed)] if s.repeat_points else np.zeros((0, machine.n_axes))
    seqs = [rep_q[rng.permutation(len(rep_q))] for _ in range(s.repeat_times)] if s.repeat_points else []
    half = (len(seqs) + 1) // 2
    for sq in seqs[:half]:
        passes_q.append(sq)
        passes_t.append(np.full(len(sq), tools[0]))
        passes_k.append(np.full(len(sq), -1))
    for k, L in enumerate(tools):
        passes_q.append(chosen if k % 2 == 0 else chosen[::-1])
        passes_t.append(np.full(len(chosen), L))
        passes_k.append(np.arange(len(chosen)) if k == 0 else np.full(len(chosen), -1))
    for sq in seqs[half:]:
        passes_q.append(sq)
        passes_t.append(np.full(len(sq), tools[0]))
        passes_k.append(np.full(len(sq), -1))
    q_cmd = np.vstack(passes_q)
    t_cmd = np.concatenate(passes_t)
    idx, sign = route.approach_rows(q_cmd, s.approach)
    approach = np.repeat(sign[:, None], machine.n_axes, axis=1) if s.approach != "none" else None
    template = with_nest_rows(q_cmd[idx], t_cmd[idx], approach, np.concatenate(passes_k)[idx], chosen_seen, nests)

    say("predicted uncertainty")
    vq = validation_commands(machine, s.validation_points, *clip_to_zone(machine, s.zone), seed=s.seed + 7)
    vq = vq[~inside(machine, vq, s.exclude)]
    score, cov = score_rows(info, template, vq, tools[0], f"this plan ({s.method})",
                            travel_s=_moves(template, steps, speed), commands=len(chosen))
    if nests:  # the same commands without the nests: what a tool-tip-only campaign would give
        say("predicted uncertainty without the table nests")
        bare = Information(model, noise, tracker, tools)
        tips = template.take(template.tool_rows)
        without, _ = score_rows(bare, tips, vq, tools[0], "the same without nests", travel_s=score.travel_s,
                                commands=len(chosen))
    else:
        bare, without = info, None
    shuffled = chosen[np.random.default_rng(s.seed + 2).permutation(len(chosen))]
    t_random = route.travel_time(np.vstack([shuffled] * len(tools)), speed)
    say("validation run")
    run = validation_run(machine, s, lo, hi, tools[0], sl if s.sight else None, nests, speed)
    plan = Plan(machine, s, template, chosen, cand, removed, sight_by, tracker, s.tracker_mm is not None, steps,
                score, info, cov, t_random, geometry, (lo, hi), vq, nests, without, bare, side)
    plan.validation_template, plan.placement = run, placement
    plan.warnings = plan_warnings(plan)
    return plan


def validation_run(machine: Machine, s: PlanSettings, lo: np.ndarray, hi: np.ndarray, tool: float,
                   sl: SightLine | None, nests: dict[str, np.ndarray], speed: np.ndarray) -> PlanTemplate:
    """The validation run's template: ``s.validation_run`` quasi-random commands inside
    [lo, hi] (the measurement zone, room for the approach), outside the exclusion zones,
    free of collisions and in sight with the holder ``tool`` [m] (as the plan's
    commands), on the NC grid, in a short order; each read with that holder and at the
    table nests the tracker sees there."""
    cand = quantise(machine, validation_commands(machine, 8 * s.validation_run, lo, hi, seed=s.seed + 11))
    cand = np.clip(cand, lo, hi)
    cand = cand[~inside(machine, cand, s.exclude)]
    if sl is not None:
        cand = cand[(sl.collisions(cand, tool) == "") & ~sl.check(cand, tool).blocked]
    if len(cand) < s.validation_run:
        raise InputError(f"--validation {s.validation_run}: only {len(cand)} validation commands are free and in sight "
                         "inside the measurement zone; ask for fewer or move the tracker")
    q = cand[:s.validation_run]
    q = q[route.order_points(q, speed)]
    seen = np.ones((len(q), len(nests)), bool)
    if sl is not None:
        for k, p_wp in enumerate(nests.values()):
            seen[:, k] = ~sl.check_nests(q, p_wp, tool).blocked
    idx, sign = route.approach_rows(q, s.approach)
    approach = np.repeat(sign[:, None], machine.n_axes, axis=1) if s.approach != "none" else None
    return with_nest_rows(q[idx], np.full(len(idx), tool), approach, idx, seen, nests)


def with_nest_rows(q: np.ndarray, tool: np.ndarray, approach: np.ndarray | None, command: np.ndarray,
                   seen: np.ndarray, nests: dict[str, np.ndarray]) -> PlanTemplate:
    """The template of tool-tip rows (q (N,n) [m, rad], tool (N,) [m], approach) with a
    reading of every nest the tracker sees after each row of the first holder:
    ``command`` (N,) index of the row's command into ``seen`` (C,K), -1 on rows without
    nest readings (other holders, repeated points)."""
    K = len(nests)
    if not K:
        return PlanTemplate(np.arange(1, len(q) + 1), q, tool, approach, "plan")
    read = np.where(command[:, None] >= 0, seen[np.maximum(command, 0)], False)  # (N, K)
    count = 1 + read.sum(axis=1)
    src = np.repeat(np.arange(len(q)), count)                  # the tool row each template row belongs to
    first = np.r_[0, np.cumsum(count)[:-1]]
    is_nest = np.ones(len(src), bool)
    is_nest[first] = False
    ids = np.array(list(nests), dtype=object)
    which = np.nonzero(read)[1]                                 # nest index of each nest row, row-major
    instrument = np.where(is_nest, "nest", "tracker").astype(object)
    target = np.full(len(src), "", dtype=object)
    target[is_nest] = ids[which]
    pos = np.full((len(src), 3), np.nan)
    pos[is_nest] = np.array(list(nests.values()))[which]
    return PlanTemplate(np.arange(1, len(src) + 1), q[src], tool[src], None if approach is None else approach[src],
                        "plan", instrument, target, pos)


def _moves(template: PlanTemplate, steps: np.ndarray, speed: np.ndarray) -> float:
    """Move time [s] of the rows in order, through each row's approach position (nest
    readings are taken at the dwell of the row before them: no move)."""
    template = template.take(template.tool_rows)
    q = template.q
    if template.approach is None:
        return route.travel_time(q, speed)
    pre = q - template.approach * steps
    path = np.empty((2 * len(q), q.shape[1]))
    path[0::2], path[1::2] = pre, q
    return route.travel_time(path, speed)


def score_rows(info: Information, template: PlanTemplate, validation: np.ndarray, validation_tool: float,
               label: str, travel_s: float = float("nan"), commands: int | None = None) -> tuple[PlanScore, np.ndarray]:
    """Score the rows of ``template`` (tool-tip and nest readings) with ``info``: the
    covariance and the predicted error at ``validation`` commands with ``validation_tool``
    [m] (the posterior: a term no row sees keeps its prior)."""
    q, tool = template.q, template.tool
    n = len(q)
    instrument = template.instrument if template.instrument is not None else np.full(n, "tracker", dtype=object)
    target = template.target if template.target is not None else np.full(n, "", dtype=object)
    W = info.compact_rows(q, tool, instrument, target)
    cov = info.covariance(W)
    sd = np.sqrt(np.diag(cov))
    kept = info.keep.copy()
    kept[:6] = False  # E_0 belongs to the set-up, not the machine
    well = int(np.sum(sd[kept] < 0.1 * info.sigma[kept]))
    pred = info.predicted_errors(info.posterior(W), validation, validation_tool)
    n_cmd = commands if commands is not None else len(np.unique(np.round(q, 9), axis=0))
    return PlanScore(label, len(q), n_cmd, info.log_det(W), float(sd[6]), well, int(kept.sum()), pred, travel_s), cov


def compare(plan: Plan, others: list[tuple[str, PlanTemplate]]) -> list[PlanScore]:
    """Scores of other plans (label, template) judged with ``plan``'s model, noise, tracker
    and validation commands, after ``plan``'s own score."""
    speed = route.axis_speeds(plan.machine, plan.settings.rapid_mm_min, plan.settings.rapid_deg_min)
    out = [plan.score]
    for label, t in others:
        try:
            sc, _ = score_rows(plan.information, t, plan.validation, float(plan.tools[0]), label,
                               travel_s=_moves(t, plan.steps, speed))
        except InputError as exc:  # another plan's nests: judged only with this plan's nests
            raise InputError(f"--compare {label}: {exc}; compare plans with the same --nests/--nest") from None
        out.append(sc)
    return out
