"""Choosing tables under controller limits (Paper II): exact search against brute
force (the branch and bound against scoring every combination), the GA and the
heuristic against the exact optimum, constraints honoured."""
import itertools

import numpy as np
import pytest

from vecpin.compensation.functions import pitch_names
from vecpin.compensation.tableproblem import TableProblem
from vecpin.compensation.frame import model_as_actual
from vecpin.compensation.tables import cross_table_axes, table_name, table_names
from vecpin.models import make_model
from vecpin.measurement.noise import NoiseModel
from vecpin.simulation.simulate import simulate
from vecpin.compensation.selection import (BranchAndBound, Constraints, Scorer, admissible_combinations, exact_search,
                                           genetic_search, impact_heuristic)

TOOLS = [0.21488, 0.31286]


@pytest.fixture(scope="module")
def problem(machines):
    flow = machines["flow_xyzcb"]
    sim = simulate(flow, seed=0, mean_error_mm=0.65)
    model = make_model("6dof", flow, 6).fit(sim.campaign, NoiseModel.default(flow, "spherical"))
    # Paper II: pseudo-measurements at the identification commands, both tools
    return TableProblem(model_as_actual(model), flow, sim.campaign.q[:295], TOOLS, order=6)


def test_schur_scores_equal_direct_solves(problem):
    scorer = Scorer(problem)
    cand = Constraints(6).candidates(problem.machine.axis_names)
    rng = np.random.default_rng(0)
    combos = np.array([rng.choice(len(cand), 4, replace=False) for _ in range(15)])
    batched = scorer.score_many(combos, cand)
    for c, b in zip(combos, batched):
        names = [cand[j] for j in c]
        assert b == pytest.approx(problem.cost(pitch_names(problem.machine) + names), rel=1e-6)
        assert scorer.score(names) == pytest.approx(b, rel=1e-9)


def test_exact_search_is_the_brute_force_optimum(problem):
    """Brute force through the plain (non-Schur) solve on a reduced candidate list."""
    cons = Constraints(3, forbid_output=("B", "C"))
    sel = exact_search(problem, cons, finalists=1)
    cand = cons.candidates(problem.machine.axis_names)
    assert len(cand) == 12 and sel.evaluations == 220
    best = min(itertools.combinations(cand, 3), key=lambda c: problem.cost(pitch_names(problem.machine) + list(c)))
    assert sorted(sel.tables) == sorted(best)


@pytest.mark.parametrize("cons", [Constraints(5), Constraints(6, no_circular=True),
                                  Constraints(5, forbid_output=("X",), forbidden_pairs=(("yz", "zb"),))])
def test_branch_and_bound_keeps_what_scoring_every_combination_keeps(problem, cons):
    """The ten best combinations and their scores, to the last bit, with a fraction scored (the
    large case, Fanuc's 6 of production_xyzbaw's 30 tables: tests/controller_cases.py)."""
    cand = cons.candidates(problem.machine.axis_names)
    scorer = Scorer(problem)
    search = BranchAndBound(scorer, cand, cons, cons.max_tables, 10)
    combos, scores = search.run()
    every = admissible_combinations(cand, cons, cons.max_tables, cross_table_axes(problem.machine.axis_names))
    all_scores = scorer.score_many(every, cand)
    best = np.argsort(all_scores, kind="stable")[:10]
    assert np.array_equal(combos, every[best]) and np.array_equal(scores, all_scores[best])
    assert search.scored < len(every) / 3


@pytest.mark.parametrize("cons", [Constraints(6), Constraints(6, no_circular=True), Constraints(6, forbid_output=("X",))])
def test_exact_never_loses_to_the_ga_or_the_heuristic(problem, cons):
    axes = cross_table_axes(problem.machine.axis_names)
    ex = exact_search(problem, cons)
    assert cons.admissible(ex.tables, axes) and len(ex.tables) == 6
    scorer = Scorer(problem)
    best_rms = min(r for _, r, _ in ex.finalists)
    for seed in range(3):
        ga = genetic_search(problem, cons, seed=seed, scorer=scorer)
        assert cons.admissible(ga.tables, axes) and len(ga.tables) == 6
        assert best_rms <= ga.rms_mm + 1e-9
        assert ex.mean_mm <= ga.mean_mm + 1e-9
        assert all(b <= a + 1e-12 for a, b in zip(ga.history, ga.history[1:]))  # elitist: never worse
        assert len(ga.history) <= 50
    h = impact_heuristic(problem, cons)
    assert cons.admissible(h.tables, axes)
    assert best_rms <= h.rms_mm + 1e-9 and ex.mean_mm <= h.mean_mm + 1e-9


def test_constraints_are_honoured(problem):
    cons = Constraints(6, forbid_output=("X",), no_circular=True, forbidden_pairs=(("yz", "zb"),))
    for sel in (exact_search(problem, cons, finalists=3), genetic_search(problem, cons, seed=1), impact_heuristic(problem, cons)):
        assert not any(t[0] == "x" for t in sel.tables)
        assert not any(t[::-1] in sel.tables for t in sel.tables)
        assert not ("yz" in sel.tables and "zb" in sel.tables)


