"""Choosing which compensation tables to use under controller limits (Paper II).

Pitch tables (input = output) and the gauge-line offset are always used; the
question is which k of the n(n-1) cross tables to add, subject to constraints: at
most k tables, output axes that cannot be compensated, no circular pairs (ij with
ji), and other forbidden combinations declared per controller.

Three methods, one interface, one figure of merit:

* :func:`exact_search` - the best admissible combinations, exactly. The table problem is
  linear in the table coefficients around the model (:class:`~vecpin.compensation.tableproblem.TableProblem`),
  so with the normal equations precomputed and the always-used block eliminated once
  (Schur complement), each combination is one small solve, batched: every combination
  is scored when they are few; when they are many, a branch and bound
  (:class:`BranchAndBound`) proves most of them worse without scoring them (6 of 30
  tables: about 2,300 of 593,775 scored, the same choice). The best combinations are then
  re-solved on the full model and discretised, and, for a controller that resamples the
  tables on its own grid, judged as it will hold them (``hold``: its files written and
  read back), so that the set written is the best as written.
* :func:`genetic_search` - Paper II §3: order-free reproduction, rank-weighted parent
  selection (eq. 12), mutation, 50 generations or 20 without improvement.
* :func:`impact_heuristic` - Paper II Table 4: rank tables by how much the error grows
  when each alone is left out of the full set; take the top k that fit.

All three score a combination by the linearised RMS volumetric error; the exact search
therefore never loses to the others on that score, and its finalists are judged on the
mean volumetric error of the discretised tables on the model, as the paper reports.
"""
from __future__ import annotations

import heapq
import itertools
import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy import linalg

from vecpin.compensation.functions import pitch_names
from vecpin.compensation.report import compensated_errors
from vecpin.compensation.tableproblem import TableProblem, ridged
from vecpin.compensation.tables import cross_table_axes
from vecpin.errors import ControllerLimitError, VecpinError
from vecpin.units import MM_PER_M


@dataclass(frozen=True)
class Constraints:
    """What the controller allows. Table names are output then input axis ('zx',
    :func:`~vecpin.compensation.tables.table_name`); whether two tables may go together
    is decided on their (output, input) axis pairs, ``axes`` (name -> pair, from
    :func:`~vecpin.compensation.tables.cross_table_axes` of the machine's axis names)."""

    max_tables: int
    forbid_output: tuple[str, ...] = ()
    forbid_input: tuple[str, ...] = ()
    no_circular: bool = False
    forbidden_pairs: tuple[tuple[str, str], ...] = ()

    def candidates(self, axis_names: list[str]) -> list[str]:
        """The cross tables the output and input axes allowed may make, output axis by output axis."""
        out_forbidden = {a.lower() for a in self.forbid_output}
        in_forbidden = {a.lower() for a in self.forbid_input}
        return [name for name, (o, i) in cross_table_axes(axis_names).items()
                if o.lower() not in out_forbidden and i.lower() not in in_forbidden]

    def compatible(self, a: str, b: str, axes: dict[str, tuple[str, str]]) -> bool:
        """Whether tables ``a`` and ``b`` may go together: not the same pair of axes swapped
        (``no_circular``, on their (output, input) pairs in ``axes``), nor a forbidden pair."""
        if self.no_circular and axes[a] == axes[b][::-1]:
            return False
        return (a, b) not in self.forbidden_pairs and (b, a) not in self.forbidden_pairs

    def admissible(self, combo, axes: dict[str, tuple[str, str]]) -> bool:
        """Whether the tables ``combo`` may all go together (``axes`` as in :meth:`compatible`)."""
        combo = list(combo)
        return len(set(combo)) == len(combo) and all(self.compatible(a, b, axes)
                                                     for a, b in itertools.combinations(combo, 2))


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
    held: list[float] = field(default_factory=list)  # exact with ``hold``: each finalist's mean [mm] as held


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
        """Scores [m] of many combinations (C, k) of candidate indices, batched: one Cholesky
        factor of a bordered matrix per combination. Blocks smaller than the largest are padded
        with columns of their own that nothing couples to (unit diagonal, zero right-hand
        side): they leave every factor's other entries as they are, so every score too."""
        blocks = [self.problem.blocks[n] for n in candidates]
        size = max(len(b) for b in blocks)
        n, n_pad = len(self.h), sum(size - len(b) for b in blocks)
        pads = iter(range(n, n + n_pad))
        cols = np.array([np.concatenate([b, [next(pads) for _ in range(size - len(b))]]) for b in blocks], dtype=np.intp)
        # one Cholesky factor of [[S_b, h_b], [h_b', base + lift]] per combination: its last
        # diagonal element squared is base + lift - h_b' S_b^-1 h_b, the residual plus the lift
        # (the lift keeps the bordered matrix positive definite when the residual is ~0)
        lift = 1e-9 * max(self.base, np.finfo(float).tiny)
        last = n + n_pad
        bordered = np.zeros((last + 1, last + 1))
        bordered[:n, :n], bordered[:n, last], bordered[last, :n] = self.S, self.h, self.h
        bordered[last, last] = self.base + lift
        bordered[n:last, n:last] = np.eye(n_pad)
        out = np.empty(len(combos))
        for s0 in range(0, len(combos), chunk):
            part = combos[s0:s0 + chunk]
            idx = np.concatenate([cols[part].reshape(len(part), -1), np.full((len(part), 1), last)], axis=1)
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


