"""A fitted model judged on a campaign: uncompensated and model residual distances."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.measurement.campaign import Campaign
from vecpin.measurement.registration import check_registration, check_same_pose, registered_errors, station0
from vecpin.models import ErrorModel
from vecpin.units import norm_mm
from vecpin.measurement.stats import distance_stats
from vecpin.workflows.summary import per_tool_table


@dataclass
class Evaluation:
    """Distances [mm] per row of the judged campaign (station 0's tracker rows):
    measured minus nominal (``uncompensated``) and measured minus model (``residual``)."""

    rows: int
    tool: np.ndarray
    uncompensated: np.ndarray
    residual: np.ndarray
    reregistered: bool
    other_rows: int  # rows of other stations or instruments, not judged

    @property
    def reduction_pct(self) -> float:
        return 100.0 * (1 - self.residual.mean() / self.uncompensated.mean())

    def lines(self) -> list[str]:
        out = per_tool_table([("uncompensated (nominal kinematics)", self.uncompensated), ("model", self.residual)],
                             self.tool)
        out.append(f"  reduction of the mean: {self.reduction_pct:.1f}%")
        if self.other_rows:
            out.append(f"  (station 0 tracker rows; the file has {self.other_rows} more rows of other stations "
                       "or the ball bar)")
        return out

    def to_dict(self) -> dict:
        return {"rows": self.rows, "reregistered": self.reregistered, "units": "mm",
                "uncompensated": distance_stats(self.uncompensated, self.tool),
                "model_residual": distance_stats(self.residual, self.tool), "reduction_of_mean_pct": self.reduction_pct}


def evaluate(model: ErrorModel, campaign: Campaign, reregister: bool = False, zone=None,
             model_source: str = "the model") -> Evaluation:
    """Judge ``model`` on ``campaign`` (its station-0 tracker rows; of those commanded in
    ``zone`` {axis: (low, high)} mm/deg when given). ``reregister``: the tracker was
    moved, so its pose is fitted to this campaign first. A campaign the model's tracker
    pose (or, re-registered, the machine's nominal kinematics) cannot describe is refused
    (:func:`~vecpin.measurement.registration.check_same_pose`)."""
    if zone:
        from vecpin.workflows.fitting import zone_rows
        campaign = zone_rows(model.machine, campaign, zone)
    c = station0(campaign)
    if c.plain:
        nominal = model.machine.tool_tip(c.q, c.tool, frame="base")
        if reregister:
            check_registration(nominal, c.xyz, c.source, c.lines)
            d_nom = norm_mm(registered_errors(nominal, c.xyz))
        else:
            predicted = model.predict_nominal(c.q, c.tool)
            check_same_pose(nominal, predicted, c.xyz, c.source, model_source, c.lines)
            d_nom = norm_mm(c.xyz - predicted)
    else:  # targets on the tool, several tool points: the fitted targets placed on the nominal machine
        res = model.nominal_residuals(c)
        d_nom = norm_mm(registered_errors(c.xyz - res, c.xyz)) if reregister else norm_mm(res)
    d_mod = norm_mm(model.residuals(c, reregister=reregister))
    return Evaluation(len(c), c.tool, d_nom, d_mod, reregister, len(campaign) - len(c))
