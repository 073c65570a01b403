"""Each model kind's search after the common stage (:mod:`vecpin.selection.choice`; the
kinds run side by side): its best refined axis by axis, then along the axes the campaign
measured over part of their travel, the bases chosen again on those axes' held-out ends,
so that the model keeps only what extrapolates where it will be used beyond the span
measured. The kinds after the first are screened before they are searched (:func:`screen_kind`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vecpin.measurement.campaign import Campaign
from vecpin.models import MODELS
from vecpin.selection.search import Candidate, Problem, Search, one_standard_error


@dataclass
class KindStage:
    """One kind's search after the common stage: its own :class:`Search`, and along
    partly measured axes its choice by the one-SE rule (``start``), that choice with its
    bases chosen on the held-out ends (``end``) and what changed."""

    search: Search
    start: Candidate | None = None
    end: Candidate | None = None
    changed: tuple = ()
    common: float = math.nan   # the lowest held-out mean [mm] of its common-basis candidates, before refinement
    note: str = ""             # a kind after the first screened at its bases (screen_kind): what was found


def kind_stage(own: Search, prob: Problem, camp: Campaign, options, ends, per_axis: bool, say) -> KindStage:
    """The search of one kind after the common stage (the kinds run side by side): its
    best refined axis by axis (``per_axis``: every kind, a spline may turn the ranking),
    then with ``ends`` its bases along them chosen on their held-out ends
    (:func:`along_ends`)."""
    stage = KindStage(own, common=min((c.mean for c in own.cands), default=math.nan))
    cur = own.refine(prob, options) if per_axis else None
    if cur is not None:
        say(f"refined axis by axis: {cur.label()}")
    if ends and per_axis and own.cands:
        stage.start = one_standard_error(own.cands, min(own.cands, key=lambda c: c.mean), prob.size,
                                         prob.size_bound)[0]
        stage.end, stage.changed = along_ends(own, prob, camp, stage.start, options, ends)
    return stage


def along_ends(search: Search, prob: Problem, camp: Campaign, start: Candidate, options,
               ends) -> tuple[Candidate, tuple[str, ...]]:
    """The basis of every axis measured over part of its travel (``ends``, chain order)
    chosen again on the held-out ends of every such axis (:func:`on_every_end`), the
    other axes as reached so far: among that axis' options with no more terms than it has
    (effective terms, :meth:`Problem.size`), the fewest model terms within one paired
    standard error of the lowest held-out mean on those rows (:func:`one_standard_error`),
    so that along an axis the model is used beyond, it keeps only what extrapolates there,
    and no axis keeps a function that spoils the extrapolation along another. (The
    candidate reached, what changed, 'axis old -> new'.)"""
    chosen, changed = start, []
    for i in ends:
        trials = [chosen.axes[:i] + (o,) + chosen.axes[i + 1:] for o in options[i]
                  if o.size <= chosen.axes[i].size]
        new = [t for t in trials if (prob.kind, t) not in search.scored and (prob.kind, t) not in search.left_out
               and search.supported(prob, t)]
        for c in (prob.candidates(new) if len(new) > 1 else [prob.candidate(t) for t in new]):
            search.add(c)
        pool = [search.scored[(prob.kind, t)] for t in trials if (prob.kind, t) in search.scored]
        sizes = prob.sizes(pool + [chosen])
        pool = [c.axes for c, n in zip(pool, sizes) if round(n) <= round(sizes[-1])]   # a smoothing counts too
        if len(pool) < 2:   # the axis' basis alone (a constant): nothing to choose
            continue
        judged = on_every_end(prob, camp, pool, ends)
        low = min(judged, key=lambda c: c.mean)
        size = lambda c: prob.size(search.scored[(prob.kind, c.axes)])   # noqa: E731 (cached on the scored one)
        pick = search.scored[(prob.kind, one_standard_error(judged, low, size)[0].axes)]
        if pick is not chosen:
            changed.append(f"{prob.machine.axes[i].name} {chosen.axes[i].label()} -> {pick.axes[i].label()}")
            chosen = pick
    return chosen, tuple(changed)


def on_every_end(prob: Problem, camp: Campaign, choices: list[tuple], ends) -> list[Candidate]:
    """``choices`` judged on the held-out ends of every axis in ``ends``, each axis' two
    ends estimated without any of their own commands (:meth:`Problem.on_ends`): one
    candidate per choice, its held-out distances those of every axis' ends in turn (a
    function of one axis moves the predictions where another is extrapolated, too)."""
    parts = [(p.candidates(choices) if len(choices) > 1 else [p.candidate(t) for t in choices])
             for p in (prob.on_ends(j, camp) for j in ends)]
    return [Candidate(prob.kind, t, parts[0][k].n_terms, np.concatenate([part[k].heldout for part in parts]),
                      spans=prob.spans)
            for k, t in enumerate(choices)]


def screen_choices(first: KindStage, prob: Problem) -> tuple[list[tuple], list[list]]:
    """(choices, options per axis): the bases of the first kind's choice by the one-SE rule (``prob``: its
    problem; along partly measured axes also after its ends) and of its lowest held-out mean, where another kind
    is screened (:func:`screen_kind`)."""
    lowest = min(first.search.cands, key=lambda c: c.mean)
    start = first.start or one_standard_error(first.search.cands, lowest, prob.size, prob.size_bound)[0]
    picks = [c for c in (first.end, start, lowest) if c is not None]
    choices = list(dict.fromkeys(c.axes for c in picks))
    return choices, [list(dict.fromkeys(t[i] for t in choices)) for i in range(len(choices[0]))]


def screen_kind(prob: Problem, choices: list[tuple], first: KindStage, limit: float) -> tuple[Search, bool, str]:
    """Another kind judged at the first kind's bases (``choices``, :func:`screen_choices`; ``prob``: its problem
    with those bases only) before its own search, the same folds and noise: (its search of them, whether it
    joins, what was found). It joins where one of them comes within one paired standard error of the first
    kind's lowest held-out mean plus what refining its bases gained the first kind (its common-basis lowest
    less its lowest): a kind that the same refinement would not bring within one standard error of the lowest
    cannot be chosen by the one-SE rule, and its search is left out. (The axis-perturbation model's terms at a
    set of bases are nearly those of the 6-DoF model along the axes they perturb; on the 19 campaigns of
    ``benchmarks/bench_fit_speed.py`` it was never chosen, its search a third of a default fit.)"""
    search = Search()
    search.limit = limit
    for choice in choices:
        search.score(prob, choice)
    if not search.cands:   # none it can determine at those bases: its own search decides
        name = MODELS[prob.kind].display_name
        return search, True, f"{name}: no candidate at the first kind's bases; searched in full"
    lowest = min(first.search.cands, key=lambda c: c.mean)
    gain = max(first.common - lowest.mean, 0.0) if math.isfinite(first.common) else 0.0
    n = lowest.heldout.size
    margins = []
    for c in search.cands:
        delta = c.heldout - lowest.heldout
        se = float(np.std(delta, ddof=1) / math.sqrt(n)) if n > 1 else 0.0
        margins.append(delta.mean() - se - gain)
    best = search.cands[int(np.argmin(margins))]
    joins = min(margins) <= 0
    name, first_name = (MODELS[k].display_name for k in (prob.kind, lowest.kind))
    text = (f"{name} at {first_name}'s bases: {best.label()} {best.mean:.4f} mm held-out mean against {first_name}'s "
            f"lowest {lowest.mean:.4f} mm" + ("; searched in full" if joins else
                                               f", {min(margins):.4f} mm beyond one standard error and the "
                                               f"{gain:.4f} mm its refinement gained: its own bases not searched"))
    return search, joins, text


def other_kinds(kinds, first: KindStage, problems: dict, limit: float, scale: float, say, problem, staged) -> list:
    """The stages of the kinds after the first, each screened at the first kind's bases (``problem(kind,
    options)``: its problem with those bases only; :func:`screen_kind`): its search in
    full (``staged``) where it could be chosen, else the candidates screened (no choice of its own)."""
    out = []
    if not kinds:   # every kind searched in full already (the first supports no candidate)
        return out
    choices, options = screen_choices(first, problems[next(iter(problems))])
    for kind in kinds:
        problems[kind] = rescaled(problem(kind, options), scale)
        own, joins, text = screen_kind(problems[kind], choices, first, limit)
        say(text)
        if joins:
            del problems[kind]
        out.append(staged(kind) if joins else KindStage(own, note=text))
    return out


def rescaled(prob: Problem, scale: float) -> Problem:
    """``prob`` with every noise sigma times ``scale``."""
    if scale != 1.0:
        prob.problem.rescale(scale)
    return prob


def ends_choice(stages: list[KindStage], problems: dict) -> tuple[Candidate, float, str, Candidate]:
    """The choice when axes were measured over part of their travel: of every kind's
    choice with its bases along those axes chosen on their held-out ends
    (:func:`kind_stage`), the one-SE rule on every held-out row: (chosen, its standard
    error [mm], the reason, the chosen kind's choice before its ends were judged)."""
    results = [own.end for own in stages]
    low = min(results, key=lambda c: c.mean)
    chosen, se, _ = one_standard_error(results, low, lambda c: problems[c.kind].size(c))
    stage = next(own for own in stages if own.end is chosen)
    changed = stage.changed
    reason = (f"each kind's fewest model terms within one standard error of its lowest held-out mean, its bases along "
              f"the axes measured over part of their travel then chosen on their held-out ends by the same rule"
              f"{' (' + ', '.join(changed) + ')' if changed else ''}; of the kinds, "
              + ("the lowest held-out mean" if chosen is low else
                 f"the fewest model terms within one standard error ({se:.4f} mm) of the lowest ({low.mean:.4f} mm)"))
    return chosen, se, reason, stage.start