def admissible_combinations(candidates: list[str], constraints: Constraints, k: int,
                            axes: dict[str, tuple[str, str]]) -> np.ndarray:
    """Every admissible combination of ``k`` candidate indices, (C, k), in lexicographic order:
    all combinations, less those holding a pair the constraints forbid (checked pair of
    columns by pair of columns over the whole array; ``axes``: each table's (output, input)
    pair, :func:`~vecpin.compensation.tables.cross_table_axes`)."""
    n = len(candidates)
    flat = np.fromiter(itertools.chain.from_iterable(itertools.combinations(range(n), k)), dtype=np.intp)
    combos = flat.reshape(-1, k)
    clash = np.array([[i != j and not constraints.compatible(a, b, axes) for j, b in enumerate(candidates)]
                      for i, a in enumerate(candidates)], dtype=bool).reshape(n, n)
    keep = np.ones(len(combos), dtype=bool)
    for i, j in itertools.combinations(range(k), 2):
        keep &= ~clash[combos[:, i], combos[:, j]]
    return combos[keep]


#: up to this many combinations of k of the candidates (before the constraints) the exact search
#: scores every one in one batch; above it, it branches and bounds (:class:`BranchAndBound`)
EXHAUSTIVE_UP_TO = 20_000


def _spans(sizes) -> list[np.ndarray]:
    """Local column indices of consecutive blocks of ``sizes`` columns."""
    ends = np.cumsum(sizes)
    return [np.arange(e - z, e) for z, e in zip(sizes, ends)]


def _own_gains(St: np.ndarray, ht: np.ndarray, spans: list[np.ndarray]) -> np.ndarray:
    """Each block's own gain h_j' S_jj^-1 h_j [m^2] (the residual it removes alone), batched
    over blocks of one size."""
    out = np.empty(len(spans))
    for size in {len(sp) for sp in spans}:
        which = [i for i, sp in enumerate(spans) if len(sp) == size]
        idx = np.stack([spans[i] for i in which])
        b = ht[idx]
        x = np.linalg.solve(St[idx[:, :, None], idx[:, None, :]], b[:, :, None])[:, :, 0]
        out[which] = np.einsum("ij,ij->i", b, x)
    return out


def _suffix_gains(St: np.ndarray, ht: np.ndarray, spans: list[np.ndarray], order: np.ndarray) -> np.ndarray:
    """Gain [m^2] of the blocks ``order[p:]`` together, for every p: one Cholesky factor
    S = L L' with the blocks in the order ``order[::-1]``; with z = L^-1 h, the gain of the
    first m columns is the sum of their z^2 (a cumulative sum of non-negative terms, so
    the gains never grow with p, in floating point too)."""
    cols = np.concatenate([spans[i] for i in order[::-1]])
    L = np.linalg.cholesky(St[np.ix_(cols, cols)])
    z = linalg.solve_triangular(L, ht[cols], lower=True)
    ends = np.cumsum([len(spans[i]) for i in order[::-1]]) - 1
    return np.cumsum(z * z)[ends][::-1]


def _condition(St: np.ndarray, ht: np.ndarray, j: np.ndarray, rest: np.ndarray):
    """The normal equations over columns ``rest`` given that columns ``j`` are in the fit
    (their Schur complement) and the gain [m^2] of ``j``."""
    cf = linalg.cho_factor(St[np.ix_(j, j)])
    Srj = St[np.ix_(rest, j)]
    x = linalg.cho_solve(cf, ht[j])
    return St[np.ix_(rest, rest)] - Srj @ linalg.cho_solve(cf, Srj.T), ht[rest] - Srj @ x, float(ht[j] @ x)


