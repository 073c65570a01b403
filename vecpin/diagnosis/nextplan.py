"""What to measure next (:mod:`vecpin.planning.discriminate`): for the findings a
campaign cannot settle (an ambiguity group, an effect the backward elimination dropped),
the commands that tell the rival models apart, inside the campaign's measured range, or,
when nothing inside it tells them apart, over the travel and said to be extrapolation."""
from __future__ import annotations

from typing import Callable

import numpy as np

from vecpin.diagnosis.result import EffectScore
from vecpin.errors import VecpinError
from vecpin.identification.linearised import Linearised
from vecpin.measurement.campaign import Campaign
from vecpin.models.effects import Effect
from vecpin.planning.discriminate import discriminating_plan

SETTLES_CHI2 = 9.0  # a discriminating plan is offered when it separates the candidates by 3 sigma at least


def next_measurements(scores: list[EffectScore], accepted: list[Effect], cur_model, cur_lin: Linearised,
                       cur_eval: dict, base_fit, camp: Campaign, say: Callable[[str], None]) -> None:
    """What to measure next (:mod:`vecpin.planning.discriminate`): for every accepted
    effect of an ambiguity group, the commands that tell its members apart (each member
    fitted with the other accepted effects); for every effect dropped by the backward
    elimination, those that tell the final model from the model with it. Stored on the
    score as ``next_plan``; a rival model that cannot be fitted is left out with a note.
    A reading scatters about the right model as the final model's held-out rows do (their
    whitened chi2 per equation, at least the noise's)."""
    scatter = float(np.sum(cur_eval["heldout_w"][cur_lin.valid] ** 2) / max(cur_lin.valid.sum(), 1))
    for sc in scores:
        if sc.effect is None or not ((sc.accepted and sc.alternatives) or sc.dropped):
            continue
        others = [a for a in accepted if a is not sc.effect]
        if sc.accepted:
            rivals = {sc.label: cur_model} | {e.label: others + [e] for e in sc.alternative_effects}
        else:
            rivals = {f"without {sc.label}": cur_model, f"with {sc.label}": accepted + [sc.effect]}
        models = {}
        for label, m in rivals.items():
            try:
                models[label] = m if not isinstance(m, list) else base_fit(camp, m)
            except VecpinError as err:
                say(f"{label}: cannot be fitted for a discriminating plan ({err}); left out of it")
        if len(models) < 2:
            continue
        plan = discriminating_plan(models, camp, scatter=scatter)   # inside the measured range first
        if plan.chi2_gap < SETTLES_CHI2:
            inside = plan
            plan = discriminating_plan(models, camp, scatter=scatter, inside=False)
            sc.evidence += (f"; no {len(inside.tool)} commands inside the measured range separate "
                            f"{' and '.join(plan.labels)} beyond the noise (expected chi2 {inside.chi2_gap:.1f})")
            if plan.chi2_gap < SETTLES_CHI2 or not plan.beyond:
                sc.evidence += (f", nor over the travel (expected chi2 {plan.chi2_gap:.1f}): not settled by where the "
                                "machine is measured (for time effects: a reference point read again over time)")
                continue
            sc.evidence += f"; the plan to tell them apart extrapolates ({plan.beyond_text()})"
        sc.next_plan = plan
        say(f"what to measure next for {sc.label}: {len(plan.tool)} points")
