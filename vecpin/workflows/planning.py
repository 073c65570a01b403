"""Plan a campaign and write its files (the ``plan`` command).

Files, written together (:class:`vecpin.fileio.OutputSet`): ``plan.csv`` (the campaign
template: commands and holder lengths in measurement order, empty x/y/z), the NC
programs ``PLAN_840D.MPF`` (Siemens 840D), ``O1000.nc`` (Fanuc), ``plan.ngc`` (plain
G-code), the validation run ``validation.csv`` with its programs ``VALID_840D.MPF``,
``O1001.nc``, ``validation.ngc``, ``plan.png`` (Paper I Fig. 6: kept and removed points, tracker) and
``plan.json`` (settings, counts and predicted figures; no time stamps, so a rerun
writes the same bytes).
"""
from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from vecpin.errors import InputError, VecpinWarning
from vecpin.fileio import OutputSet, check_output_dir
from vecpin.kinematics.machine import Machine
from vecpin.measurement.nestheights import NEST_HEIGHTS_FILE, nest_heights_csv
from vecpin.measurement.partframe import table_turns
from vecpin.measurement.tableface import SWEEP_SD_UM, TABLE_FACE_FILE, swept_axes, table_face_csv
from vecpin.measurement.plantemplate import PlanTemplate, read_template
from vecpin.measurement.repeatability import SESSION_GAP_S
from vecpin.kinematics.axes import is_arm
from vecpin.planning.armpose import arm_clearance
from vecpin.planning.armprogram import (APPROACH_SPEED, MOVE_SPEED, arm_dialects, arm_program_name, arm_route,
                                        arm_time, write_arm_program)
from vecpin.planning.sightline import SightLine
from vecpin.planning.ncprogram import (DIALECTS, READ_DWELL_S, check_program_options, nc_axis_names, program_name,
                                      retract_axis, retract_travel_mm, safe_position, write_program)
from vecpin.planning.route import axis_speeds
from vecpin.planning.plan import Plan, PlanScore, PlanSettings, compare, make_plan
from vecpin.planning.planchecks import t_offset_identified
from vecpin.planning.problem import check_safe_height
from vecpin.planning.timing import HOLDER_CHANGE_S, TRACKER_MOVE_S, CampaignTime, ProgramTiming, row_times, run_times
from vecpin.units import M_PER_MM, MM_PER_M, to_mm