def test_no_circular_forbids_exactly_the_swapped_pair_when_axis_names_hold_the_separator():
    """Axes whose names hold '_' (table names 'x_1_x_c' = X_1 from X_C): a name can be split
    into other axes ('x_1_x' from 'c' reads back as 'c_x_1_x', the table of C_X from 1_X);
    the constraint goes by the axes the tables were made from and forbids exactly the
    swapped pairs, each one once."""
    names = ["x_1", "c_x", "x_c", "1_x"]
    table_names(names)   # no two tables share a name
    axes = cross_table_axes(names)
    cons = Constraints(2, no_circular=True)
    cand = cons.candidates(names)
    assert len(cand) == 12 and axes["x_1_x_c"] == ("x_1", "x_c")
    forbidden = {frozenset((a, b)) for a, b in itertools.combinations(cand, 2) if not cons.compatible(a, b, axes)}
    swapped = {frozenset((table_name(o, i), table_name(i, o))) for o, i in itertools.combinations(names, 2)}
    assert forbidden == swapped and len(swapped) == 6
    assert cons.compatible("x_1_x_c", "c_x_1_x", axes) and not cons.compatible("x_1_x_c", "x_c_x_1", axes)
    assert len(admissible_combinations(cand, cons, 2, axes)) == 66 - 6
    assert Constraints(2).compatible("x_1_x_c", "x_c_x_1", axes)


def test_constraints_cost_accuracy_and_paper_shape(problem):
    """Paper II Table 7 shape: no-circular costs little or nothing, forbidding X outputs costs more."""
    free = exact_search(problem, Constraints(6)).mean_mm
    circ = exact_search(problem, Constraints(6, no_circular=True)).mean_mm
    no_x = exact_search(problem, Constraints(6, forbid_output=("X",))).mean_mm
    assert free <= circ + 1e-9 <= no_x + 1e-9
    assert no_x > 1.3 * free


def test_heuristic_ranking_is_table_four(problem):
    h = impact_heuristic(problem, Constraints(6))
    assert len(h.ranking) == 20
    errs = [e for _, e in h.ranking]
    assert errs == sorted(errs, reverse=True)
    assert set(h.tables) <= {n for n, _ in h.ranking[:6]}


def test_the_best_sets_are_judged_as_the_controller_holds_them(problem, tmp_path):
    """Issue 39: Fanuc holds a straightness table at its moving axis' pitch points only, here 3
    per axis (a profile limit): the set best as planned is not the best as written (by 0.5 %
    on this model in its reference frame; by 2 % in the frame the fit settled in). With the
    controller's ``hold`` (its files written and read back) the search ranks its finalists as
    held, and the set it chooses is the best of them as the independent applier
    (tests/controller_appliers.py, from the parameter manual) applies their files."""
    from controller_appliers import fanuc_corrections
    from controller_cases import controller_commands

    from vecpin.compensation.report import compensated_errors
    from vecpin.export import fanuc
    from vecpin.export.common import ExportJob
    from vecpin.export.profile import ControllerProfile
    from vecpin.fileio import OutputSet
    m = problem.machine
    ref = {a.name: (float(a.to_user(a.upper)) - 5.0 if a.kind == "linear" else 0.0) for a in m.axes}
    prof = ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1,
                                        "limits": {"pitch_points_per_axis": 3},
                                        "axes": {a: {"number": k + 1, "reference_position": ref[a],
                                                     "detection_unit": 0.001} for k, a in enumerate(m.axis_names)}})
    limits = fanuc.FORMAT.limits_for(prof)
    seen = []
    sel = exact_search(problem, Constraints(4, forbid_output=("B", "C")), finalists=5,
                       hold=lambda ts: seen.append(ts) or limits.hold(ts, m))

    def applied(k, tables):  # mean error [mm] of the files as the applier applies them, on the problem's rows
        folder = tmp_path / str(k)
        with OutputSet(folder) as out:
            fanuc.write(ExportJob(tables, m, prof, limits, out))
        qc = controller_commands(m, problem.q, fanuc_corrections(folder, m.axis_names, ref, m.to_user(problem.q)),
                                 tables.gauge_offset_change)
        return np.linalg.norm(compensated_errors(problem.actual, m, qc, problem.q, problem.L), axis=1).mean() * 1e3

    written = [applied(k, ts) for k, ts in enumerate(seen)]
    np.testing.assert_allclose(sel.held, written, rtol=2e-3)        # as held = as the control applies the files
    names = [n for n, _, _ in sel.finalists]
    planned_best = int(np.argmin([mean for _, _, mean in sel.finalists]))
    assert sel.tables == names[int(np.argmin(written))] != names[planned_best]
    assert min(written) < written[planned_best]