class BranchAndBound:
    """The ``keep`` best admissible combinations of ``k`` candidate tables by the linearised
    score, the same as scoring every combination (:func:`admissible_combinations`), found
    by an exact branch and bound.

    A node is a partial set P with the list C of tables its completions may take (each
    compatible with P), the normal equations conditioned on P and its residual r(P).
    Child p takes C[p] and leaves out C[:p], C ordered by each table's own gain given P
    (the promising ones first: good sets are found early). A least-squares fit never gets
    worse with more columns, so P + C[p:] - every table a completion of child p may take,
    and more - fits at least as well as any of those completions: its residual bounds
    them from below. One Cholesky factor (:func:`_suffix_gains`) gives that bound for
    every p. A child whose bound is above the keep-th best score found so far (plus a
    rounding margin) is left out with its whole subtree, and so are the children after
    it (their bounds only grow). The combinations kept are re-scored with
    :meth:`Scorer.score_many`, as the exhaustive search scores them."""

    def __init__(self, scorer: Scorer, candidates: list[str], constraints: Constraints, k: int, keep: int):
        self.scorer, self.candidates, self.constraints, self.k, self.keep = scorer, candidates, constraints, k, keep
        self.blocks = [scorer.problem.blocks[n] for n in candidates]
        self.axes = cross_table_axes(scorer.problem.machine.axis_names)  # table -> (output, input)
        self.margin = 1e-9 * max(scorer.base, np.finfo(float).tiny)   # [m^2]: bounds vs scores, rounding
        self.best: list[tuple[float, tuple[int, ...]]] = []             # heap of (-residual, combination)
        self.limit = math.inf  # [m^2] keep-th best residual so far plus the margin: above it, none is kept
        self.scored = 0       # combinations scored (leaves)
        self.nodes = 0        # partial sets branched on

    def offer(self, residuals: np.ndarray, combos: list[tuple[int, ...]]) -> None:
        """Keep the best combinations seen: twice ``keep``, so that near ties (within
        rounding) survive to the re-scoring."""
        worst = -self.best[0][0] if len(self.best) >= 2 * self.keep else math.inf
        for j in np.flatnonzero(residuals < worst):
            if len(self.best) < 2 * self.keep:
                heapq.heappush(self.best, (-float(residuals[j]), combos[j]))
            elif residuals[j] < -self.best[0][0]:
                heapq.heapreplace(self.best, (-float(residuals[j]), combos[j]))
        if len(self.best) >= self.keep:
            self.limit = sorted(-b for b, _ in self.best)[self.keep - 1] + self.margin

    def node(self, P: tuple[int, ...], r: float, C: list[int], St: np.ndarray, ht: np.ndarray) -> None:
        """Branch on the partial set ``P`` (residual ``r`` [m^2]) over the tables ``C``."""
        self.nodes += 1
        need = self.k - len(P)
        spans = _spans([len(self.blocks[c]) for c in C])
        gains = _own_gains(St, ht, spans)
        if need == 1:
            self.scored += len(C)
            self.offer(r - gains, [P + (c,) for c in C])
            return
        order = np.argsort(-gains, kind="stable")
        bounds = r - _suffix_gains(St, ht, spans, order)
        names = [self.candidates[c] for c in C]
        for p, i in enumerate(order):
            if len(order) - p - 1 < need - 1 or bounds[p] > self.limit:
                break
            rest = [q for q in order[p + 1:] if self.constraints.compatible(names[i], names[q], self.axes)]
            if len(rest) < need - 1:
                continue
            cols = np.concatenate([spans[q] for q in rest])
            St2, ht2, gain = _condition(St, ht, spans[i], cols)
            self.node(P + (C[i],), r - gain, [C[q] for q in rest], St2, ht2)

    def run(self) -> tuple[np.ndarray, np.ndarray]:
        """The ``keep`` best combinations (indices into the candidates, each ascending) and
        their scores [m], best first; empty when none is admissible."""
        cols = np.concatenate(self.blocks)
        self.node((), self.scorer.base, list(range(len(self.candidates))), self.scorer.S[np.ix_(cols, cols)],
                  self.scorer.h[cols])
        if not self.best:
            return np.zeros((0, self.k), dtype=np.intp), np.zeros(0)
        combos = np.array(sorted(tuple(sorted(c)) for _, c in self.best), dtype=np.intp)
        scores = self.scorer.score_many(combos, self.candidates)
        order = np.argsort(scores, kind="stable")[:self.keep]
        return combos[order], scores[order]