@dataclass
class PlanRun:
    plan: Plan
    files: list[Path]
    comparison: list[PlanScore] = field(default_factory=list)
    program: str = ""   # what the NC programs do between and at the points (one line)
    time: CampaignTime | None = None  # the campaign's time as its NC program runs
    timing: ProgramTiming | None = None
    validation_time: CampaignTime | None = None
    validation_time_once: CampaignTime | None = None  # the same run reading every point once
    nest_heights: bool = True   # the nests' heights above the table's face asked for (nest_heights.csv)

    def lines(self) -> list[str]:
        p, s = self.plan, self.plan.settings
        m = p.machine
        c = p.counts()
        tr = [int(round(float(v))) + 0 for v in to_mm(p.tracker)]  # whole mm, no "-0"
        if p.tracker_given:
            where = "given"
        elif p.tracker_side in ("", "-y"):
            where = "assumed 2 m in front of the workspace (-y side), at its lowest tip; give `tracker_mm` X,Y,Z"
        else:
            where = (f"assumed 2 m beyond the workspace on its {p.tracker_side} side, from which the tips are in "
                     "sight; give `tracker_mm` X,Y,Z")
        info = p.information
        out = [f"measurement plan for {m.name}: {len(p.commands)} commands x {len(s.tools_mm)} holder lengths "
               f"({', '.join(f'{t:g}' for t in s.tools_mm)} mm) = {len(p.template)} rows",
               f"  model {s.model} order {s.order}: {info.P} parameters with E_0"
               + (f" and {len(p.nests)} nest positions" if p.nests else "")
               + ("" if not info.stations else " and the second tracker station's pose" if len(info.stations) == 1
                  else f" and {len(info.stations)} more tracker stations' poses")
               + f", {int((~info.keep).sum())} that no design identifies left out",
               f"  tracker at ({tr[0]}, {tr[1]}, {tr[2]}) mm, machine frame ({where})",
               f"  candidates {c['candidates']}: {c['exclusion']} in exclusion zones (CA), {c['collision']} with a holder "
               f"in the machine's geometry (collisions), {c['sight']} out of sight (LoS, {p.geometry} geometry), "
               f"{c['kept']} left; chosen {s.method}"]
        out += self.nest_lines()
        if "approach" in c:
            out.append(f"  approach along the tool axis ({s.approach_mm:g} mm back, the arm's pre-pose): "
                       f"{c['approach']} candidates left out (out of reach, a joint limit, near a singularity, or a "
                       "holder in the geometry)")
        if c["sight"]:
            names, counts = np.unique(p.sight_by[p.removed == "sight"].astype(str), return_counts=True)
            top = sorted(zip(counts, names), reverse=True)[:4]
            out.append("  sight blocked by: " + ", ".join(f"{n} ({k})" for k, n in top))
        if s.repeat_points:
            out.append(f"  repeated points (eq. 22): {s.repeat_points} commands x {s.repeat_times} sequences, "
                       "half at the start and half at the end (short- and long-term repeatability)")
            if self.time is not None and self.time.total_s < SESSION_GAP_S:
                out.append(f"    the campaign takes {self.time.total_s / 60:.0f} min, less than the "
                           f"{SESSION_GAP_S / 60:.0f} min that part two sessions: its repeats give the short-term "
                           "repeatability only (assess calls it optimistic); for the long-term one, let that long pass "
                           "before the repeats at the end (a program stop)")
        else:
            out.append("  no repeated points: the decision (assess) needs the machine's repeatability, measured on "
                       "commands repeated in the campaign; add them, e.g. `repeat_points` 9, `repeat_times` 4: nine "
                       "commands measured four times")
        sc = p.score
        pr = sc.predicted
        out += [f"  approach: {s.approach} ({s.approach_mm:g} mm / {s.approach_deg:g} deg); moves "
                f"{sc.travel_s / 60:.1f} min in this order (the same commands in random order: "
                f"{p.travel_random_s / 60:.1f} min)",
                f"  predicted (linearised covariance, {pr.points} quasi-random validation commands, holder "
                f"{s.tools_mm[0]:g} mm, " + ("tool tip relative to the workpiece, " if pr.frame == "workpiece" else "")
                + "best-fit rigid motion removed):",
                f"    model error from parameter uncertainty: mean {to_mm(pr.model_mean):.4f} mm, max "
                f"{to_mm(pr.model_max):.4f} mm (1-sigma RMS {to_mm(pr.rms_1sigma):.4f} mm)",
                f"    validation residual incl. measurement noise: mean {to_mm(pr.measured_mean):.4f} mm, max "
                f"{to_mm(pr.measured_max):.4f} mm",
                (f"    gauge line T_offset: 1-sigma {to_mm(sc.t_offset_sigma):.4f} mm; "
                 if t_offset_identified(info, p.covariance, s.expected_error_mm) else
                 f"    gauge line T_offset: not identifiable with this plan (1-sigma {to_mm(sc.t_offset_sigma):.2f} mm; "
                 "set it on a tool presetter); " if info.keep[6] else
                 "    gauge line T_offset: no design identifies it (another term moves every reading alike); ")
                + f"{sc.well_determined} of "
                f"{sc.counted} counted terms below 10% of their prior",
                "    (what the model cannot describe adds to these: judge it with a validation run)"]

        if self.comparison:
            out.append("  comparison (same model, noise, tracker and validation commands):")
            out += PlanScore.header() + [x.line() for x in self.comparison]
        if self.program:
            out.append(f"  {'arm' if is_arm(p.machine) else 'NC'} programs: {self.program}")
        if self.time is not None:
            out.append(f"  {self.time.line()}")
        out += self.validation_lines()
        out += [f"  wrote {f}" for f in self.files]
        return out

    def validation_lines(self) -> list[str]:
        """The validation run: which commands, where they are written, how long it takes."""
        p = self.plan
        v = p.validation_template
        if v is None:
            return []
        reads = p.validation_reads
        n = len(v.tool_rows) // reads
        took = f", {self.validation_time.total_s / 60:.0f} min a run" if self.validation_time is not None else ""
        if reads > 1 and self.validation_time_once is not None:
            took += f" ({self.validation_time_once.total_s / 60:.0f} min reading every point once)"
        return [f"  validation run: {n} quasi-random commands inside the measured zone, free and in sight with the "
                f"{p.settings.tools_mm[0]:g} mm holder" + (f", {len(v.nest_rows)} table nest readings" if v.has_nests
                                                           else "")
                + (f"; the tool and each nest read {reads} times in a row at every command, the machine standing "
                   "still (a dwell per reading, no move between them; their mean is judged: less tracker noise at "
                   "the tip)" if reads > 1 else "")
                + f" (validation.csv and its NC programs{took}): measure them without the tables and again with "
                "them; a simulation of the plan uses the same commands"]

    def nest_lines(self) -> list[str]:
        """What the table nests add (none on a machine without table axes)."""
        p = self.plan
        if not p.machine.has_workpiece:
            return []
        if not p.nests:
            left = int((~p.information.keep[p.information.model_columns]).sum())
            return [f"  no table nests (`nests` 0): the tool tip alone never sees the table axes; {left} model terms "
                    "stay unknown and uncorrected (plan with `nests` 3 to read reflectors on the table)"]
        t = p.template
        seen = int(np.sum(t.stations[t.nest_rows] == 0))
        table = int(p.information.table_terms().sum())
        before = int((~p.bare.keep[p.bare.model_columns]).sum())
        places = "; ".join(f"{k} ({', '.join(f'{v:.0f}' for v in to_mm(x) + 0.0)})" for k, x in p.nests.items())
        a, b = p.score.predicted, p.without_nests.predicted
        return [f"  table nests: {len(p.nests)} reflectors on the table, mm in the workpiece frame (planned; the fit "
                f"finds them): {places}",
                f"    read at the dwell of each command with the first holder: {seen} nest rows of "
                f"{len(p.commands) * len(p.nests)} (the others are out of sight)",
                f"    table-axis terms identified: {table} of the {before} model terms that tool-tip readings alone "
                "leave out",
                f"    predicted error of the tool tip relative to the workpiece: mean {to_mm(a.model_mean):.4f} mm, "
                f"max {to_mm(a.model_max):.4f} mm with the nests; mean {to_mm(b.model_mean):.4f} mm, max "
                f"{to_mm(b.model_max):.4f} mm without them (the table errors' prior)", self.heights_line()] + \
            ([self.sweep_line()] if self.sweep_axes else []) + \
            ([f"    {x}" for x in p.placement.lines(p.machine)] if p.placement else [])

    def heights_line(self) -> str:
        """What the operator measures of the nests for the fit to see the table's face, and where it goes."""
        if not self.nest_heights:
            return ("    heights above the table's face: not asked (declined): the fit sees the nests, not the face; "
                    "the tables keep the table where the model places it, and a tilt of the true face against that "
                    "stays in what a part clamped on it sees")
        planned = ", ".join(f"{k} at {float(x[2]) * MM_PER_M:.0f}" for k, x in sorted(self.plan.nests.items()))
        return (f"    heights above the table's face: once the nests are placed, measure each reflector centre's "
                f"height above the face, mm (a height gauge on the face: the reflector's top less its radius), and "
                f"write it in {NEST_HEIGHTS_FILE}, column height_mm (planned: {planned} mm); give that file to the fit "
                "(`nest_heights`): it then finds the face, and the tables keep the table a part is clamped to")

    @property
    def sweep_axes(self) -> list[str]:
        """The linear axes that move a dial test indicator across the table's face, where the table turns
        (the face's parallelism the plan asks for: :data:`~vecpin.measurement.tableface.TABLE_FACE_FILE`)."""
        m = self.plan.machine
        return list(swept_axes(m)) if self.plan.nests and table_turns(m) else []

    def sweep_line(self) -> str:
        """How to read the table face's parallelism with an indicator, and where it goes."""
        axes, m, q = self.sweep_axes, self.plan.machine, np.asarray(self.plan.commands, float)
        mid = ", ".join(f"{a} {0.5 * (q[:, k].min() + q[:, k].max()) * MM_PER_M:.0f} mm" for a in axes
                        for k in [m.axis(a).index])
        return (f"    the table face's parallelism (the indicator reads a few µrad; through the fitted model's lines of "
                f"motion it places the face to about 10-15 µrad in simulation, the nests' heights to 70-150): every "
                f"rotary axis at 0, a dial test indicator in the spindle touching the face, move "
                f"{' and then '.join(axes)} across it (a few hundred mm, away from the nests and clamps), each sweep "
                f"centred on the middle of the travel the plan measures ({mid}; the fit reads the model's line of "
                f"motion over that stretch, and a line that is not straight has another slope elsewhere); write per "
                f"axis the distance moved, mm, and the indicator's change over it, µm, + when pushed in as the command "
                f"increases, in {TABLE_FACE_FILE} (sd_um: the reading's standard deviation, {SWEEP_SD_UM:g} µm "
                f"assumed); give that file to the fit (`table_face`)")

    def to_dict(self) -> dict:
        p, s = self.plan, self.plan.settings

        def score(x: PlanScore) -> dict:
            pr = x.predicted
            return {"label": x.label, "rows": x.rows, "commands": x.commands, "log_det": round(x.log_det, 6),
                    "t_offset_sigma_mm": round(float(to_mm(x.t_offset_sigma)), 6),
                    "well_determined": x.well_determined, "counted": x.counted,
                    "model_mean_mm": round(float(to_mm(pr.model_mean)), 6),
                    "model_max_mm": round(float(to_mm(pr.model_max)), 6),
                    "validation_mean_mm": round(float(to_mm(pr.measured_mean)), 6),
                    "validation_max_mm": round(float(to_mm(pr.measured_max)), 6),
                    "moves_min": round(x.travel_s / 60, 4)}
        return {"format": "vecpin-plan", "version": 1, "machine": p.machine.name,
                "settings": {"points": s.n_commands, "nests": len(p.nests), "tools_mm": list(s.tools_mm), "model": s.model, "order": s.order,
                             "method": s.method, "approach": s.approach, "approach_mm": s.approach_mm,
                             "approach_deg": s.approach_deg, "repeat": [s.repeat_points, s.repeat_times],
                             "exclude": [{k: list(v) for k, v in z.items()} for z in s.exclude],
                             "zone": None if s.zone is None else {k: list(v) for k, v in s.zone.items()},
                             "seed": s.seed, "noise": p.information.noise.to_dict(p.machine)},
                "tracker_mm": [round(float(v), 6) for v in to_mm(p.tracker)], "tracker_given": p.tracker_given,
                "stations_mm": [[round(float(v), 6) for v in to_mm(x)] for x in plan_stations(p)],
                "counts": p.counts(), "geometry": p.geometry,
                "nests_mm": {k: [round(float(v), 6) for v in to_mm(x)] for k, x in p.nests.items()},
                "nest_heights": (NEST_HEIGHTS_FILE if self.nest_heights else "declined") if p.nests else None,
                "table_face": TABLE_FACE_FILE if self.sweep_axes else None,
                "score": score(p.score), "comparison": [score(x) for x in self.comparison[1:]],
                "without_nests": None if p.without_nests is None else score(p.without_nests),
                "moves_random_order_min": round(p.travel_random_s / 60, 4),
                "expected_error_mm": s.expected_error_mm,
                "warnings": list(p.warnings),
                "validation": None if p.validation_template is None else
                {"commands": len(p.validation_template.tool_rows) // p.validation_reads,
                 "rows": len(p.validation_template),
                 "minutes": None if self.validation_time is None else round(self.validation_time.total_s / 60, 4)}
                | ({"reads": p.validation_reads, "minutes_one_reading": None if self.validation_time_once is None
                    else round(self.validation_time_once.total_s / 60, 4)} if p.validation_reads > 1 else {}),
                "campaign_time": None if self.time is None else self.time.to_dict(),
                "program": None if self.timing is None else timing_dict(self.timing)}


