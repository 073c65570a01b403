"""A measurement plan in one call: candidates, exclusion zones and line of sight, the
D-optimal choice, the order and approach, the predicted uncertainty (Paper I Section 4,
Fig. 6; eq. 22 for repeated points).

0. The problem: the settings checked, the tracker and the table nests placed, the box the
   commands may take (:mod:`~vecpin.planning.problem`).
1. Candidates: a scrambled Halton set over the axis space (inside a measurement zone if
   one is given, and far enough from the limits for the approach move), on the NC grid
   (0.001 mm, 0.001 deg) (:mod:`~vecpin.planning.candidates`).
2. Removed: candidates in an exclusion zone ("CA"), in collision, and those the tracker
   cannot see with every target holder length ("LoS").
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
in the D-optimal choice and the prediction through the fit's one likelihood. Its
validation run reads the tool and each nest
:data:`~vecpin.planning.nests.VALIDATION_READS` times in a row at every command, the
machine standing still (``Plan.validation_reads``; the NC program and the run's time a
dwell per reading, no move between them), and their mean is judged.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from vecpin.errors import InputError
from vecpin.kinematics.axes import is_arm
from vecpin.kinematics.machine import Machine
from vecpin.measurement.plantemplate import PlanTemplate
from vecpin.planning import route
from vecpin.planning.armpose import arm_approach_signs, arm_clearance, check_arm_approach, screen_approaches
from vecpin.planning.approaches import free_commands, planning_retract, safe_template
from vecpin.planning.candidates import Candidates, quantise, screen_candidates
from vecpin.planning.doptimal import greedy_d_optimal
from vecpin.planning.information import Information, PredictedError, validation_commands
from vecpin.planning.planchecks import plan_warnings
from vecpin.planning.nestplacement import Placement, station_blocks
from vecpin.planning.nests import VALIDATION_READS
from vecpin.planning.problem import PlanProblem, PlanSettings, plan_problem, planned_model
from vecpin.planning.sightline import SightLine
from vecpin.planning.zones import clip_to_zone, inside
from vecpin.units import MM_PER_M, M_PER_MM
from vecpin.threads import one_blas_thread





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
    validation run (first holder, in a short order, table nests where seen), each point
    read ``validation_reads`` times in a row at its standstill."""

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
    validation_reads: int = 1

    @property
    def tools(self) -> np.ndarray:
        return np.array(self.settings.tools_mm, float) * M_PER_MM

    def counts(self) -> dict[str, int]:
        out = {"candidates": len(self.candidates), "exclusion": int((self.removed == "exclusion").sum()),
               "collision": int((self.removed == "collision").sum()), "sight": int((self.removed == "sight").sum()),
               "kept": int((self.removed == "").sum())}
        if is_arm(self.machine):  # an arm's approach along the tool axis (:mod:`~vecpin.planning.armpose`)
            out["approach"] = int((self.removed == "approach").sum())
        return out


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
    """Plan a campaign for ``machine`` (see the module text): the problem and its
    measurement set-up, the candidates and what removes them, the D-optimal choice, the
    measurement order, the predicted uncertainty and the validation run."""
    say = progress or (lambda msg: None)
    problem = plan_problem(machine, settings or PlanSettings())
    if is_arm(machine):
        check_arm_approach(problem.settings.approach, problem.settings.approach_mm)
    cands = screen_candidates(problem, say)
    if is_arm(machine):
        screen_arm(problem, cands, say)
    model = planned_model(machine, problem.settings)
    problem.settings.check_model(machine, model.n_parameters)
    say(f"{problem.settings.model} model of order {problem.settings.order}: {model.n_parameters + 6} parameters; "
        "judging redundancy")
    info = Information(model, problem.noise, problem.tracker, problem.tools, nests=problem.nests)
    chosen, chosen_seen = choose_commands(problem, info, cands, say)
    say("ordering the points")
    chosen, template = measurement_order(problem, chosen, chosen_seen)
    if problem.placement is not None:  # a second tracker station's block of rows, when one is proposed
        s = problem.settings
        template = station_blocks(machine, template, problem.placement, geometry=s.geometry,
                                  tool_radius=s.tool_radius_mm * M_PER_MM, target_clearance=s.target_clearance_mm * M_PER_MM)
    if not is_arm(machine):   # an arm's approach was screened along its tool axis (screen_arm)
        template = safe_template(machine, cands.sight, template, problem.steps, planning_retract(machine))
    return plan_result(problem, info, cands, chosen, template, say)


