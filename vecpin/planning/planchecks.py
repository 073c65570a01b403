"""What makes a plan useless, said with the fix: the holder runs into the machine, the
predicted error is no better than the machine uncompensated, the tracker stands in
the work envelope or out of a tracker's range, the gauge line cannot be identified.

Each check is a sentence for ``vecpin: warning:`` (the plan's first lines); the plan
is still written (a user may know better), but never silently.
"""
from __future__ import annotations

import numpy as np

from vecpin.units import MM_PER_M, to_mm

TRACKER_RANGE = 40.0     # m: farther than this a laser tracker does not read a target (40 m is a long-range model)
EXPECTED_ERROR_MM = 0.2  # mm: a large machine tool's mean error uncompensated, registered as a tracker sees it
PREDICTED_SHARE = 0.5    # a plan whose predicted error is above this share of the uncompensated one gains little


def t_offset_identified(info, covariance: np.ndarray, expected_error_mm: float = EXPECTED_ERROR_MM) -> bool:
    """Does the plan identify the gauge line T_offset: counted (some design sees it) and
    its 1-sigma below :data:`PREDICTED_SHARE` of the machine's expected error (a gauge
    line known worse than that shifts every tip by more than the plan may leave)?"""
    return bool(info.keep[6]) and float(to_mm(np.sqrt(covariance[6, 6]))) < PREDICTED_SHARE * expected_error_mm


def work_envelope(machine, q: np.ndarray, tools: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) corners [m], base frame, of the tool tips at commands q with every holder."""
    tips = np.vstack([machine.tool_tip(q, float(L), frame="base") for L in tools])
    return tips.min(axis=0), tips.max(axis=0)


def plan_warnings(plan) -> list[str]:
    """The warnings of a :class:`~vecpin.planning.plan.Plan`, each with its fix, most
    serious first."""
    out = []
    s = plan.settings
    c = plan.counts()
    tools = ", ".join(f"{t:g}" for t in s.tools_mm)
    if c["collision"]:
        names, counts = np.unique(plan.sight_by[plan.removed == "collision"].astype(str), return_counts=True)
        where = ", ".join(f"{n} ({k})" for k, n in sorted(zip(counts, names), reverse=True)[:3])
        out.append(f"{c['collision']} of {c['candidates']} candidate commands put a target holder ({tools} mm) into the "
                   f"machine's own geometry: {where}. These are collisions, not line-of-sight losses; the plan leaves "
                   "them out, but the machine must never be commanded there with these holders: keep such runs out "
                   "with `zone` or `exclude`, or plan shorter `tools_mm`")
    lo, hi = work_envelope(plan.machine, plan.candidates, plan.tools)
    tr = plan.tracker
    if np.all((tr >= lo) & (tr <= hi)):
        box = ", ".join(f"{a} {to_mm(low):.0f} .. {to_mm(high):.0f}" for a, low, high in zip("xyz", lo, hi))
        out.append(f"`tracker_mm` ({', '.join(f'{v:.0f}' for v in to_mm(tr))}) mm stands inside the tool tips' work "
                   f"envelope ({box} mm, machine frame): the machine would run into it; place it outside, e.g. "
                   "2 m in front of the workspace (leave `tracker_mm` out for that)")
    far = float(max(np.linalg.norm(lo - tr), np.linalg.norm(hi - tr)))
    if far > TRACKER_RANGE:
        out.append(f"`tracker_mm`: the tool tips are up to {far:,.0f} m from the tracker; a laser tracker reads a "
                   f"target at most about {TRACKER_RANGE:.0f} m away (and its noise grows with the range): place it "
                   "within a few metres of the machine")
    pr, expected = plan.score.predicted, s.expected_error_mm
    if to_mm(pr.model_mean) > PREDICTED_SHARE * expected:
        lost = c["collision"] + c["sight"]
        hint = (f"a `tracker_mm` position that sees more of the workspace ({c['sight']} of {c['candidates']} candidates "
                "are out of sight), " if c["sight"] > 0.25 * c["candidates"] else "")
        out.append(f"the plan's predicted model error (mean {to_mm(pr.model_mean):.3f} mm, max "
                   f"{to_mm(pr.model_max):.3f} mm) is {to_mm(pr.model_mean) / expected:.0%} of the error the machine is "
                   f"expected to have uncompensated (mean {expected:g} mm, `expected_error_mm`): "
                   f"compensation from this campaign would gain little or make the machine worse; plan with {hint}"
                   "more `n_commands` or a lower `order`" + (
                       f"; the prediction covers the whole measurement zone, also where {lost} of {c['candidates']} "
                       "candidates were lost to collisions and sight and the model extrapolates: a `zone` where the "
                       "holders can go plans and judges that part alone" if lost > 0.1 * c["candidates"] else ""))
    info = plan.information
    if info.keep[6] and not t_offset_identified(info, plan.covariance, s.expected_error_mm):
        out.append(f"gauge line T_offset: this plan cannot identify it (1-sigma {np.sqrt(plan.covariance[6, 6]) * MM_PER_M:.2f} "
                   f"mm, above half the expected error {s.expected_error_mm:g} mm): its rows do not separate it from the "
                   f"other terms of the order-{s.order} model; set the gauge line on a tool presetter (the tables then "
                   "leave it as the controller has it), or plan a lower `order`")
    return out


__all__ = ["plan_warnings", "t_offset_identified", "work_envelope", "TRACKER_RANGE", "PREDICTED_SHARE",
           "EXPECTED_ERROR_MM"]