def plan_to_dir(machine: Machine, out_dir: str | Path, settings: PlanSettings, *, dialects=None,
                dwell_s: float = 4.0, nest_dwell_s: float = 15.0, feed_mm_min: float = 1000.0,
                safe_z_mm: float | None = None, retract: str | None = None, axis_map: dict | None = None,
                compare_with: list[str] = (), progress: Callable[[str], None] | None = None,
                holder_change_s: float = HOLDER_CHANGE_S, tracker_move_s: float = TRACKER_MOVE_S,
                read_dwell_s: float = READ_DWELL_S, nest_heights: bool = True) -> PlanRun:
    """Plan (see :func:`vecpin.planning.plan.make_plan`) and write the files into ``out_dir``.

    The NC programs' options (``dwell_s``, ``nest_dwell_s``, ``feed_mm_min``, ``safe_z_mm``,
    ``retract``, ``axis_map``; ``read_dwell_s``: the validation run's dwell per further
    reading of a point at its standstill): :func:`vecpin.planning.ncprogram.write_program`.
    ``compare_with``: other plans to judge beside this one: template CSV paths, or
    "random" (the same number of commands at random from the same candidates).
    ``holder_change_s``, ``tracker_move_s``: the time of a holder change and of moving the
    tracker to another station, for the campaign's time (:mod:`vecpin.planning.timing`).
    The plan's warnings (:mod:`vecpin.planning.planchecks`) are issued as
    :class:`~vecpin.errors.VecpinWarning` before the files are written. ``dialects``: the
    programs to write (default: every NC dialect; on an arm, :func:`is_arm`, every arm
    program of :mod:`vecpin.planning.armprogram`, which approach along the tool axis). ``nest_heights``: with
    table nests, write :data:`~vecpin.measurement.nestheights.NEST_HEIGHTS_FILE` for the heights of their
    reflectors above the table's face, which the operator measures (False: not asked); where the
    table turns, :data:`~vecpin.measurement.tableface.TABLE_FACE_FILE` for the face's parallelism
    read with an indicator swept along the axes that cross it."""
    check_output_dir(out_dir)
    check_program_options(dwell_s, feed_mm_min, nest_dwell_s, read_dwell_s)
    arm = is_arm(machine)
    dialects, r, up = program_request(machine, dialects, retract, safe_z_mm, axis_map)
    settings.check()   # the settings alone (holder lengths, ...) before the figures' imports
    ProgramTiming(np.ones(machine.n_axes), np.zeros(machine.n_axes), holder_change_s=holder_change_s,
                  tracker_move_s=tracker_move_s).check()
    from vecpin.viz.figures import plan_figure
    templates = {c: read_template(c, machine) for c in compare_with if c != "random"}  # a bad file fails now
    plan = make_plan(machine, settings, progress)
    for w in plan.warnings:
        warnings.warn(VecpinWarning(w), stacklevel=2)
    others: list[tuple[str, PlanTemplate]] = []
    for c in compare_with:
        if c == "random":
            from dataclasses import replace
            rp = make_plan(machine, replace(settings, method="random"), None)
            others.append(("random commands", rp.template))
        else:
            others.append((Path(c).name, templates[c]))
    comparison = compare(plan, others) if others else []
    files = []
    with OutputSet(out_dir) as out:
        files.append(out.write_text("plan.csv", plan.template.to_csv(machine)))
        if arm:
            return _arm_run(out, machine, plan, files, comparison, dialects, (dwell_s, nest_dwell_s, read_dwell_s),
                            holder_change_s)
        sight = None if not settings.sight else SightLine(machine, plan.tracker, geometry=settings.geometry)
        files += _nc_programs(out, machine, plan, dialects, sight, dict(
            dwell_s=dwell_s, nest_dwell_s=nest_dwell_s, feed_mm_min=feed_mm_min, safe_z_mm=safe_z_mm, retract=retract,
            axis_map=axis_map), read_dwell_s)
        v = plan.validation_template
        plan_figure(plan, out.path("plan.png"))
        files.append(out.final("plan.png"))
        t = plan.template
        nests = int(np.sum(t.instrument == "nest")) if t.instrument is not None else 0
        dwells = (len(t) - nests) * dwell_s + nests * nest_dwell_s
        lifts = retract_travel_mm(machine, t, plan.steps, safe_z_mm, retract, sight)
        speed = axis_speeds(machine, settings.rapid_mm_min, settings.rapid_deg_min)[r]
        program = (f"{machine.axis_names[r]} to {safe_position(machine, r, up, safe_z_mm):g} mm (machine coordinates, "
                   f"`safe_z_mm`) before every move between points: {lifts / 1000:.1f} m up and down, "
                   f"{lifts * M_PER_MM / speed / 60:.1f} min at its rapid speed; dwells {dwell_s:g} s per point"
                   + (f" + {nest_dwell_s:g} s per nest reading" if nests else "") + f": {dwells / 60:.1f} min"
                   + f"; approach clearance {settings.approach_mm:g} mm / {settings.approach_deg:g} deg, "
                   f"{machine.axis_names[r]} from the side away from the work"
                   + (", every move of the programs checked against the machine's geometry" if sight else ""))
        timing = program_timing(machine, plan, dwell_s=dwell_s, nest_dwell_s=nest_dwell_s, feed_mm_min=feed_mm_min,
                                safe_z_mm=safe_z_mm, retract=retract, holder_change_s=holder_change_s,
                                tracker_move_s=tracker_move_s, read_dwell_s=read_dwell_s)
        _, run_time, once = run_times(machine, v, timing, plan.validation_reads)
        run = PlanRun(plan, files, comparison, program if dialects else "", row_times(machine, t, timing)[1], timing,
                      run_time, once, nest_heights)
        files += _face_files(out, run)
        files.append(out.final("plan.json"))
        out.write_text("plan.json", json.dumps(run.to_dict(), indent=1) + "\n")
    return run


