"""Choosing which compensation tables to use under controller limits (Paper II).

Pitch tables (input = output) and the gauge-line offset are always used; the
question is which k of the n(n-1) cross tables to add, subject to constraints: at
most k tables, output axes that cannot be compensated, no circular pairs (ij with
ji), and other forbidden combinations declared per controller.

Three methods, one interface, one figure of merit:

* :func:`exact_search` - every admissible combination. The table problem is linear in
  the table coefficients around the model (:class:`~vecpin.compensation.TableProblem`),
  so with the normal equations precomputed and the always-used block eliminated once
  (Schur complement), each combination is one small solve, batched; the best
  combinations are then re-solved on the full model and discretised.
* :func:`genetic_search` - Paper II §3: order-free reproduction, rank-weighted parent
  selection (eq. 12), mutation, 50 generations or 20 without improvement.
* :func:`impact_heuristic` - Paper II Table 4: rank tables by how much the error grows
  when each alone is left out of the full set; take the top k that fit.

All three score a combination by the linearised RMS volumetric error; the exact search
therefore never loses to the others on that score, and its finalists are judged on the
mean volumetric error of the discretised tables on the model, as the paper reports.
"""
from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy import linalg

from vecpin.compensation.functions import TableProblem, compensated_errors, pitch_names, ridged
from vecpin.compensation.tables import reversed_names, table_name
from vecpin.errors import VecpinError
from vecpin.units import MM_PER_M


@dataclass(frozen=True)
class Constraints:
    """What the controller allows. Table names are output then input axis ('zx',
    :func:`~vecpin.compensation.tables.table_name`)."""

    max_tables: int
    forbid_output: tuple[str, ...] = ()
    forbid_input: tuple[str, ...] = ()
    no_circular: bool = False
    forbidden_pairs: tuple[tuple[str, str], ...] = ()

    def candidates(self, axis_names: list[str]) -> list[str]:
        out_forbidden = {a.lower() for a in self.forbid_output}
        in_forbidden = {a.lower() for a in self.forbid_input}
        return [table_name(o, i) for o in axis_names for i in axis_names
                if o != i and o.lower() not in out_forbidden and i.lower() not in in_forbidden]

    def compatible(self, a: str, b: str) -> bool:
        if self.no_circular and b in reversed_names(a):
            return False
        return (a, b) not in self.forbidden_pairs and (b, a) not in self.forbidden_pairs

    def admissible(self, combo) -> bool:
        combo = list(combo)
        return len(set(combo)) == len(combo) and all(self.compatible(a, b) for a, b in itertools.combinations(combo, 2))


@dataclass
class Selection:
    """The outcome of one method: chosen cross tables, scores and cost of finding them.
    ``rms_mm`` is the linearised score; ``mean_mm``/``max_mm`` the discretised tables
    re-solved on the model over the problem's pseudo-measurements."""

    method: str
    tables: list[str]
    rms_mm: float
    mean_mm: float = float("nan")
    max_mm: float = float("nan")
    seconds: float = 0.0
    evaluations: int = 0
    history: list[float] = field(default_factory=list)   # GA: best score per generation (mm)
    ranking: list[tuple[str, float]] = field(default_factory=list)  # heuristic: table, mean mm without it
    finalists: list[tuple[list[str], float, float]] = field(default_factory=list)  # exact: tables, rms, mean


