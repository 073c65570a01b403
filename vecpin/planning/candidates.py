"""The candidate commands of a plan: a scrambled Halton set over the problem's box in
axis space, on the NC grid (0.001 mm, 0.001 deg), less those in an exclusion zone ("CA"),
those where a target holder runs into the machine's geometry (collisions) or cannot get
there without (:mod:`~vecpin.planning.approaches`) and those the
tracker cannot see with every holder ("LoS"); with the table nests the tracker sees at
each."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.planning.approaches import free_commands, planning_retract
from vecpin.planning.problem import PlanProblem
from vecpin.planning.sightline import SightLine
from vecpin.planning.zones import inside
from vecpin.units import M_PER_MM
from vecpin.models.recorded import scrambled_halton   # scipy's qmc.Halton, without scipy.stats


def default_candidates(n_commands: int) -> int:
    """Candidates a plan of ``n_commands`` commands chooses from: 10 per command (at least
    2,000), but beyond 10,000 candidates 3 per command: the whole plan of 10,000 commands
    of an order-6 model from 30,000 candidates takes under a minute on a head machine, and
    on a table machine, its nests read at every command, under a minute up to
    :data:`~vecpin.planning.problem.TABLE_MINUTE_POINTS` commands (``benchmarks/bench_planning.py``)."""
    return max(2000, min(10 * n_commands, max(10_000, 3 * n_commands)))


def quantise(machine: Machine, q: np.ndarray, resolution: float = 1e-3) -> np.ndarray:
    """Commands [m, rad] on the NC grid: ``resolution`` mm on linear, deg on rotary axes."""
    return machine.to_si(np.round(machine.to_user(q) / resolution) * resolution)


def candidate_commands(machine: Machine, n: int, lower: np.ndarray, upper: np.ndarray, seed: int = 0) -> np.ndarray:
    """n scrambled-Halton commands in [lower, upper] [m, rad], on the NC grid and inside."""
    u = scrambled_halton(machine.n_axes, n, seed=seed)
    q = quantise(machine, lower + u * (upper - lower))
    return np.clip(q, lower, upper)


@dataclass
class Candidates:
    """The candidate commands ``q`` (N, n) [m, rad] and why each was removed
    (``removed``, see :class:`Plan`; ``sight_by`` the solid that blocked it), the
    ``seen`` (N, K) table nests the tracker sees at each, the ``geometry`` tested and the
    line of sight ``sight`` (None when not tested)."""

    q: np.ndarray
    removed: np.ndarray
    sight_by: np.ndarray
    seen: np.ndarray
    geometry: str
    sight: SightLine | None

    @property
    def kept(self) -> np.ndarray:
        return np.flatnonzero(self.removed == "")


def screen_candidates(problem: PlanProblem, say: Callable[[str], None]) -> Candidates:
    """Scrambled-Halton candidates in the problem's box, less those in an exclusion zone,
    those where a holder runs into the machine's geometry and those the tracker cannot
    see with every holder; refuses when fewer than the planned commands are left."""
    s, machine = problem.settings, problem.machine
    n_cand = s.candidates or default_candidates(s.n_commands)
    say(f"{n_cand} candidate commands (scrambled Halton, seed {s.seed})")
    cand = candidate_commands(machine, n_cand, problem.lo, problem.hi, s.seed)
    removed = np.full(len(cand), "", dtype=object)
    removed[inside(machine, cand, s.exclude)] = "exclusion"
    out = Candidates(cand, removed, np.full(len(cand), "", dtype=object), np.ones((len(cand), len(problem.nests)), bool),
                     "not tested", None)
    if s.sight:
        _sight_and_collisions(problem, out, say)
    ok = out.kept
    if len(ok) < s.n_commands:
        raise InputError(f"only {len(ok)} of {len(cand)} candidate commands survive the exclusion zones, the "
                         f"collisions ({int((removed == 'collision').sum())}) and the line of sight; ask for fewer "
                         "`n_commands`, more `candidates`, or move the tracker")
    return out


def _sight_and_collisions(problem: PlanProblem, c: Candidates, say: Callable[[str], None]) -> None:
    """Mark in ``c`` the candidates where a holder runs into the machine's geometry
    ('collision'), then those out of the tracker's sight with any holder ('sight'), and
    which table nests the tracker sees at the candidates left (first holder)."""
    s, tools = problem.settings, problem.tools
    sl = SightLine(problem.machine, problem.tracker, geometry=s.geometry, tool_radius=s.tool_radius_mm * M_PER_MM,
                   target_clearance=s.target_clearance_mm * M_PER_MM)
    c.sight, c.geometry = sl, sl.geometry
    inside_solids = sl.inside_fixed()
    if inside_solids:
        raise InputError(f"`tracker_mm`: the tracker position lies inside the machine's geometry "
                         f"({', '.join(inside_solids)}); place it where it can stand")
    test = c.kept
    say(f"collisions and line of sight for {len(test)} commands x {len(tools)} holder lengths ({c.geometry} geometry)")
    for L in tools:  # the holder in the machine's geometry: a collision, not a sight loss
        hit = sl.collisions(c.q[test], L)
        new = (hit != "") & (c.sight_by[test] == "")
        c.sight_by[test[new]] = hit[new]
    c.removed[c.sight_by != ""] = "collision"
    test = c.kept
    for L in tools:
        res = sl.check(c.q[test], L)
        hit = res.blocked & (c.sight_by[test] == "")
        c.sight_by[test[hit]] = res.by[hit]
    c.removed[(c.sight_by != "") & (c.removed == "")] = "sight"
    rt, test = planning_retract(problem.machine), c.kept
    for L in tools:  # every approach to it collides: dropped as a collision, the solid named "(approach)"
        why = free_commands(problem.machine, sl, c.q[test], L, s.approach, problem.steps, rt)
        new = (why != "") & (c.sight_by[test] == "")
        c.sight_by[test[new]] = [f"{w} (approach)" for w in why[new]]
    c.removed[(c.sight_by != "") & (c.removed == "")] = "collision"
    if problem.nests:
        test = c.kept
        say(f"line of sight for {len(test)} commands x {len(problem.nests)} table nests")
        for k, p_wp in enumerate(problem.nests.values()):
            c.seen[test, k] = ~sl.check_nests(c.q[test], p_wp, tools[0]).blocked