def _face_files(out: OutputSet, run: PlanRun) -> list[Path]:
    """The files the operator fills in of the table's face: the nests' heights (where asked) and, where the
    table turns, the indicator's sweeps."""
    files = []
    if run.plan.nests and run.nest_heights:
        files.append(out.write_text(NEST_HEIGHTS_FILE, nest_heights_csv(run.plan.nests)))
    if run.sweep_axes:
        files.append(out.write_text(TABLE_FACE_FILE, table_face_csv(run.sweep_axes)))
    return files


def _nc_programs(out: OutputSet, machine: Machine, plan: Plan, dialects, sight, opts: dict,
                 read_dwell_s: float) -> list[Path]:
    """Write the plan's NC program and its validation run's (with validation.csv between)
    in each dialect; ``opts``: :func:`~vecpin.planning.ncprogram.write_program`'s options."""
    files = []
    for d in dialects:
        text = write_program(d, machine, plan.template, plan.steps, title=f"for {machine.name}",
                             stations=plan_stations(plan), sight=sight, **opts)
        files.append(out.write_text(program_name(d), text))
    v = plan.validation_template
    files.append(out.write_text("validation.csv", v.to_csv(machine)))
    for d in dialects:
        text = write_program(d, machine, v, plan.steps, program_number=1001,
                             title=f"- validation run for {machine.name}", reads=plan.validation_reads,
                             read_dwell_s=read_dwell_s, sight=sight, **opts)
        files.append(out.write_text(program_name(d, "validation"), text))
    return files