class Scorer:
    """Linearised RMS volumetric error of any set of cross tables (plus pitch and dT),
    with the always-used block eliminated once."""

    def __init__(self, problem: TableProblem, ridge: float | None = None):
        self.problem = problem
        G = ridged(problem.G, problem.ridge if ridge is None else ridge, problem.ridge_base)
        g = problem.g
        a = problem.columns(pitch_names(problem.machine))
        Gaa = G[np.ix_(a, a)]
        cf = linalg.cho_factor(Gaa)
        W_Ga = linalg.cho_solve(cf, G[a, :])                     # Gaa^-1 G_a.
        self.S = G - G[:, a] @ W_Ga                               # Schur complement (rows/cols outside a)
        self.h = g - G[:, a] @ linalg.cho_solve(cf, g[a])
        self.base = problem.e0e0 - g[a] @ linalg.cho_solve(cf, g[a])
        self.rows = len(problem.q)
        self.evaluations = 0

    def block(self, names) -> np.ndarray:
        return np.concatenate([self.problem.blocks[n] for n in names]) if len(names) else np.zeros(0, int)

    def score(self, names) -> float:
        """Linearised RMS volumetric error [m]."""
        self.evaluations += 1
        b = self.block(list(names))
        if b.size == 0:
            return math.sqrt(max(self.base, 0.0) / self.rows)
        x = linalg.solve(self.S[np.ix_(b, b)], self.h[b], assume_a="pos")
        return math.sqrt(max(self.base - self.h[b] @ x, 0.0) / self.rows)

    def score_many(self, combos: np.ndarray, candidates: list[str], chunk: int = 4096) -> np.ndarray:
        """Scores of many combinations (C, k) of candidate indices, batched."""
        blocks = [self.problem.blocks[n] for n in candidates]
        size = {len(b) for b in blocks}
        if len(size) != 1:
            return np.array([self.score([candidates[j] for j in c]) for c in combos])
        cols = np.stack(blocks)  # (n_cand, s)
        # one Cholesky factor of [[S_b, h_b], [h_b', base + lift]] per combination: its last
        # diagonal element squared is base + lift - h_b' S_b^-1 h_b, the residual plus the lift
        # (the lift keeps the bordered matrix positive definite when the residual is ~0)
        lift = 1e-9 * max(self.base, np.finfo(float).tiny)
        n = len(self.h)
        bordered = np.zeros((n + 1, n + 1))
        bordered[:n, :n], bordered[:n, n], bordered[n, :n], bordered[n, n] = self.S, self.h, self.h, self.base + lift
        out = np.empty(len(combos))
        for s0 in range(0, len(combos), chunk):
            part = combos[s0:s0 + chunk]
            idx = np.concatenate([cols[part].reshape(len(part), -1), np.full((len(part), 1), n)], axis=1)
            L = np.linalg.cholesky(bordered[idx[:, :, None], idx[:, None, :]])
            out[s0:s0 + chunk] = np.sqrt(np.maximum(L[:, -1, -1] ** 2 - lift, 0.0) / self.rows)
        self.evaluations += len(combos)
        return out


def finalise(problem: TableProblem, names: list[str], n_points: int = 1024):
    """Re-solve tables ``names`` (plus pitch) on the full model, discretise, and score
    the mean/max volumetric error [mm] over the pseudo-measurements."""
    tables = problem.solve(pitch_names(problem.machine) + list(names)).discretise(n_points)
    err = compensated_errors(problem.actual, problem.machine, tables, problem.q, problem.L)
    d = np.linalg.norm(err, axis=1) * MM_PER_M
    return tables, float(d.mean()), float(d.max())


def admissible_combinations(candidates: list[str], constraints: Constraints, k: int) -> np.ndarray:
    """Every admissible combination of ``k`` candidate indices, (C, k), in lexicographic order:
    all combinations, less those holding a pair the constraints forbid (checked pair of
    columns by pair of columns over the whole array)."""
    n = len(candidates)
    flat = np.fromiter(itertools.chain.from_iterable(itertools.combinations(range(n), k)), dtype=np.intp)
    combos = flat.reshape(-1, k)
    clash = np.array([[i != j and not constraints.compatible(a, b) for j, b in enumerate(candidates)]
                      for i, a in enumerate(candidates)], dtype=bool).reshape(n, n)
    keep = np.ones(len(combos), dtype=bool)
    for i, j in itertools.combinations(range(k), 2):
        keep &= ~clash[combos[:, i], combos[:, j]]
    return combos[keep]


def exact_search(problem: TableProblem, constraints: Constraints, finalists: int = 10,
                 n_points: int = 1024) -> Selection:
    """Best admissible combination of ``constraints.max_tables`` cross tables."""
    t0 = time.perf_counter()
    cand = constraints.candidates(problem.machine.axis_names)
    k = min(constraints.max_tables, len(cand))
    scorer = Scorer(problem)
    combos = admissible_combinations(cand, constraints, k)
    if len(combos) == 0:
        raise VecpinError(f"no admissible set of {k} tables under these constraints")
    scores = scorer.score_many(combos, cand)
    order = np.argsort(scores)[:finalists]
    best, fin = None, []
    for j in order:
        names = [cand[i] for i in combos[j]]
        _, mean, mx = finalise(problem, names, n_points)
        fin.append((names, float(scores[j] * MM_PER_M), mean))
        if best is None or mean < best[2]:
            best = (names, float(scores[j] * MM_PER_M), mean, mx)
    return Selection("exact", best[0], best[1], best[2], best[3], time.perf_counter() - t0,
                     scorer.evaluations, finalists=fin)