def screen_arm(problem: PlanProblem, c: Candidates, say: Callable[[str], None]) -> None:
    """Mark in ``c`` the candidates of an arm that cannot be approached along the tool
    axis ('approach'; ``sight_by`` says why: :func:`~vecpin.planning.armpose.screen_approaches`);
    refuses when fewer than the planned commands are left."""
    s = problem.settings
    ok = c.kept
    say(f"approach poses {s.approach_mm:g} mm back along the tool axis for {len(ok)} commands")
    sl = c.sight if c.sight is not None else SightLine(
        problem.machine, problem.tracker, geometry=s.geometry, tool_radius=s.tool_radius_mm * M_PER_MM,
        target_clearance=s.target_clearance_mm * M_PER_MM)
    why = screen_approaches(problem.machine, c.q[ok], arm_clearance(s), sl, problem.tools)
    c.sight_by[ok[why != ""]] = why[why != ""]
    c.removed[ok[why != ""]] = "approach"
    if len(c.kept) < s.n_commands:
        raise InputError(f"only {len(c.kept)} of {len(c.q)} candidate commands of the arm can be approached "
                         f"{s.approach_mm:g} mm along the tool axis and are free and in sight; ask for fewer "
                         "`n_commands`, more `candidates`, a shorter `approach_mm`, or move the tracker")


def choose_commands(problem: PlanProblem, info: Information, c: Candidates,
                    say: Callable[[str], None]) -> tuple[np.ndarray, np.ndarray]:
    """The planned commands (P, n) [m, rad] among the candidates left, greedy D-optimal on
    the whitened Jacobian ``info`` of their rows (tool tips and the nests seen) or at
    random, and the (P, K) nests the tracker sees at each."""
    s = problem.settings
    ok = c.kept
    if s.method == "doptimal":
        say(f"whitened Jacobian of {len(ok)} candidates"
            + (f" with {len(problem.nests)} table nests" if problem.nests else ""))
        pick, _ = greedy_d_optimal(info.kept_rows(c.q[ok], c.seen[ok]), s.n_commands, progress=say)
    else:
        pick = np.random.default_rng(s.seed).choice(len(ok), s.n_commands, replace=False)
    return c.q[ok[pick]], c.seen[ok[pick]]


def measurement_order(problem: PlanProblem, chosen: np.ndarray, seen: np.ndarray) -> tuple[np.ndarray, PlanTemplate]:
    """The chosen commands in a short tour and the campaign template: the repeated points
    (eq. 22) at the start, one pass per holder (every other pass reversed), the rest of the
    repeated points at the end, each row approached as the settings say, table nests read
    at the first holder's dwell."""
    s, tools, machine = problem.settings, problem.tools, problem.machine
    order = route.order_points(chosen, problem.speed)
    chosen, seen = chosen[order], seen[order]
    rng = np.random.default_rng(s.seed + 1)
    rep_q = chosen[_spread(chosen, s.repeat_points, problem.speed)] if s.repeat_points else np.zeros((0, machine.n_axes))
    seqs = [rep_q[rng.permutation(len(rep_q))] for _ in range(s.repeat_times)] if s.repeat_points else []
    half = (len(seqs) + 1) // 2
    passes = [(sq, tools[0], np.full(len(sq), -1)) for sq in seqs[:half]]
    passes += [(chosen if k % 2 == 0 else chosen[::-1], L,
                np.arange(len(chosen)) if k == 0 else np.full(len(chosen), -1)) for k, L in enumerate(tools)]
    passes += [(sq, tools[0], np.full(len(sq), -1)) for sq in seqs[half:]]
    q_cmd = np.vstack([q for q, _, _ in passes])
    t_cmd = np.concatenate([np.full(len(q), L) for q, L, _ in passes])
    command = np.concatenate([k for _, _, k in passes])
    idx, sign = route.approach_rows(q_cmd, s.approach)
    approach = np.repeat(sign[:, None], machine.n_axes, axis=1) if s.approach != "none" else None
    if approach is not None and is_arm(machine):  # each joint's direction from the pre-pose
        approach = arm_approach_signs(machine, q_cmd[idx], arm_clearance(s))
    return chosen, with_nest_rows(q_cmd[idx], t_cmd[idx], approach, command[idx], seen, problem.nests)