def _arm_run(out: OutputSet, machine: Machine, plan: Plan, files: list, comparison: list, dialects: tuple[str, ...],
             dwells: tuple[float, float, float], holder_change_s: float) -> PlanRun:
    """Write an arm's programs of the plan and its validation run
    (:mod:`vecpin.planning.armprogram`; ``dwells`` [s]: the tool's, a nest's, a further
    reading's) and return the run with their times."""
    c = arm_clearance(plan.settings)
    v = plan.validation_template
    times = []
    sight = SightLine(machine, plan.tracker, geometry=plan.settings.geometry,
                      tool_radius=plan.settings.tool_radius_mm * M_PER_MM)
    for t, run, title in ((plan.template, "plan", f"for {machine.name}"),
                          (v, "validation", f"- validation run for {machine.name}")):
        reads = plan.validation_reads if run == "validation" else 1
        route = arm_route(machine, t, c, dwells, reads, sight)
        for m in route[1]:
            warnings.warn(VecpinWarning(f"{arm_program_name(dialects[0], run)}: the move {m}: no route frees it "
                                        "(the program's header says so): jog it by hand"))
        for d in dialects:
            text = write_arm_program(d, machine, t, c, dwell_s=dwells[0], nest_dwell_s=dwells[1],
                                     read_dwell_s=dwells[2], reads=reads, title=title, route=route,
                                     radius=sight.holder_radius)
            files.append(out.write_text(arm_program_name(d, run), text))
        times.append(arm_time(t, route[0], holder_change_s))
        if run == "plan":
            files.append(out.write_text("validation.csv", v.to_csv(machine)))
    program = (f"joint moves at {MOVE_SPEED:g} rad/s between points; each point approached from {c * 1000:g} mm back "
               f"along the tool axis at {APPROACH_SPEED:g} rad/s; dwells {dwells[0]:g} s per point"
               if c > 0 else f"joint moves at {MOVE_SPEED:g} rad/s straight to each point; dwells {dwells[0]:g} s")
    from vecpin.viz.figures import plan_figure
    plan_figure(plan, out.path("plan.png"))
    files.append(out.final("plan.png"))
    run = PlanRun(plan, files, comparison, program, times[0], None, times[1], times[1])
    files.append(out.final("plan.json"))
    out.write_text("plan.json", json.dumps(run.to_dict(), indent=1) + "\n")
    return run


