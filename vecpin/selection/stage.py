"""Each model kind's search after the common stage (:mod:`vecpin.selection.choice`; the
kinds run side by side): its best refined axis by axis, then along the axes the campaign
measured over part of their travel, the bases chosen again on those axes' held-out ends,
so that the model keeps only what extrapolates where it will be used beyond the span
measured.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.measurement.campaign import Campaign
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


def kind_stage(own: Search, prob: Problem, camp: Campaign, options, ends, per_axis: bool, say) -> KindStage:
    """The search of one kind after the common stage (the kinds run side by side): its
    best refined axis by axis (``per_axis``: every kind, a spline may turn the ranking),
    then with ``ends`` its bases along them chosen on their held-out ends
    (:func:`along_ends`)."""
    stage = KindStage(own)
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