def held_mean(problem: TableProblem, tables, hold) -> float:
    """Mean volumetric error [mm] over the problem's pseudo-measurements of ``tables`` as
    the controller holds them (``hold(tables)``); inf when the controller cannot hold them
    (a :class:`~vecpin.errors.ControllerLimitError`: its grid or value range)."""
    try:
        held = hold(tables)
    except ControllerLimitError:
        return math.inf
    err = compensated_errors(problem.actual, problem.machine, held, problem.q, problem.L)
    return float(np.linalg.norm(err, axis=1).mean() * MM_PER_M)


def exact_search(problem: TableProblem, constraints: Constraints, finalists: int = 10,
                 n_points: int = 1024, hold=None) -> Selection:
    """Best admissible combination of ``constraints.max_tables`` cross tables: the
    ``finalists`` best by the linearised score (every combination scored in one batch up to
    :data:`EXHAUSTIVE_UP_TO` of them, else :class:`BranchAndBound`, which finds the same),
    re-solved on the model and discretised; the best of them by mean volumetric error,
    of the tables as the controller holds them when ``hold(tables)`` gives that (a
    controller that resamples them on its own grid: Fanuc), else as planned."""
    t0 = time.perf_counter()
    cand = constraints.candidates(problem.machine.axis_names)
    k = min(constraints.max_tables, len(cand))
    scorer = Scorer(problem)
    if math.comb(len(cand), k) <= EXHAUSTIVE_UP_TO:
        combos = admissible_combinations(cand, constraints, k, cross_table_axes(problem.machine.axis_names))
        scores = scorer.score_many(combos, cand) if len(combos) else np.zeros(0)
        scored = len(combos)
        order = np.argsort(scores)[:finalists]
        combos, scores = combos[order], scores[order]
    else:
        search = BranchAndBound(scorer, cand, constraints, k, finalists)
        combos, scores = search.run()
        scored = search.scored
    if len(combos) == 0:
        raise VecpinError(f"no admissible set of {k} tables under these constraints")
    best, fin, held = None, [], []
    for combo, score in zip(combos, scores):
        names = [cand[i] for i in combo]
        tables, mean, mx = finalise(problem, names, n_points)
        fin.append((names, float(score * MM_PER_M), mean))
        key = mean
        if hold is not None:
            held.append(held_mean(problem, tables, hold))
            key = (held[-1], mean)
        if best is None or key < best[4]:
            best = (names, float(score * MM_PER_M), mean, mx, key)
    return Selection("exact", best[0], best[1], best[2], best[3], time.perf_counter() - t0, scored, finalists=fin,
                     held=held)


def genetic_search(problem: TableProblem, constraints: Constraints, population: int = 8, mutation: float = 0.2,
                   keep: float = 0.5, generations: int = 50, unchanged: int = 20, seed: int = 0,
                   n_points: int = 1024, scorer: Scorer | None = None) -> Selection:
    """Paper II's genetic algorithm (§3, Fig. 2-3)."""
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    cand = constraints.candidates(problem.machine.axis_names)
    axes = cross_table_axes(problem.machine.axis_names)
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
                if all(constraints.compatible(g, h, axes) for h in ch):
                    ch.append(str(g))
                if len(ch) == k:
                    return ch
        raise VecpinError(f"no admissible set of {k} tables under these constraints")

    def replace_gene(ch: list[str], pos: int) -> None:
        others = ch[:pos] + ch[pos + 1:]
        options = [g for g in cand if g not in ch and all(constraints.compatible(g, h, axes) for h in others)]
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
                if all(constraints.compatible(g, h, axes) for h in others):
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
    axes = cross_table_axes(m.axis_names)
    every = list(axes)
    cand = set(constraints.candidates(m.axis_names))
    ranking = []
    for name in every:
        x = problem.solve_linear(pitch_names(m) + [n for n in every if n != name])
        e = (problem.e0 + problem.A @ x).reshape(-1, 3)
        ranking.append((name, float(np.linalg.norm(e, axis=1).mean() * MM_PER_M)))
    ranking.sort(key=lambda r: -r[1])
    chosen: list[str] = []
    for name, _ in ranking:
        if name in cand and all(constraints.compatible(name, c, axes) for c in chosen):
            chosen.append(name)
        if len(chosen) == constraints.max_tables:
            break
    scorer = Scorer(problem)
    _, mean, mx = finalise(problem, chosen, n_points)
    return Selection("heuristic", sorted(chosen), scorer.score(chosen) * MM_PER_M, mean, mx, time.perf_counter() - t0,
                     len(every) + 1, ranking=ranking)