def program_request(machine: Machine, dialects, retract: str | None, safe_z_mm: float | None,
                    axis_map: dict | None) -> tuple[tuple[str, ...], int | None, int | None]:
    """The programs to write (default per kind of machine), the retract axis and its
    direction (None on an arm), every program option checked before the planning (an
    arm has no axis to retract with; an axis without an NC address in a dialect asked for)."""
    if is_arm(machine):
        if retract is not None or safe_z_mm is not None:
            raise InputError(f"`retract`/`safe_z_mm`: {machine.name} is an arm, it has no axis to retract with; its "
                             "program backs off along the tool axis (`approach_mm`)")
        return arm_dialects(dialects, machine), None, None
    dialects = tuple(d for d in DIALECTS if d != "heidenhain") if dialects is None else tuple(dialects)
    r, up = retract_axis(machine, retract)
    safe_position(machine, r, up, safe_z_mm)
    check_safe_height(machine, r, up, safe_z_mm)
    for d in dialects:
        nc_axis_names(machine, d, axis_map)
    return dialects, r, up


def plan_stations(plan: Plan) -> list[np.ndarray]:
    """The tracker stations (3,) [m], machine base frame, by station id: the plan's
    tracker, then a second station when the nest placement proposed one (the template's
    ``station`` column reads its block from there)."""
    return [np.asarray(x, float) for x in plan.placement.stations] if plan.placement else [plan.tracker]


