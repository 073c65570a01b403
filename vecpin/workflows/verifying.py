"""Before and after: the uncompensated and the compensated validation runs of a machine
side by side (the ``verify`` command; Paper I Table 3 and Fig. 11).

Each run is judged on its own: the distance of every measured point from the commanded
position (nominal kinematics, after the best-fit rigid motion of the run, as the seed's
volumetric errors). For the compensated run the commanded position uses the
controller's changed gauge line: nominal tool length + the tables' ``T_offset`` change.
With a fitted model the predicted figures stand beside the measured ones: without the
tables, the model's errors at the run's commands; with them, the error the tables leave
of the model plus (when both runs measure the same commands) the model's residual on
the uncompensated run - what the model does not describe stays after compensation
(Paper I: "The compensated accuracy in Table 3 is comparable with the model accuracy").
The tables are those given, or computed from the model for a generic controller.

On a machine with a table both runs are judged by the tip relative to the table when they
read the table nests (:mod:`vecpin.measurement.tableframe`: each command's table pose from
its nests, the nests where the model's fit put them or re-fitted from the two runs), the
predicted figures in the same frame; two runs without nest rows are judged at the tool tip
with a warning and without the predicted figures (those are relative to the table); one
run with nests and one without are refused (they would not measure the same thing).
Relative to the table each run's figure also stands net of the measurement noise, as
``evaluate`` gives it (:func:`vecpin.measurement.tableframe.net_of_noise`: the noise's
expected share, from copies of the run given the tracker's and the axes' noise again,
subtracted in quadrature; the model's noise settings, or the default ones without a
model), with its standard uncertainty, or "not resolved" with a bound; and the reduction
of that RMS with its uncertainty (or the least reduction the bound allows).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vecpin.compensation.frame import model_as_actual
from vecpin.compensation.report import compensated_errors
from vecpin.compensation.tables import TableSet
from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.partframe import FRAME_TEXT, RunReference, part_frame_errors, spindle_axis
from vecpin.measurement.registration import check_registration, registered_errors, spans_plane
from vecpin.measurement.tableframe import (NetOfNoise, check_nest_rows, net_of_noise, registers_table, table_nests,
                                          table_tips, tip_noise)
from vecpin.measurement.stats import distance_stats
from vecpin.models import ErrorModel
from vecpin.units import M_PER_MM, norm_mm

SEED_TABLE3 = [("Uncompensated", 0.551, None, 0.940, None), ("6-DoF Tables", 0.038, 93.1, 0.099, 89.5),
               ("AP Tables", 0.043, 92.2, 0.094, 90.0)]


@dataclass
class Run:
    """One validation run: distances [mm] per row, measured and (with a model) predicted."""

    label: str
    source: str
    tool: np.ndarray
    measured: np.ndarray
    predicted: np.ndarray | None = None


@dataclass
class Verification:
    before: Run
    after: Run
    gauge_change_mm: float
    tables_from: str
    model_label: str | None
    same_commands: bool
    notes: list[str] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)
    frame: str = FRAME_TEXT
    warnings: list[str] = field(default_factory=list)  # printed first
    commands: str = ""  # which commands the two runs measure (one line)
    net: list[NetOfNoise] | None = None  # relative to the table: before and after, net of the measurement noise
    shape: list[np.ndarray] | None = None  # measured distances [mm] with each run's best rigid motion removed
    thermal: object | None = None  # the runs at their temperatures with thermal.json (workflows.verifythermal)

    def net_reduction(self) -> tuple[float, float] | None:
        """(reduction [%] of the RMS net of the measurement noise, its standard uncertainty
        [%]); (least reduction the after run's bound allows, NaN) when the after run does
        not resolve its error; None when the before run does not (or no table frame)."""
        if self.net is None or not self.net[0].resolved:
            return None
        b, a = self.net
        if not a.resolved:
            return 100.0 * (1 - (a.rms + 2 * a.sd) / b.rms), float("nan")
        r = a.rms / b.rms
        return 100.0 * (1 - r), 100.0 * r * float(np.hypot(a.sd / a.rms, b.sd / b.rms))

    def net_lines(self) -> list[str]:
        """The runs' figures net of the measurement noise (relative to the table), one line each."""
        if self.net is None:
            return []
        out = ["  net of the measurement noise (RMS relative to the table; the noise's expected share, from copies of "
               "each run given the tracker's and the axes' noise again, subtracted in quadrature; ± one standard "
               "uncertainty):"]
        for label, n in zip(("uncompensated", "compensated"), self.net):
            out.append(f"    {label:<14s} " + (f"{n.rms:.4f} ± {n.sd:.4f} mm" if n.resolved else
                                              f"not resolved by this run: {n.rms:.4f} ± {n.sd:.4f} mm, below "
                                              f"{n.rms + 2 * n.sd:.4f} mm at two standard uncertainties")
                       + f" (measured RMS {n.measured_rms:.4f} mm, noise {n.noise_rms:.4f} mm)")
        red = self.net_reduction()
        out.append("    reduction of the RMS net of the noise: " + (
            "not resolved (the uncompensated run's error is not resolved)" if red is None else
            f"at least {red[0]:.1f} % (the compensated run's bound); more validation commands, or each read several "
            "times, resolve it" if np.isnan(red[1]) else f"{red[0]:.1f} ± {red[1]:.1f} %"))
        return out

    def reduction(self, stat: str, tool_key: str = "all") -> float:
        b = distance_stats(self.before.measured, self.before.tool)[tool_key][stat]
        a = distance_stats(self.after.measured, self.after.tool)[tool_key][stat]
        return 100.0 * (1 - a / b)

    def lines(self) -> list[str]:
        pred = self.before.predicted is not None
        w = max(20, len(self.before.label), len(self.after.label))
        head = f"  {'run':<{w}s} {'tools':<18s} {'n':>4s} {'mean mm':>9s} {'reduct.':>8s} {'max mm':>9s} {'reduct.':>8s}"
        if pred:
            head += f" | {'model mean':>10s} {'max':>8s}"
        out = self.warnings + ["verification: validation runs of the real machine before and after compensation "
                               "(Paper I Table 3 layout)", f"  frame of every figure: {self.frame}"]
        if self.commands:
            out.append(f"  commands compared: {self.commands}")
        out.append(head)
        sb = distance_stats(self.before.measured, self.before.tool)
        sa = distance_stats(self.after.measured, self.after.tool)
        keys = list(sb) if len(sb) > 2 else ["all"]
        for run, st in ((self.before, sb), (self.after, sa)):
            pst = distance_stats(run.predicted, run.tool) if run.predicted is not None else None
            for k in keys:
                if k not in st:
                    continue
                s = st[k]
                red_mean = red_max = "--"
                if run is self.after and k in sb:
                    red_mean = f"{100 * (1 - s['mean'] / sb[k]['mean']):7.1f}%"
                    red_max = f"{100 * (1 - s['max'] / sb[k]['max']):7.1f}%"
                label = run.label if k == "all" else ""
                line = (f"  {label:<{w}s} {k:<18s} {s['n']:4d} {s['mean']:9.4f} {red_mean:>8s} {s['max']:9.4f} "
                        f"{red_max:>8s}")
                if pst is not None:
                    line += f" | {pst[k]['mean']:10.4f} {pst[k]['max']:8.4f}"
                out.append(line)
        if self.shape is not None:
            out.append(f"  shape of the error (each run's best rigid motion removed, the seed's figure): mean "
                       f"{self.shape[0].mean():.4f} -> {self.shape[1].mean():.4f} mm, max {self.shape[0].max():.4f} -> "
                       f"{self.shape[1].max():.4f} mm")
        out += self.net_lines()
        out.append(f"  compensated run judged against the commanded positions with the gauge line changed by "
                   f"{self.gauge_change_mm:+.4f} mm ({self.tables_from})")
        if pred:
            out.append(f"  model: {self.model_label} (best-fit rigid motion removed)")
        out.append("  for comparison, Paper I Table 3 (the dissertation's laboratory XYZCB as measured, the machine "
                   "bundled as flow_xyzcb; 35 validation points, short tool):")
        for name, mean, rm, mx, rx in SEED_TABLE3:
            out.append(f"    {name:<16s} mean {mean:.3f} mm" + (f" ({rm:.1f}%)" if rm else "") +
                       f", max {mx:.3f} mm" + (f" ({rx:.1f}%)" if rx else ""))
        out += self.thermal.lines() if self.thermal is not None else []
        out += [f"  note: {n}" for n in self.notes]
        out += [f"  wrote {f}" for f in self.files]
        return out

    def to_dict(self) -> dict:
        def run(r: Run) -> dict:
            d = {"label": r.label, "file": r.source, "units": "mm", "measured": distance_stats(r.measured, r.tool)}
            if r.predicted is not None:
                d["predicted"] = distance_stats(r.predicted, r.tool)
            return d
        return {"format": "vecpin-verify", "version": 1, "uncompensated": run(self.before),
                "compensated": run(self.after), "gauge_change_mm": self.gauge_change_mm,
                "tables": self.tables_from, "model": self.model_label,
                "reduction_of_mean_pct": self.reduction("mean"), "reduction_of_max_pct": self.reduction("max"),
                "same_commands": self.same_commands, "notes": self.notes, "frame": self.frame,
                "warnings": self.warnings, "commands": self.commands,
                "shape_mm": None if self.shape is None else
                {"uncompensated": distance_stats(self.shape[0], self.before.tool)["all"],
                 "compensated": distance_stats(self.shape[1], self.after.tool)["all"]},
                "rms_net_of_noise_mm": None if self.net is None else
                {"uncompensated": [self.net[0].rms, self.net[0].sd], "compensated": [self.net[1].rms, self.net[1].sd],
                 "resolved": [self.net[0].resolved, self.net[1].resolved],
                 "reduction_pct": None if self.net_reduction() is None else
                 [self.net_reduction()[0], None if np.isnan(self.net_reduction()[1]) else self.net_reduction()[1]]},
                "thermal": None if self.thermal is None else self.thermal.to_dict(),
                "seed_table3": [{"model": n, "mean_mm": a, "max_mm": c} for n, a, _, c, _ in SEED_TABLE3]}


def run_distances(machine: Machine, campaign: Campaign, gauge_change: float = 0.0, judged: str = "part") -> np.ndarray:
    """Distances [mm] of the measured points from the commanded positions (nominal tool
    length + ``gauge_change`` [m]): in the part's frame (``judged`` "part": the points taken
    into the run's own reference frame, then the part's set-up removed), or with the run's
    own best-fit rigid motion removed ("shape")."""
    c = campaign.primary()
    nominal = machine.tool_tip(c.q, c.tool + gauge_change, frame="base")
    if judged == "shape":
        return norm_mm(registered_errors(nominal, c.xyz))
    reference = RunReference(machine, c.q, c.tool + gauge_change, nominal, c.xyz)
    return norm_mm(part_frame_errors(nominal, reference(c.xyz), spindle_axis(machine)))


def verify(machine: Machine, before: Campaign, after: Campaign, model: ErrorModel | None = None,
           tables: TableSet | None = None, tables_source: str | None = None, progress=None, thermal=None,
           thermal_source: str | None = None) -> Verification:
    """The two runs side by side (see the module text); ``progress(msg)`` hears of the
    slow step (tables computed from the model); ``thermal``: the controller's thermal
    terms (:class:`~vecpin.compensation.thermal.ThermalTerms`, from ``thermal_source``)
    active in the compensated run: both runs judged with them at their temperatures
    (:mod:`vecpin.workflows.verifythermal`)."""
    table = _check_runs(machine, before, after)
    if model is not None and machine.has_workpiece and not table:
        raise InputError(f"{before.source} and {after.source} have no nest rows: on {machine.name} the model's figures "
                         "are the tip relative to the table, which runs read at the tool alone cannot measure (the "
                         f"table axes {', '.join(machine.table_axes)} are not seen); read three or more table nests at "
                         "every command in both runs, or judge them at the tool without the model")
    tables, tables_from = _tables_for(model, tables, tables_source, progress)
    dT = tables.gauge_offset_change if tables is not None else 0.0
    m = _measure(machine, before, after, model, dT, table)
    b, a = m.b, m.a
    before_run = Run(f"uncompensated ({Path(before.source).name})", before.source, b.tool, m.measured[0])
    after_run = Run(f"compensated ({Path(after.source).name})", after.source, a.tool, m.measured[1])
    label, notes = None, m.notes
    same = len(a) == len(b) and np.allclose(a.q, b.q, atol=1e-9) and np.allclose(a.tool, b.tool, atol=1e-9)
    if model is not None:
        before_run.predicted, after_run.predicted, label = _predict(machine, model, tables, m, dT, table, same)
    if not same:
        notes.append("the two runs measure different commands: compare the statistics, not the points")
    if after_run.measured.mean() >= before_run.measured.mean():
        notes.append("the compensated run is not better than the uncompensated one: were the tables active, and is "
                     "AFTER really the run with them?")
    judged = None
    if thermal is not None:
        from vecpin.workflows.verifythermal import judge_thermal
        judged = judge_thermal(machine, thermal, thermal_source or "thermal terms", b, a)
    return Verification(before_run, after_run, dT / M_PER_MM, tables_from, label, bool(same), notes, frame=m.frame,
                        warnings=m.warnings, commands=compared_commands(machine, b, a, same), net=m.net, shape=m.shape,
                        thermal=judged)


def _check_runs(machine: Machine, before: Campaign, after: Campaign) -> bool:
    """Refuse runs that cannot be compared (nests in one only, the same measurements twice,
    another machine or unit); True when both are judged relative to the table."""
    for run in (before, after):
        check_nest_rows(machine, run)
    table = machine.has_workpiece and bool(len(before.nest_rows) or len(after.nest_rows))
    if table and not (len(before.nest_rows) and len(after.nest_rows)):
        w, wo = (before, after) if len(before.nest_rows) else (after, before)
        raise InputError(f"{w.source} has nest rows and {wo.source} has none: the first would be judged relative to "
                         "the table, the second at the tool tip, which are not the same error; measure both runs "
                         "with the table nests (or judge both at the tool without their nest rows)")
    if (len(after) == len(before) and np.array_equal(after.q, before.q) and np.array_equal(after.tool, before.tool)
            and np.array_equal(after.xyz, before.xyz)):   # every row: a machine whose tool stands still differs at its nests
        same_file = Path(before.source).resolve() == Path(after.source).resolve()
        raise InputError(f"verify {before.source} {after.source}: "
                         + ("the same file is given " if same_file else "the two files hold the same measurements ")
                         + "as the run before and the run after compensation; AFTER is a second run, measured with "
                           "the tables active")
    for run in (before.primary(), after.primary()):  # another machine's run, or other units, is not a validation run
        tips = machine.tool_tip(run.q, run.tool, frame="base")
        if not table or spans_plane(tips):
            check_registration(tips, run.xyz, run.source, run.lines)
    return table


def _tables_for(model: ErrorModel | None, tables: TableSet | None, source: str | None, progress):
    """The tables the compensated run ran with, and where they come from (one phrase)."""
    if tables is not None:
        return tables, f"tables {source}"
    if model is None:
        return None, "no tables given: 0 assumed (give `tables`)"
    from vecpin.compensation.plan import plan_tables
    if progress:
        progress("computing the tables from the model (generic controller): none were given")
    return (plan_tables(model, n_commands=600, uncertainty=False).tables,
            "tables computed from the model (generic controller, full set); give `tables` for the real ones")


@dataclass
class _Measured:
    """The runs' judged rows (``b``, ``a``), measured distances [mm] and what was seen of the table."""

    b: Campaign
    a: Campaign
    measured: list[np.ndarray]
    seen: list | None
    frame: str
    notes: list[str]
    warnings: list[str]
    net: list[NetOfNoise] | None = None
    shape: list[np.ndarray] | None = None   # the measured distances [mm] with each run's best rigid motion removed


class OnTheModel(RunReference):
    """The uncompensated run taken into the model's reference frame (the frame its tables
    keep): registered rigidly onto the model's tips at the run's commands, relative to the
    workpiece (the base frame on a machine without a table branch). The same motion takes a
    later run from the same place there, so a turn the tables give the volume stays in it."""

    def __init__(self, model: ErrorModel, q: np.ndarray, tool, points: np.ndarray):
        from vecpin.compensation.frame import model_as_actual, model_reference_frame
        from vecpin.measurement.registration import rigid_registration
        frame = model_reference_frame(model)
        tips = model_as_actual(model, frame=frame)(np.atleast_2d(q), np.asarray(tool, float), False)[0]
        self.R0, self.t0 = rigid_registration(tips, points)
        self.centre, self.R1 = np.zeros(3), np.eye(3)
        self.how = f"the model's reference frame ({frame.how}), the uncompensated run registered onto the model"


TRACKER_MOVED = 3e-3  # rad: a compensated run turned this far from the uncompensated one was read from another place


def _after_reference(machine: Machine, ref: RunReference, a: Campaign, nominal: np.ndarray, source: str):
    """(the reference the compensated run is judged in, notes, the frame's words): the
    uncompensated run's, so that a turn the tables give the working volume counts; the run's
    own when the tracker was evidently moved between the runs (said in a note)."""
    turn = ref.turn_of(nominal, a.xyz)
    if turn < TRACKER_MOVED:
        return ref, [], (f"both runs in {ref.how} (the tracker stayed where it was, so a turn the tables give the "
                         "working volume counts)")
    own = RunReference(machine, a.q, a.tool, nominal, a.xyz)
    return own, [f"{source} is turned {1e3 * turn:.1f} mrad from the uncompensated run: the "
                 "tracker was moved between the runs, so each run is judged in its own reference frame and a turn "
                 "of the working volume by the tables is not seen; read both runs from one tracker place"], (
        f"each run in its own reference frame ({ref.how})")


def _measure(machine: Machine, before: Campaign, after: Campaign, model: ErrorModel | None, dT: float,
             table: bool) -> _Measured:
    """Measured distances [mm] of both runs: at the tool tip (each run registered rigidly), or
    relative to the table from the nests read at each command (workpiece frame)."""
    if not table:
        b, a = before.primary(), after.primary()
        warnings = []
        if machine.has_workpiece:
            warnings.append(f"WARNING: {before.source} and {after.source} have no nest rows: both judged at the tool "
                            f"tip, which the table axes ({', '.join(machine.table_axes)}) do not move, so their "
                            "errors and their compensation are not seen; read table nests in both runs to judge the "
                            "tip relative to the table")
        nb = machine.tool_tip(b.q, b.tool, frame="base")
        na = machine.tool_tip(a.q, a.tool + dT, frame="base")
        ref = OnTheModel(model, b.q, b.tool, b.xyz) if model is not None else RunReference(machine, b.q, b.tool, nb,
                                                                                            b.xyz)
        ref_a, notes, frame = _after_reference(machine, ref, a, na, after.source)
        spindle = spindle_axis(machine)
        measured = [norm_mm(part_frame_errors(nb, ref(b.xyz), spindle)),
                    norm_mm(part_frame_errors(na, ref_a(a.xyz), spindle))]
        shape = [norm_mm(registered_errors(nb, b.xyz)), norm_mm(registered_errors(na, a.xyz))]
        return _Measured(b, a, measured, None, f"{FRAME_TEXT}; {frame}", notes, warnings, shape=shape)
    nests, refitted = table_nests([before, after], dict(model.setup_.nests) if model is not None else None)
    seen = [table_tips(run, nests, refitted) for run in (before, after)]
    for run, tt in zip((before, after), seen):
        if not len(tt.rows):
            few = "" if registers_table(run) else (" (the run reads fewer than three nests: two give the table's "
                                                    "place, not its turn about the line through them)")
            raise InputError(f"{run.source}: no command has tool rows and three or more nests read at it, so the "
                             f"tip relative to the table cannot be measured{few}; a run judged at the tool would not "
                             "show what the tables do to the table axes: read three or more nests at every command")
    b, a = before.subset(seen[0].rows), after.subset(seen[1].rows)
    nominal = [machine.tool_tip(c.q, c.tool + g, frame="workpiece") for c, g in ((b, 0.0), (a, dT))]
    to_ref = (OnTheModel(model, b.q, b.tool, seen[0].tip) if model is not None else
              RunReference(machine, b.q, b.tool, nominal[0], seen[0].tip))
    how = f"{to_ref.how}; both runs taken there by the same motion"
    frame = (f"{FRAME_TEXT}: the tool tip relative to the table (workpiece frame: every command's table pose from "
             f"its nests, nests {', '.join(sorted(nests))} " + ("re-fitted from the two runs" if refitted else
                                                               "where the model's fit put them") + f"), in {how}")
    spindle = spindle_axis(machine)
    residual = [part_frame_errors(n, to_ref(tt.tip), spindle) for n, tt in zip(nominal, seen)]
    shape = [norm_mm(registered_errors(n, tt.tip)) for n, tt in zip(nominal, seen)]
    from vecpin.measurement.noise import NoiseModel
    noise = model.noise_ if model is not None else NoiseModel.default(machine, "spherical")
    note = (f"tracker noise through the nest registration: {1e3 * np.nanmean(tip_noise(after, seen[1], noise.tracker)):.4f} "
            "mm mean on the compensated run (" + ("the model's" if model is not None else "default") +
            " tracker noise): the measured figures carry it")
    net = [net_of_noise(r, run, tt, noise, machine, removed=4) for r, run, tt in zip(residual, (before, after), seen)]
    return _Measured(b, a, [norm_mm(r) for r in residual], seen, frame, [note] + _face_unread(model), [], net, shape)


def _face_unread(model: ErrorModel | None) -> list[str]:
    """The note where the model's fit had no nest heights and no indicator sweep: the table's face was not read."""
    if model is None or len(getattr(model.setup_, "nest_heights", {})) >= 3 or getattr(model.setup_, "face_sweep", {}):
        return []
    return ["the table's face was not read (the fit had no heights of the nests above it): the table is taken as the "
            "model places it, and a tilt of the true face against that, which nests without their heights cannot "
            "show, adds to what a part clamped on the face sees; give the nests' heights to the fit to judge it"]


def _predict(machine: Machine, model: ErrorModel, tables: TableSet | None, m: _Measured, dT: float, table: bool,
             same: bool) -> tuple[np.ndarray, np.ndarray, str]:
    """The model's predicted distances [mm] for both runs and the line that says how."""
    b, a = m.b, m.a
    actual = model_as_actual(model)
    before = norm_mm(compensated_errors(actual, machine, None, b.q, b.tool))
    comp = compensated_errors(actual, machine, tables, a.q, a.tool)  # what the tables leave of the model
    ref = machine.tool_tip(a.q, a.tool + dT, frame="workpiece" if table else "base")
    if not same:
        return before, norm_mm(part_frame_errors(ref, ref + comp, spindle_axis(machine))), (
            f"{model.label()}; compensated: the error the tables leave of the model only "
            "(different commands, so the model's residual cannot be added)")
    # plus what the model does not describe: its residual on the uncompensated run
    if table:
        resid = registered_errors(actual(b.q, b.tool, False)[0], m.seen[0].tip)
    else:  # machine frame
        from vecpin.measurement.registration import rigid_registration
        feats = None
        if model.effects:
            from vecpin.measurement.features import Features
            feats = Features.from_campaign(b)
        predicted = model.predict_tip(b.q, b.tool, "machine", features=feats)
        R, t = rigid_registration(predicted, b.xyz)  # the run on the model: what is left is what it does not describe
        resid = (b.xyz - t) @ R - predicted
    return before, norm_mm(part_frame_errors(ref, ref + comp + resid, spindle_axis(machine))), (
        f"{model.label()}; compensated: the model's residual on the uncompensated run plus the error its tables "
        "leave of the model")


def compared_commands(machine: Machine, b: Campaign, a: Campaign, same: bool) -> str:
    """Which commands the runs measure: how many, the same or not, the axis ranges they
    span (mm, deg) and the holders: a run inside a zone judges that zone only."""
    q = machine.to_user(np.vstack([b.q, a.q]))
    span = ", ".join(f"{ax.name} {lo:.0f} .. {hi:.0f}" for ax, lo, hi in zip(machine.axes, q.min(axis=0), q.max(axis=0)))
    tools = ", ".join(f"{t / M_PER_MM:g}" for t in np.unique(np.round(np.r_[b.tool, a.tool], 6)))
    which = (f"the same {len(b)} commands in both runs" if same else
             f"{len(b)} commands before, {len(a)} after, not the same")
    return f"{which}; axes {span} (mm, deg; of the travel " + ", ".join(
        f"{ax.lower_user:.0f} .. {ax.upper_user:.0f}" for ax in machine.axes) + f"); holder {tools} mm"


def verify_to_dir(machine: Machine, before: Campaign, after: Campaign, out_dir: str | Path | None, **kw) -> Verification:
    """:func:`verify`, and with ``out_dir`` also ``verify.json`` and ``verify.png`` (Fig. 11)."""
    if out_dir is not None:
        from vecpin.fileio import check_output_dir
        check_output_dir(out_dir)
    v = verify(machine, before, after, **kw)
    if out_dir is None:
        return v
    from vecpin.fileio import OutputSet
    from vecpin.viz.figures import before_after_histograms
    with OutputSet(out_dir) as out:
        runs = {v.before.label: v.before, v.after.label: v.after}
        before_after_histograms({k: r.measured for k, r in runs.items()},
                                {k: r.predicted for k, r in runs.items() if r.predicted is not None},
                                out.path("verify.png"),
                                title="Validation runs before and after compensation, in the part's frame (Paper I Fig. 11)")
        v.files = [out.final("verify.png"), out.final("verify.json")]
        out.write_text("verify.json", json.dumps(v.to_dict(), indent=1) + "\n")
    return v


def load_tables(tables: str | Path, machine: Machine) -> tuple[TableSet, str]:
    """A table set from ``tables``: a ``tables.json`` file or the folder the tables were written into."""
    from vecpin.errors import InputError
    p = Path(tables)
    if p.is_dir():
        cand = p / "tables.json"
        if not cand.is_file():
            found = sorted(x.name for x in p.glob("*.json"))
            raise InputError(f"`tables` {p}: no tables.json in that folder (found: {', '.join(found) or 'nothing'})")
        p = cand
    if not p.is_file():
        raise InputError(f"`tables` {p}: no such file or folder")
    try:
        ts = TableSet.load_json(p, machine)
    except (ValueError, KeyError, TypeError, OSError) as exc:
        raise InputError(f"`tables` {p}: not a vecpin table file ({exc})") from None
    if ts.source and ts.source != machine.name:
        raise InputError(f"`tables` {p}: the tables are for machine '{ts.source}', not '{machine.name}'")
    return ts, str(p)
