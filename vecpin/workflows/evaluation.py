"""A fitted model judged on a campaign: uncompensated and model residual distances."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from vecpin.errors import CampaignFileError
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.partframe import RunReference, part_frame_errors, spindle_axis
from vecpin.measurement.tableframe import (NetOfNoise, check_nest_rows, net_of_noise, registers_table, table_nests,
                                          table_tips, tip_noise)
from vecpin.measurement.registration import (check_registration, check_same_pose, registered_errors, spans_plane,
                                             station0)
from vecpin.models import ErrorModel
from vecpin.units import MM_PER_M, norm_mm
from vecpin.measurement.stats import distance_stats
from vecpin.workflows.summary import per_tool_table


TRACKER_FRAME = ("the tool tip in the tracker frame; uncompensated in the part's frame (the run taken into the "
                 "machine's reference lines, a translation and a rotation about the spindle removed), model: measured "
                 "minus modelled")
TABLE_FRAME = ("the tool tip relative to the table (workpiece frame, seen from the nests); uncompensated in the part's "
               "frame (the machine's reference lines, a translation and a rotation about the spindle removed), model: "
               "measured minus modelled, registered rigidly")


@dataclass
class Evaluation:
    """Distances [mm] per row of the judged campaign: measured minus nominal
    (``uncompensated``) and measured minus model (``residual``), in ``frame``: station 0's
    tracker rows in the tracker frame, or on a table machine with nest rows the tool rows
    relative to the table (each command's table pose from its nests, registered)."""

    rows: int
    tool: np.ndarray
    uncompensated: np.ndarray
    residual: np.ndarray
    reregistered: bool
    other_rows: int  # rows of other stations or instruments, not judged
    frame: str = TRACKER_FRAME
    warnings: list[str] = field(default_factory=list)  # printed first
    notes: list[str] = field(default_factory=list)
    noise_mm: float | None = None  # mean tracker noise of the measured tip relative to the table
    outside: np.ndarray | None = None  # rows commanded beyond what the fit measured (judged apart)
    net: NetOfNoise | None = None  # relative to the table: the model error with the measurement noise taken out
    shape: np.ndarray | None = None  # uncompensated distances [mm] with the best rigid motion removed instead
    still: dict = field(default_factory=dict)  # axes that stood still in the fit's campaign: {name: (position, unit)}

    @property
    def reduction_pct(self) -> float:
        return 100.0 * (1 - self.residual.mean() / self.uncompensated.mean())

    def lines(self) -> list[str]:
        out = [f"  frame: {self.frame}"]
        out += per_tool_table([("uncompensated (nominal kinematics)", self.uncompensated), ("model", self.residual)],
                              self.tool)
        out.append(f"  reduction of the mean: {self.reduction_pct:.1f}%")
        if self.shape is not None:
            out.append(f"  uncompensated, shape of the error (the best rigid motion removed, the seed's figure): mean "
                       f"{self.shape.mean():.4f} mm, max {self.shape.max():.4f} mm")
        if self.outside is not None and self.outside.any():
            k = self.outside
            out += ["  inside and outside the measured range:"]
            for side, rows in (("inside", ~k), ("outside", k)):
                if rows.any():
                    out += per_tool_table([(f"uncompensated, {side}", self.uncompensated[rows]),
                                           (f"model, {side}", self.residual[rows])], np.zeros(rows.sum()))[1:]
        if self.still:
            n_out = 0 if self.outside is None else int(self.outside.sum())
            out.append(f"  did not move in the fit's campaign: {_still_text(self.still)} (the model's errors held "
                       f"there, no slope beyond); {n_out} of {len(self.residual)} rows evaluated leave the measured range")
        if self.other_rows and self.frame == TRACKER_FRAME:
            out.append(f"  (station 0 tracker rows; the file has {self.other_rows} more rows of other stations, "
                       "nests or the ball bar)")
        return out + [f"  note: {n}" for n in self.notes]

    def to_dict(self) -> dict:
        return {"rows": self.rows, "reregistered": self.reregistered, "units": "mm", "frame": self.frame,
                "warnings": self.warnings, "notes": self.notes, "table_tip_noise_mean_mm": self.noise_mm,
                "model_rms_net_of_noise_mm": None if self.net is None else [self.net.rms, self.net.sd],
                "uncompensated": distance_stats(self.uncompensated, self.tool),
                "uncompensated_shape": None if self.shape is None else distance_stats(self.shape, self.tool),
                "model_residual": distance_stats(self.residual, self.tool), "reduction_of_mean_pct": self.reduction_pct,
                "still_axes": {a: {"position": p, "unit": u} for a, (p, u) in self.still.items()},
                "rows_outside_measured_range": 0 if self.outside is None else int(self.outside.sum()),
                "outside_measured_range": None if self.outside is None or not self.outside.any() else {
                    "rows": int(self.outside.sum()),
                    "uncompensated": distance_stats(self.uncompensated[self.outside], self.tool[self.outside]),
                    "model_residual": distance_stats(self.residual[self.outside], self.tool[self.outside])}}


def evaluate(model: ErrorModel, campaign: Campaign, reregister: bool = False, zone=None,
             model_source: str = "the model") -> Evaluation:
    """Judge ``model`` on ``campaign`` (its station-0 tracker rows; of those commanded in
    ``zone`` {axis: (low, high)} mm/deg when given). ``reregister``: the tracker was
    moved, so its pose is fitted to this campaign first. A campaign the model's tracker
    pose (or, re-registered, the machine's nominal kinematics) cannot describe is refused
    (:func:`~vecpin.measurement.registration.check_same_pose`). Targets whose offsets the
    campaign does not give take the fitted ones of the model."""
    if getattr(model, "setup_", None) is not None and model.setup_.targets:
        campaign = dataclasses.replace(campaign, targets=dict(model.setup_.targets) | dict(campaign.targets))
    if zone:
        from vecpin.fitting.problem import zone_rows
        campaign = zone_rows(model.machine, campaign, zone)
    check_nest_rows(model.machine, campaign)
    few = len(campaign.nest_rows) > 0 and not registers_table(campaign)
    if model.machine.has_workpiece and len(campaign.nest_rows) and not few:
        ev, judged = _relative_to_table(model, campaign, reregister)
        _judge_range(model, judged, ev)
        return ev
    if few:   # fewer than three nests: no table pose at a command, the tool rows judged as on a head machine
        campaign = campaign.subset(np.setdiff1d(np.arange(len(campaign)), campaign.nest_rows))
    if model.machine.has_workpiece:
        c = station0(campaign)
        if not spans_plane(model.machine.tool_tip(c.q, c.tool, frame="base", point=c.point)):
            raise CampaignFileError(campaign.source, f"no nest rows, and the tool of '{model.machine.name}' stands still "
                                    "in the base frame (every axis moves the table): nothing is seen at the tool; read "
                                    "reflectors in three or more table nests at each command", column="instrument")
    ev = _at_the_tool(model, campaign, reregister, model_source)
    _judge_range(model, station0(campaign), ev)
    if model.machine.has_workpiece:
        ev.warnings.append(f"WARNING: {campaign.source} has " + ("fewer than three table nests (their rows left out: "
                           "two nests do not give the table's turn about the line through them)" if few else
                           "no nest rows") + ": judged at the tool tip, which the table axes "
                           f"({', '.join(model.machine.table_axes)}) do not move, so their errors are not seen; read "
                           "reflectors in three or more table nests at each command to judge the tip relative to the "
                           "table")
    return ev


def _at_the_tool(model: ErrorModel, campaign: Campaign, reregister: bool, model_source: str) -> Evaluation:
    """Station 0's tracker rows in the tracker frame (module :func:`evaluate`)."""
    c = station0(campaign)
    if c.plain:
        m = model.machine
        nominal = m.tool_tip(c.q, c.tool, frame="base")
        if reregister:
            check_registration(nominal, c.xyz, c.source, c.lines)
        else:
            check_same_pose(nominal, model.predict_nominal(c.q, c.tool), c.xyz, c.source, model_source, c.lines)
        if spans_plane(nominal):   # where a part is: the run in the machine's reference frame, its set-up removed
            d_nom = norm_mm(part_frame_errors(nominal, RunReference(m, c.q, c.tool, nominal, c.xyz)(c.xyz),
                                              spindle_axis(m)))
            shape = norm_mm(registered_errors(nominal, c.xyz))
        else:   # one joint's sweep, one point: nothing to register, the distances from the model's tracker pose
            d_nom = shape = norm_mm(c.xyz - model.predict_nominal(c.q, c.tool))
    else:  # targets on the tool, several tool points: the fitted targets placed on the nominal machine
        res = model.nominal_residuals(c)
        shape = norm_mm(registered_errors(c.xyz - res, c.xyz))
        d_nom = shape if reregister else norm_mm(res)
    d_mod = norm_mm(model.residuals(c, reregister=reregister))
    return Evaluation(len(c), c.tool, d_nom, d_mod, reregister, len(campaign) - len(c), shape=shape)


def _relative_to_table(model: ErrorModel, campaign: Campaign, reregister: bool) -> tuple[Evaluation, Campaign]:
    """The tool rows relative to the table: each command's table pose registered on its
    nests (the fitted nests, or re-fitted from the run), the measured tip against the
    nominal and the modelled tip relative to the workpiece, each after the best rigid
    registration (:mod:`vecpin.measurement.tableframe`). Returns the evaluation and the
    judged rows."""
    m = model.machine
    nests, refitted = table_nests([campaign], dict(model.setup_.nests))
    tt = table_tips(campaign, nests, refitted)
    if not len(tt.rows):
        raise CampaignFileError(campaign.source, "no command has tool rows and three or more nests (not on a line) read "
                                "at the same command and station, so the tip relative to the table cannot be measured; "
                                "read the nests at the commands of the tool rows", column="instrument")
    c = campaign.subset(tt.rows)
    offset = None
    if np.any(c.target != ""):
        offset = np.array([model.setup_.targets.get(str(t), np.zeros(3)) for t in c.target])
    feats = None
    if model.effects:
        from vecpin.measurement.features import Features
        feats = Features.from_campaign(campaign).subset(tt.rows)
    where = {"frame": "workpiece", "point": c.point, "offset": offset}
    nominal = m.tool_tip(c.q, c.tool, **where)
    modelled = model.tool_tip(c.q, c.tool, model.b_, jacobian=False, features=feats, **where).tip
    notes = [f"{tt.commands} commands judged; nests {', '.join(sorted(nests))} "
             + ("re-fitted from this run (the model's nests are not all in it, or moved)" if refitted
                else "where the fit put them") + "; the tracker registered on them at every command, the measured, "
             "nominal and modelled tips registered rigidly (where the part sits is not observable)"]
    noise = tip_noise(campaign, tt, model.noise_.tracker) * MM_PER_M
    notes.append(f"tracker noise through the nest registration: {noise.mean():.4f} mm mean at the tip relative to "
                 "the table (the model's own noise settings; a model error below it is not resolved by this run)")
    residual = registered_errors(modelled, tt.tip)
    net = net_of_noise(residual, campaign, tt, model.noise_, m)
    notes.append(net.line())
    if len(tt.unjudged):
        notes.append(f"{len(tt.unjudged)} tool row(s) not judged: fewer than three nests read at their command (first: "
                     f"row {campaign.lines[tt.unjudged[0]]})")
    if reregister:
        notes.append("`reregister`: not needed relative to the table (every command registers the tracker on the nests)")
    if refitted:
        to_ref = RunReference(m, c.q, c.tool, nominal, tt.tip)
    else:   # the nests where the fit put them: the model's reference frame
        from vecpin.compensation.frame import model_reference_frame
        to_ref = model_reference_frame(model).apply
    uncompensated = part_frame_errors(nominal, to_ref(tt.tip), spindle_axis(m))
    return Evaluation(len(c), c.tool, norm_mm(uncompensated),
                      norm_mm(residual), reregister, len(campaign) - len(c), TABLE_FRAME,
                      notes=notes, noise_mm=float(noise.mean()), net=net,
                      shape=norm_mm(registered_errors(nominal, tt.tip))), c


OUTSIDE_MARGIN = 0.02   # of an axis' travel: commands this far beyond the measured range are extrapolation


def _judge_range(model: ErrorModel, judged: Campaign, ev: Evaluation) -> None:
    """Mark the judged rows commanded beyond the range the fit measured (its zone, or the
    lowest and highest command of each axis, by more than ``OUTSIDE_MARGIN`` of the travel):
    the model extrapolates there, so they are reported apart, with a first-line warning."""
    from vecpin.models.recorded import recorded_box, still_axes
    m = model.machine
    lo, hi = recorded_box(model, widen_still=False)   # an axis that stood still: the one position it stood at
    ev.still = {a.name: (float(a.to_user(lo[a.index])), a.unit) for a in still_axes(model)}
    margin = OUTSIDE_MARGIN * np.array([a.travel for a in m.axes])
    beyond = (judged.q < lo - margin) | (judged.q > hi + margin)
    outside = beyond.any(axis=1)
    if not outside.any():
        return
    ev.outside = outside
    axes = [a for a in m.axes if beyond[:, a.index].any()]
    where = ", ".join(f"{a.name} {a.to_user(lo[a.index]):.1f}..{a.to_user(hi[a.index]):.1f} {a.unit}"
                      + (" (it did not move in the fit's campaign: errors held there)" if a.name in ev.still else "")
                      for a in axes)
    inside_mean = ev.residual[~outside].mean() if (~outside).any() else float("nan")
    outside_mean = ev.residual[outside].mean()
    ev.warnings.append(f"WARNING: {outside.sum()} of {len(outside)} rows of {judged.source} are commanded beyond "
                       f"what the fit measured ({where}): the model extrapolates there (model mean {outside_mean:.4f} "
                       f"mm outside, {inside_mean:.4f} mm inside); judged apart below")


def _still_text(still: dict) -> str:
    """'J4 at 12.5 deg, Z at 300 mm' of :attr:`Evaluation.still`."""
    return ", ".join(f"{a} at {p:g} {u}" for a, (p, u) in still.items())