def plan_station_positions(path: str | Path) -> list[np.ndarray] | None:
    """The tracker stations (3,) [m] of a plan, machine base frame, by station id, from
    plan.json beside the template ``path`` (None when there is none or it is from an older
    vecpin)."""
    js = Path(path).with_name("plan.json")
    if not js.is_file():
        return None
    try:
        d = json.loads(js.read_text(encoding="utf-8")).get("stations_mm")
        return None if d is None else [np.asarray(x, float).reshape(3) * M_PER_MM for x in d]
    except (ValueError, TypeError, AttributeError) as exc:
        raise InputError(f"{js}: not a plan.json vecpin wrote ({exc}); plan again or remove it") from None


def program_timing(machine: Machine, plan: Plan, *, dwell_s: float, nest_dwell_s: float, feed_mm_min: float,
                   safe_z_mm: float | None, retract: str | None, holder_change_s: float,
                   tracker_move_s: float = TRACKER_MOVE_S, read_dwell_s: float = READ_DWELL_S) -> ProgramTiming:
    """The NC program's timing settings of ``plan`` (its rapid speeds and approach steps)."""
    s = plan.settings
    return ProgramTiming(axis_speeds(machine, s.rapid_mm_min, s.rapid_deg_min), plan.steps, dwell_s, nest_dwell_s,
                         holder_change_s, feed_mm_min, safe_z_mm, retract, tracker_move_s, read_dwell_s)


def timing_dict(t: ProgramTiming) -> dict:
    """plan.json's "program": what the simulator needs to time the plan's rows as the program runs them."""
    return {"dwell_s": t.dwell_s, "nest_dwell_s": t.nest_dwell_s, "holder_change_s": t.holder_change_s,
            "tracker_move_s": t.tracker_move_s, "read_dwell_s": t.read_dwell_s,
            "feed_mm_min": t.feed_mm_min, "safe_z_mm": t.safe_z_mm, "retract_axis": t.retract,
            "speed_si": [round(float(v), 9) for v in t.speed], "steps_si": [round(float(v), 12) for v in t.steps]}


def plan_timing(path: str | Path) -> ProgramTiming | None:
    """The program timing written with a plan template: plan.json beside ``path`` (None
    when there is none or it is from an older vecpin)."""
    js = Path(path).with_name("plan.json")
    if not js.is_file():
        return None
    try:
        d = json.loads(js.read_text(encoding="utf-8")).get("program")
        if not d:
            return None
        return ProgramTiming(np.array(d["speed_si"], float), np.array(d["steps_si"], float), float(d["dwell_s"]),
                             float(d["nest_dwell_s"]), float(d["holder_change_s"]), float(d["feed_mm_min"]),
                             d["safe_z_mm"], d["retract_axis"], float(d["tracker_move_s"]),
                             float(d.get("read_dwell_s", READ_DWELL_S)))  # older plan.json: the default
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise InputError(f"{js}: not a plan.json vecpin wrote ({exc}); plan again or remove it") from None