def plan_result(problem: PlanProblem, info: Information, c: Candidates, chosen: np.ndarray, template: PlanTemplate,
                say: Callable[[str], None]) -> Plan:
    """The plan with its predicted uncertainty (with and without the table nests), the
    move time of the same commands in random order, its validation run and its warnings."""
    s, machine, tools = problem.settings, problem.machine, problem.tools
    further = problem.placement.stations[1:] if problem.placement is not None else []
    if len(further) and np.any(template.stations != 0):  # the second set-up's pose unknowns counted
        info = info.with_stations(further)
    say("predicted uncertainty")
    vq = validation_commands(machine, s.validation_points, *clip_to_zone(machine, s.zone), seed=s.seed + 7)
    vq = vq[~inside(machine, vq, s.exclude)]
    score, cov = score_rows(info, template, vq, tools[0], f"this plan ({s.method})",
                            travel_s=_moves(template, problem.steps, problem.speed), commands=len(chosen))
    bare, without = info, None
    if problem.nests:  # the same commands without the nests: what a tool-tip-only campaign would give
        say("predicted uncertainty without the table nests")
        bare = Information(info.model, problem.noise, problem.tracker, tools, stations=info.stations)
        without, _ = score_rows(bare, template.take(template.tool_rows), vq, tools[0], "the same without nests",
                                travel_s=score.travel_s, commands=len(chosen))
    shuffled = chosen[np.random.default_rng(s.seed + 2).permutation(len(chosen))]
    t_random = route.travel_time(np.vstack([shuffled] * len(tools)), problem.speed)
    say("validation run")
    run = validation_run(machine, s, np.maximum(problem.lo, chosen.min(axis=0)),   # inside what the fit measures
                         np.minimum(problem.hi, chosen.max(axis=0)), tools[0], c.sight, problem.nests, problem.speed)
    plan = Plan(machine, s, template, chosen, c.q, c.removed, c.sight_by, problem.tracker, s.tracker_mm is not None,
                problem.steps, score, info, cov, t_random, c.geometry, (problem.lo, problem.hi), vq, problem.nests,
                without, bare, problem.tracker_side)
    plan.validation_template, plan.placement = run, problem.placement
    plan.validation_reads = VALIDATION_READS if problem.nests else 1
    plan.warnings = plan_warnings(plan)
    return plan


def validation_run(machine: Machine, s: PlanSettings, lo: np.ndarray, hi: np.ndarray, tool: float,
                   sl: SightLine | None, nests: dict[str, np.ndarray], speed: np.ndarray) -> PlanTemplate:
    """The validation run's template: ``s.n_validation`` quasi-random commands inside
    [lo, hi] (the measurement zone, room for the approach), outside the exclusion zones,
    free of collisions and in sight with the holder ``tool`` [m] (as the plan's
    commands), on the NC grid, in a short order; each read with that holder and at the
    table nests the tracker sees there, with nests every point
    :data:`~vecpin.planning.nests.VALIDATION_READS` times in a row (:func:`reread`)."""
    cand = quantise(machine, validation_commands(machine, 8 * s.n_validation, lo, hi, seed=s.seed + 11))
    cand = np.clip(cand, lo, hi)
    cand = cand[~inside(machine, cand, s.exclude)]
    if sl is not None:
        cand = cand[(sl.collisions(cand, tool) == "") & ~sl.check(cand, tool).blocked]
        if not is_arm(machine):   # the approach, free of the machine (an arm's is screened below)
            cand = cand[free_commands(machine, sl, cand, tool, s.approach, route.approach_steps(
                machine, s.approach_mm, s.approach_deg), planning_retract(machine)) == ""]
    if is_arm(machine):  # an arm's approach along the tool axis, reachable and free
        cand = cand[screen_approaches(machine, cand, arm_clearance(s), sl, np.array([tool])) == ""]
    if len(cand) < s.n_validation:
        raise InputError(f"`n_validation` {s.n_validation}: only {len(cand)} validation commands are free and in sight "
                         "inside the measurement zone; ask for fewer or move the tracker")
    q = cand[:s.n_validation]
    q = q[route.order_points(q, speed)]
    seen = np.ones((len(q), len(nests)), bool)
    if sl is not None:
        for k, p_wp in enumerate(nests.values()):
            seen[:, k] = ~sl.check_nests(q, p_wp, tool).blocked
    idx, sign = route.approach_rows(q, s.approach)
    approach = np.repeat(sign[:, None], machine.n_axes, axis=1) if s.approach != "none" else None
    if approach is not None and is_arm(machine):
        approach = arm_approach_signs(machine, q[idx], arm_clearance(s))
    rows = with_nest_rows(q[idx], np.full(len(idx), tool), approach, idx, seen, nests)
    if is_arm(machine):
        return reread(rows, VALIDATION_READS if nests else 1)
    steps = route.approach_steps(machine, s.approach_mm, s.approach_deg)
    return reread(safe_template(machine, sl, rows, steps, planning_retract(machine)), VALIDATION_READS if nests else 1)


def reread(template: PlanTemplate, reads: int) -> PlanTemplate:
    """``template`` with every row read ``reads`` times in a row (the tool, then each
    nest), the machine standing still: the further readings have no approach (0: no
    move); every row keeps a point number of its own, numbered on."""
    if reads == 1:
        return template
    out = template.take(np.repeat(np.arange(len(template)), reads))
    out.point = np.arange(1, len(out) + 1)
    if out.approach is not None:
        out.approach = out.approach.copy()
        out.approach[np.arange(len(out)) % reads != 0] = 0
    return out


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
    W = info.compact_rows(q, tool, instrument, target, template.stations)
    cov = info.covariance(W)
    sd = np.sqrt(np.diag(cov))
    kept = info.keep.copy()
    kept[:6] = False  # E_0 and the further stations' poses belong to the set-up, not the machine
    kept[len(info.names) - 6 * len(info.stations):] = False
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
            raise InputError(f"`compare_with` {label}: {exc}; compare plans with the same `nests`/`nest_mm`") from None
        out.append(sc)
    return out