def genetic_search(problem: TableProblem, constraints: Constraints, population: int = 8, mutation: float = 0.2,
                   keep: float = 0.5, generations: int = 50, unchanged: int = 20, seed: int = 0,
                   n_points: int = 1024, scorer: Scorer | None = None) -> Selection:
    """Paper II's genetic algorithm (§3, Fig. 2-3)."""
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    cand = constraints.candidates(problem.machine.axis_names)
    k = min(constraints.max_tables, len(cand))
    scorer = scorer or Scorer(problem)
    cache: dict[frozenset, float] = {}

    def fitness(ch) -> float:
        key = frozenset(ch)
        if key not in cache:
            cache[key] = scorer.score(sorted(key))
        return cache[key]

    def random_chromosome() -> list[str]:
        for _ in range(1000):
            ch = []
            for g in rng.permutation(cand):
                if all(constraints.compatible(g, h) for h in ch):
                    ch.append(str(g))
                if len(ch) == k:
                    return ch
        raise VecpinError(f"no admissible set of {k} tables under these constraints")

    def replace_gene(ch: list[str], pos: int) -> None:
        others = ch[:pos] + ch[pos + 1:]
        options = [g for g in cand if g not in ch and all(constraints.compatible(g, h) for h in others)]
        if options:
            ch[pos] = str(rng.choice(options))

    def reproduce(p1: list[str], p2: list[str]) -> list[str]:
        child = list(p1)
        n_swap = int(rng.integers(1, k)) if k > 1 else 1
        for pos in rng.choice(k, n_swap, replace=False):
            donors = [g for g in p2 if g not in child]
            rng.shuffle(donors)
            for g in donors:  # a gene already in the child is never duplicated
                others = child[:pos] + child[pos + 1:]
                if all(constraints.compatible(g, h) for h in others):
                    child[pos] = g
                    break
        return child

    pop = [random_chromosome() for _ in range(population)]
    n_keep = max(2, int(round(keep * population)))
    weights = (n_keep - np.arange(1, n_keep + 1) + 1) / np.arange(1, n_keep + 1).sum()  # eq. 12
    history, best, stale = [], math.inf, 0
    for _gen in range(generations):
        pop.sort(key=fitness)
        current = fitness(pop[0])
        history.append(current * MM_PER_M)
        if current < best - 1e-15:
            best, stale = current, 0
        else:
            stale += 1
            if stale >= unchanged:
                break
        parents = pop[:n_keep]
        children = []
        while len(children) < population - n_keep:
            i, j = rng.choice(n_keep, 2, replace=False, p=weights)
            child = reproduce(parents[i], parents[j])
            for pos in range(k):
                if rng.random() < mutation:
                    replace_gene(child, pos)
            children.append(child)
        pop = parents + children
    pop.sort(key=fitness)
    names = sorted(pop[0])
    _, mean, mx = finalise(problem, names, n_points)
    return Selection("genetic", names, fitness(pop[0]) * MM_PER_M, mean, mx, time.perf_counter() - t0,
                     len(cache), history=history)


def impact_heuristic(problem: TableProblem, constraints: Constraints, n_points: int = 1024) -> Selection:
    """Paper II Table 4: leave each cross table out of the full set in turn; the larger
    the error without it, the more it matters; take the top k that fit."""
    t0 = time.perf_counter()
    m = problem.machine
    every = [table_name(o, i) for o in m.axis_names for i in m.axis_names if o != i]
    cand = set(constraints.candidates(m.axis_names))
    ranking = []
    for name in every:
        x = problem.solve_linear(pitch_names(m) + [n for n in every if n != name])
        e = (problem.e0 + problem.A @ x).reshape(-1, 3)
        ranking.append((name, float(np.linalg.norm(e, axis=1).mean() * MM_PER_M)))
    ranking.sort(key=lambda r: -r[1])
    chosen: list[str] = []
    for name, _ in ranking:
        if name in cand and all(constraints.compatible(name, c) for c in chosen):
            chosen.append(name)
        if len(chosen) == constraints.max_tables:
            break
    scorer = Scorer(problem)
    _, mean, mx = finalise(problem, chosen, n_points)
    return Selection("heuristic", sorted(chosen), scorer.score(chosen) * MM_PER_M, mean, mx, time.perf_counter() - t0,
                     len(every) + 1, ranking=ranking)
