"""From a fitted model to controller files (the ``tables`` command), and the sign check.

The controller name resolves to its format (:mod:`vecpin.export.registry`); the
machine's controller profile and ``axis_map`` supply the facts the writer needs;
the format's limits, overridden by the profile, go down to the table layer. Every
limit and every missing fact is checked before the first solve. After writing, the
files are read back with the format's reader: the report gets a row for the tables
as the controller will hold them, and the sign test predicts from them.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from vecpin.compensation.limits import ControllerLimits
from vecpin.compensation.plan import TablePlan, add_as_written_row, gauge_effect, plan_tables, unfolded_label
from vecpin.compensation.tables import TableSet, table_name
from vecpin.kinematics.axes import is_arm
from vecpin.errors import ControllerFileError, ControllerLimitError, InputError
from vecpin.export import boundary, drives, generic
from vecpin.export.common import ControllerFormat, ExportJob, UserCommands, with_constants
from vecpin.export.profile import ControllerProfile
from vecpin.export.registry import get_format
from vecpin.export.signtest import (SignTest, SignVerdict, evaluate_sign_test, find_table, plan_sign_test, read_check,
                                    sign_tag, write_sign_test)
from vecpin.fileio import OutputSet, check_output_dir
from vecpin.measurement.campaign import Campaign
from vecpin.models import ErrorModel
from vecpin.planning.zones import check_zone_units, zone_text
from vecpin.units import MM_PER_M, slip_text

LOST_SHARE = 0.02    # files giving up more than this share of what the full tables remove say so first
ROUNDING_MM = 0.001  # ... and more than this [mm] (the files' number format rounds to 0.1-1 um)


def named_axis(machine, name: str, option: str, value: str | None = None):
    """``machine.axis(name)``, the error naming the parameter ``option`` that gave the name
    (and its ``value`` when the name is part of it)."""
    if name not in machine.axis_names:
        raise InputError(f"`{option}` {value or name}: machine '{machine.name}' has no axis '{name}' (axes: "
                         f"{', '.join(machine.axis_names)}; names are case-sensitive)")
    return machine.axis(name)


def parse_axis_map(items: list[str], machine) -> dict[str, str]:
    """``JOINT=NCNAME`` items -> {joint: NC axis name}; every joint must exist and no two
    joints may share an NC name."""
    out: dict[str, str] = {}
    for it in items:
        if "=" not in it:
            raise InputError(f"`axis_map` takes JOINT=NCNAME, not '{it}'")
        a, b = (x.strip() for x in it.split("=", 1))
        named_axis(machine, a, "axis_map", it)
        if not b:
            raise InputError(f"`axis_map` {it}: the NC axis name is empty")
        out[a] = b
    names = list(out.values())
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        n = sorted(dup)[0]
        joints = [a for a, b in out.items() if b == n]
        raise InputError(f"`axis_map`: joints {', '.join(joints)} are all mapped to NC axis {n}; each joint needs "
                         "its own NC axis")
    return out


def resolve(controller: str, machine, profile: ControllerProfile | str | Path | None = None,
            axis_map: dict[str, str] | None = None) -> tuple[ControllerFormat, ControllerProfile, ControllerLimits]:
    """(format, profile, limits) of a controller name for a machine; the profile's facts
    are checked against the machine (no table work yet)."""
    fmt = get_format(controller)
    if profile is None:
        prof = ControllerProfile()
    elif isinstance(profile, ControllerProfile):
        prof = profile
    else:
        prof = ControllerProfile.load(profile)
    prof = prof.with_axis_map(axis_map or {})
    prof.check_machine(machine, controller)
    limits = fmt.limits_for(prof)
    return fmt, prof, limits


@dataclass
class TableRun:
    plan: TablePlan
    files: list[Path]
    commands_source: str | None
    controller: str
    notes: list[str] = field(default_factory=list)
    as_written: TableSet | None = None
    sign_test: SignTest | None = None
    headline: str | None = None   # the files leave more than the full tables: how much and why (printed first)
    warnings: list[str] = field(default_factory=list)  # printed before the headline: files that fail used apart
    gauge_effect: dict | None = None  # mean error [mm] with the gauge-line change entered / not / flipped

    def _table_names(self, grid: str) -> list[str]:
        """The line naming the tables; an arm's read as joints (J2(J1)), with the key to them."""
        tables, m = self.plan.tables, self.plan.problem.machine
        if not is_arm(m):
            terms = (f"; product terms {' '.join(p.name for p in tables.products)}: two tables each"
                     if tables.products else "")
            return [f"  tables: {' '.join(tables.names())}  ({len(tables.tables)} tables, {grid}{terms})"]
        labels = boundary.joint_labels(m.axis_names)
        named = " ".join(boundary.arm_table_label(t.output_axis, t.input_axis, labels) for t in tables.tables)
        return [f"  tables: {named}  ({len(tables.tables)} tables, {grid}; J2(J1): the error of J2 as J1 moves)",
                "  joints: " + ", ".join(f"{v} {k}" for k, v in labels.items())
                + f" (the files name the tables by the joints, e.g. {tables.names()[0]})"]

    def lines(self, model_name: str) -> list[str]:
        plan = self.plan
        m_name = plan.problem.machine.name
        out = list(self.warnings) + ([self.headline] if self.headline else [])
        out.append(f"compensation tables for {m_name} ({self.controller}), model {model_name}")
        grid = ("resampled on the controller's grid (see its README)" if plan.limits.resampled
                else f"{plan.points} points each")
        arm = is_arm(plan.problem.machine)
        out += self._table_names(grid)
        out.append("  " + boundary.gauge_text(self.controller, plan.tables.gauge_offset_change, self.gauge_effect, arm)
                   + (" (the controller's README in the output folder says it too)"
                      if any(f.name.startswith("README_") for f in self.files) else ""))
        if plan.selection is not None:
            s = plan.selection
            out.append(f"  selection ({s.method}): {' '.join(s.tables)} in {s.seconds:.2f} s, "
                       f"{s.evaluations} combinations scored")
        out.append(plan.report.table())
        out += [f"  {n}" for n in self.notes]
        if self.sign_test is not None:
            st = self.sign_test
            out.append(f"  sign test {st.table}: {st.input_axis} at {st.positions[0]:.3f} and {st.positions[1]:.3f} "
                       f"{st.input_unit}, predicted shift {st.predicted:+.4f} {st.output_unit} "
                       f"(SIGNTEST_{sign_tag(st.table)}.md)")
        out += [f"  wrote {f}" for f in self.files]
        return out


def make_tables(model: ErrorModel, out_dir: str | Path, controller: str = "generic", *,
                profile: ControllerProfile | str | Path | None = None, axis_map: dict | None = None,
                max_tables: int | None = None, no_circular: bool = False, forbid_output=(), method: str = "exact",
                points: int | None = None, tools_mm=None, modulo_axes=(), commands: Campaign | None = None,
                sign_test: str | None = None, uncertainty: bool = True, zone=None,
                user_commands: UserCommands | None = None, progress: Callable[[str], None] | None = None,
                products: bool | None = None) -> TableRun:
    """Tables of ``model`` for ``controller``, written into ``out_dir`` with the generic files.

    ``profile``: the machine's controller profile (path or object); ``axis_map``: NC axis
    names that win over the profile's; ``sign_test``: an axis (its pitch table) or a
    table name for which to write a sign-test program; ``zone``: {axis: (low, high)}
    mm/deg, the region the tables are fitted in (default: the model's zone);
    ``user_commands``: how the READMEs name the sign test's commands (default: the Python
    calls; the command line gives its commands); ``products``: product terms on a turning table, as
    :func:`~vecpin.compensation.plan.plan_tables` takes them (None: its default). A profile
    axis with a following drive gets its tables for both drives, and a gantry skew of
    the model on it a differential table between them (:mod:`vecpin.export.drives`)."""
    m = model.machine
    fmt, prof, limits, modulo = _check_request(model, controller, profile, axis_map, points, forbid_output,
                                               modulo_axes, max_tables, no_circular, sign_test)
    zone = model_zone(model) if zone is None else zone
    check_lengths(model, tools_mm, zone)
    check_output_dir(out_dir)
    q = None
    if commands is not None:
        q = commands.q
        if tools_mm is None:
            tools_mm = [float(t * MM_PER_M) for t in commands.tool_lengths()]
    notes: list[str] = []
    plan, differential = _plan_for_drives(
        model, prof, limits, controller, notes, max_tables=max_tables, no_circular=no_circular or None,
        forbid_output=list(forbid_output), points=points, method=method, tools_mm=tools_mm, modulo_axes=modulo,
        commands=None if q is None else np.asarray(q), uncertainty=uncertainty, zone=zone, progress=progress,
        products=products)
    check_corrections(plan, model)
    if progress:
        progress(f"writing the {controller} files")
    as_written = None
    st = None
    xtables, xm, xprof = drives.expand(plan.tables, m, prof)
    effect = gauge_effect(plan, model) if plan.tables.gauge_offset_change != 0.0 else None
    with OutputSet(out_dir, manifest="tables") as out:  # an earlier run's files it no longer writes go
        how = user_commands or UserCommands()
        job = ExportJob(xtables, xm, xprof, limits, out, model, plan.points, notes, commands=how)
        job.gauge_effect = effect
        names = fmt.write(job) if fmt.name != "generic" else []
        names += generic.write(ExportJob(plan.tables, m, prof, limits, out, model, plan.points, notes, commands=how))
        if xm is not m:
            names += drives_readme(out, xtables, xm, prof, differential)
        if fmt.read is not None:
            stage = out.path(names[0]).parent
            as_written = drives.fold(_read_back(fmt, stage, xm, xprof, controller, out_dir), m, prof)
            as_written.gauge_offset_change = plan.tables.gauge_offset_change
        if zone:
            notes.append("zone " + zone_text(zone) + ": tables fitted to the model in this region only (load them "
                         "when the machine works there)")
        if sign_test is not None:
            table = find_table(as_written, m, sign_test)
            st = plan_sign_test(table, m, controller, [n for n in names if not n.endswith(".md")], fmt.sign)
            names += write_sign_test(out, st, fmt.dialect, prof, notes, how, m)
        headline = _judge_written(plan, model, as_written, job, names) if fmt.name != "generic" else None
        warnings = _judge_pitch_alone(fmt, plan, model, (stage, xm, xprof) if as_written is not None else None,
                                      job, names, controller, out_dir, prof)
        _fold_alternative(plan, controller, modulo, job, names)
        generic.add_prediction(out, plan.report, (AS_WRITTEN, plan.written))   # what the machine gets, predicted
    if plan.frame is not None and plan.frame.excessive:   # a correction larger than any error it removes: said first
        warnings.insert(0, "WARNING: " + plan.frame.text.split(": the tables move the tip", 1)[0].replace(
            "frame kept: ", "the tables, in the frame they keep (") + "): they move the tip by more than twice the "
            "largest error they remove; check the model (vecpin evaluate on a validation run) before loading them")
    if out.removed:
        notes.append("removed the files of an earlier vecpin tables run in this folder that this run does not write "
                     "(unchanged since): " + ", ".join(p.name for p in out.removed))
    files = [Path(out_dir) / n for n in names]
    return TableRun(plan, files, None if commands is None else commands.source, controller, notes, as_written, st,
                    headline, warnings, effect)


CORRECTION_FACTOR = 5.0   # tables moving the tip by more than this times the measured largest error are refused


def check_corrections(plan: TablePlan, model: ErrorModel) -> None:
    """Refuse tables whose largest correction at the tool tip [mm] exceeds
    :data:`CORRECTION_FACTOR` times the largest uncompensated error the campaign measured (the
    model file's record): a model predicting errors the machine did not have would make it worse."""
    sel = getattr(model, "selection_", None)
    measured = (sel or {}).get("uncompensated_mm") if isinstance(sel, dict) else None
    top = measured.get("max") if isinstance(measured, dict) else None
    if plan.frame is None or not isinstance(top, (int, float)) or not top > 0:
        return
    corr = plan.frame.largest_correction_mm
    if corr > CORRECTION_FACTOR * top:
        raise InputError(f"{getattr(model, 'source_', 'the model')}: the tables would move the tool tip by up to "
                         f"{corr:.4f} mm, more than "
                         f"{CORRECTION_FACTOR:g} times the largest error the campaign measured ({top:.4f} mm): the "
                         "model predicts errors the machine did not have, and these tables would make it worse; "
                         "nothing was written. Check the model (vecpin evaluate on a validation run) or fit it again")


def check_lengths(model: ErrorModel, tools_mm, zone) -> None:
    """Lengths a user gives the tables, against the model: tool lengths [mm] far below the
    model's tools (the fit's) but near them times 1000 were typed in metres (refused, the
    likely unit named); a zone's linear axes likewise against the axis' travel."""
    fitted = [float(t) for t in (getattr(getattr(model, "report_", None), "tool_lengths_mm", None) or [])]
    scale = float(np.mean(fitted)) if fitted else None
    for t in tools_mm or ():
        if not np.isfinite(t) or t < 0:
            raise InputError(f"`tools_mm` {t:g}: a tool length is mm from the gauge line, >= 0")
        text = None if scale is None else slip_text(t, scale, "the model's tools, mean")
        if text:
            raise InputError(f"`tools_mm` {t:g}: {text}; the model was fitted with tools "
                             f"{', '.join(f'{x:g}' for x in fitted)} mm")
    if zone:
        check_zone_units(model.machine, zone, "zone")


AS_WRITTEN = "files as written (model-predicted)"   # the report row of the controller's files read back


def _judge_written(plan: TablePlan, model: ErrorModel, as_written: TableSet | None, job: ExportJob,
                   names: list[str]) -> str | None:
    """Add the report rows of the files as written (and without the reference point data,
    where the files put constants there); when the files give up a real share of the
    compensation (:func:`_given_up`), say so, and why, in the first line of the
    controller's README (returned: the printout's first line too)."""
    if as_written is None:
        return None
    # the whole model: the drives' differential (read back from the files) turns the beam against its skew
    add_as_written_row(plan, model, as_written, AS_WRITTEN)
    if any(abs(c) > 0 for c in job.constants.values()):   # the loss if the reference point data are not loaded
        without = with_constants(as_written, {a: -c for a, c in job.constants.items()})
        add_as_written_row(plan, model, without, "files without the reference point data (model-predicted)")
    rows = {r.label: r for r in plan.report.rows}
    full, files = rows.get("full tables (model-predicted)"), rows[AS_WRITTEN]
    before = rows.get("uncompensated (model)")
    given_up = None if full is None or before is None else _given_up(before.mean, full.mean, files.mean)
    if given_up is None:
        return None
    n = len(plan.tables.tables)
    why = (f"{job.limits.name} takes {n} of the {full.tables} tables ({job.limits.source})" if n < full.tables
           else "the controller's grid and value resolution")
    share = (f"give up {100 * given_up:.0f} % of what the full tables remove" if np.isfinite(given_up)
             else "leave more than the full tables, which remove nothing")
    headline = (f"NOTE: these files {share}: they leave a model-predicted mean error of {files.mean:.4f} mm where the "
                f"full tables leave {full.mean:.4f} mm (uncompensated {before.mean:.4f} mm): {why}.")
    readme = next((k for k in names if k.startswith("README_")), None)
    if readme is not None:
        job.out.write_text(readme, headline + "\n\n" + job.out.path(readme).read_text())
    return headline


PART_GAIN = 0.5   # pitch files that keep less than this share of the whole set's gain alone are warned about first


def _judge_pitch_alone(fmt: ControllerFormat, plan: TablePlan, model: ErrorModel, staged, job: ExportJob,
                       names: list[str], controller: str, out_dir, prof: ControllerProfile) -> list[str]:
    """Where a format's pitch files may be run without the files of the cross tables
    (LinuxCNC: the COMP_FILEs without the HAL component, :data:`boundary.PITCH_ALONE`):
    the report row of those files alone as written, on the same points, and a section of
    the README. When they alone are worse than uncompensated, or keep less than
    :data:`PART_GAIN` of the files' gain, a warning that says so and what to do: returned
    (printed first) and put first in the README."""
    part = boundary.PITCH_ALONE.get(fmt.name)
    if part is None or staged is None or not any(not t.is_pitch for t in job.tables.tables):
        return []
    stage, xm, xprof = staged
    raw = _read_back(fmt, stage, xm, xprof, controller, out_dir)
    alone = drives.fold(raw.subset([]), model.machine, prof)
    alone.gauge_offset_change = plan.tables.gauge_offset_change   # the datum is entered either way
    add_as_written_row(plan, model, alone, part.label)
    rows = {r.label: r for r in plan.report.rows}
    before, files, pitch = (rows["uncompensated (model)"], rows[AS_WRITTEN],
                            rows.get("pitch only (model-predicted)"))
    own = rows[part.label]
    gain = before.mean - files.mean
    kept = (before.mean - own.mean) / gain if gain > 0 else 1.0
    refit = f" ({pitch.mean:.4f} mm, the printout's 'pitch only' row)" if pitch is not None else ""
    section = ["", f"## {part.files[0].upper() + part.files[1:]} without {part.rest}", "",
               f"Fitted together with the cross tables of {part.rest}, {part.files} alone leave a model-predicted mean "
               f"error of {own.mean:.4f} mm (uncompensated {before.mean:.4f} mm, all the files {files.mean:.4f} mm). "
               f"Pitch tables fitted to work alone: {job.commands.pitch_only}{refit}.", ""]
    readme = next((k for k in names if k.startswith("README_")), None)
    warnings = []
    if kept < PART_GAIN:
        how = (f"more than uncompensated ({before.mean:.4f} mm)" if own.mean > before.mean else
               f"only {100 * kept:.0f} % of the files' gain (uncompensated {before.mean:.4f} mm, with "
               f"{part.rest} {files.mean:.4f} mm)")
        warnings.append(f"WARNING: {part.files} without {part.rest} leave a model-predicted mean error of "
                        f"{own.mean:.4f} mm, {how}: they were fitted together with its cross tables and are not "
                        f"pitch tables for use on their own. Load {part.rest}: {part.load_rest}; or, to run "
                        f"{part.files} alone, write pitch tables fitted alone: {job.commands.pitch_only}{refit}.")
    if readme is not None:
        text = job.out.path(readme).read_text()
        job.out.write_text(readme, "".join(w + "\n\n" for w in warnings) + text + "\n".join(section))
    return warnings


def _fold_alternative(plan: TablePlan, controller: str, modulo: list[str], job: ExportJob, names: list[str]) -> None:
    """With modulo tables: the note on what folding costs (the plan's) with the
    controller's table over the whole travel, in the printout and the README."""
    if not modulo:
        return
    rows = {r.label: r for r in plan.report.rows}
    if unfolded_label(modulo) not in rows:
        return
    fold = next(n for n in plan.report.notes if n.startswith("modulo tables ("))
    alt = boundary.unfolded_alternative(controller, modulo)
    job.notes.append(f"modulo {', '.join(modulo)}: the table over the whole travel on {controller}: {alt}")
    readme = next((k for k in names if k.startswith("README_")), None)
    if readme is not None:
        text = job.out.path(readme).read_text()
        alt = boundary.unfolded_alternative(controller, modulo)
        job.out.write_text(readme, text + "\n".join(["", "## Modulo tables", "", fold[0].upper() + fold[1:] + ".",
                                                      "", f"The table over the whole travel: {alt}.", ""]))


def _given_up(uncompensated: float, full: float, files: float) -> float | None:
    """The share of the error the full tables remove that the files give up [mm/mm], when
    it is a real loss: more than :data:`LOST_SHARE` of it and more than :data:`ROUNDING_MM`
    (inf when the full tables remove nothing and the files leave more); else None.
    Measured against what the tables remove, not against what the full tables leave: a
    model its full tables cancel to 0.0006 mm would make any file look many times worse."""
    lost, removed = files - full, uncompensated - full
    if lost <= ROUNDING_MM or lost <= LOST_SHARE * max(removed, 0.0):
        return None
    return lost / removed if removed > 0 else float("inf")


def _check_request(model: ErrorModel, controller: str, profile, axis_map, points, forbid_output, modulo_axes,
                   max_tables, no_circular, sign_test) -> tuple[ControllerFormat, ControllerProfile, ControllerLimits,
                                                                 list[str]]:
    """(format, profile, limits, modulo axes): every limit and missing fact checked before
    the first solve."""
    m = model.machine
    fmt, prof, limits = resolve(controller, m, profile, axis_map)
    limits.points(points)
    for a in forbid_output:
        named_axis(m, a, "forbid_output")
    for a in modulo_axes:
        named_axis(m, a, "modulo_axes")
    modulo = sorted(set(modulo_axes) | set(prof.modulo_axes()), key=lambda a: m.axis(a).index)
    if max_tables is not None:
        limits.constraints(max_tables, no_circular or None, tuple(forbid_output), axis_names=m.axis_names)
    _, xm, xprof = drives.expand(TableSet(m.axis_names, []), m, prof)  # the writers' view: drives as axes
    fmt.check(xm, xprof, limits, modulo)
    if sign_test is not None:
        if fmt.read is None:
            raise InputError(f"`sign_test`: {controller} writes no tables a controller applies")
        key = sign_test.strip().lower()
        inputs = {a.lower(): a for a in m.axis_names} | {table_name(o, i): i for o in m.axis_names
                                                         for i in m.axis_names}
        if key not in inputs:
            raise InputError(f"`sign_test` {sign_test}: neither an axis nor a table of {m.name}")
        from vecpin.export.signtest import addresses, check_address  # its address, before the tables are computed
        check_address(prof.axis(inputs[key]).program_name or inputs[key], fmt.dialect, inputs[key], prof.where,
                      addresses(prof, m.axis_names))
    return fmt, prof, limits, modulo


def _plan_for_drives(model: ErrorModel, prof: ControllerProfile, limits: ControllerLimits, controller: str,
                     notes: list[str], *, max_tables, points, **kw) -> tuple[TablePlan, dict]:
    """(plan, differential tables): the tables planned under ``limits``; with twin drives a
    cross table on a twin axis is loaded for both drives and counts twice, so the choice
    is made again until the set fits, and a gantry skew goes into the differential."""
    m = model.machine
    differential, taken = {}, []
    if drives.twin_axes(prof):
        differential, taken, dnotes = drives.skew_differential(model, prof, limits.points(points))
        notes += dnotes
    planned = _without(model, taken)
    while True:
        plan = plan_tables(planned, limits, max_tables=max_tables, points=points, **kw)
        plan.tables.drives = drives.twin_drives(m, prof, differential)  # tables.json carries the differential
        k = _cross_tables_over(plan.tables, m, prof, differential, limits)
        if k == 0:
            return plan, differential
        max_tables = sum(not t.is_pitch for t in plan.tables.tables) - k
        if max_tables < 0:
            raise ControllerLimitError(f"{controller} holds {limits.cross_limit(m.axis_names)} cross tables, but the "
                                       "twin drives' own tables (the differential that turns the beam against the "
                                       "gantry skew, loaded on both drives) already need more: leave out the "
                                       "drive_separation_mm of the profile (no differential) or raise the limit")
        notes.append(f"twin drives: {k} cross table(s) more than {controller} holds once loaded for both drives; "
                     f"chose again with `max_tables` {max_tables}")


def _read_back(fmt: ControllerFormat, stage: Path, xm, xprof: ControllerProfile, controller: str, out_dir) -> TableSet:
    """The files as written, read with the format's reader; a file that does not read
    back is named as it would have been written (nothing is: the set is dropped)."""
    try:
        return fmt.read(stage, xm, xprof)
    except ControllerFileError as exc:
        name = Path(exc.path).name
        where = f", line {exc.line}" if exc.line is not None else ""
        raise InputError(f"`controller` {controller}: {Path(out_dir) / name} as vecpin would write it does not read "
                         f"back ({name}{where}: {exc.reason}); nothing was written. Check the names and facts of the "
                         f"{xprof.where}") from None


def _cross_tables_over(tables: TableSet, m, prof: ControllerProfile, differential: dict,
                       limits: ControllerLimits) -> int:
    """How many cross tables the controller would hold too many once the twin drives'
    copies are counted (0: they fit, or no limit)."""
    if not drives.twin_axes(prof):
        return 0
    xtables, xm, _ = drives.expand(tables, m, prof, differential)
    limit = limits.cross_limit(xm.axis_names)
    n = sum(not t.is_pitch for t in xtables.tables)
    return 0 if limit is None else max(0, n - limit)


def model_zone(model) -> dict | None:
    """The zone a model was fitted in ({axis: (low, high)} mm/deg), or None."""
    return getattr(model, "zone_", None)


def _without(model: ErrorModel, effects: list) -> ErrorModel:
    """The model with these effects' parameters at zero (what the other tables carry once
    the drives take a gantry skew)."""
    if not effects:
        return model
    out = copy.copy(model)
    b = model.b_.copy()
    for e, sl in model.effect_slices():
        if any(e is t for t in effects):
            b[sl] = 0.0
    out.b_ = b
    return out


def drives_readme(out: OutputSet, tables: TableSet, xm, prof: ControllerProfile, differential: dict) -> list[str]:
    """``DRIVES.md`` and ``tables_drives.csv``: which tables go to which drive of a twin-drive axis."""
    lines = ["# Twin-drive axes", "",
             "Every table that corrects a twin-drive axis is loaded for both drives (seed Section 2.5: 30 tables "
             "on the Master Mill). `tables_drives.csv` lists them per drive (mm/deg); `tables.json` keeps the "
             "machine's axes (the mean of the drives) and, under `drives`, each twin axis' separation and its "
             "differential tables (the leading drive's share; vecpin's simulation and verification with these "
             "tables turn the beam with them).", ""]
    for f, a in xm.leading.items():
        lead, fol = prof.axis(a), prof.axis(a).following
        names = [t.name for t in tables.tables if t.output_axis in (a, f)]
        lines.append(f"- {a}: leading drive {lead.nc_name or lead.general_name or lead.number or a}, following "
                     f"drive {fol.nc_name or fol.general_name or fol.number or f} ({f}); {len(names)} tables: "
                     + " ".join(names))
        if a in differential:
            lines.append("  - gantry skew as a differential between the drives (leading +, following -) from "
                         + ", ".join(t.input_axis for t in differential[a]) + "; already added to the tables above")
    out.write_text("DRIVES.md", "\n".join(lines) + "\n")
    tables.save_csv(out.path("tables_drives.csv"), xm)
    return ["DRIVES.md", "tables_drives.csv"]


def check_sign(test_path: str | Path, check_csv: str | Path, machine=None) -> SignVerdict:
    """Judge a sign test from its CSV of readings: ``test_path`` the SIGNTEST_<T>.json the
    tables were written with, ``check_csv`` the filled-in SIGNTEST_<T>.csv."""
    st = SignTest.load(test_path)
    if machine is not None and st.machine != machine.name:
        raise InputError(f"`test_path` {test_path}: the test is for machine '{st.machine}', the model for "
                         f"'{machine.name}'")
    return evaluate_sign_test(st, read_check(check_csv, st))


def write_profile_template(machine, controller: str, out: str | Path) -> tuple[Path, int]:
    """Write the controller profile template of ``machine`` (:mod:`vecpin.export.profiletemplate`)
    to ``out``; an existing file is refused (it may be the user's filled-in profile).
    Returns (path, fields left null that the controller's files need, optional fields left null)."""
    import json

    from vecpin.export.profiletemplate import FIELDS, template
    from vecpin.fileio import write_text
    path = Path(out)
    if path.exists():
        raise InputError(f"`out` {out}: the file exists (a filled-in profile?); give another name or remove it")
    d = template(machine, controller)
    required = FIELDS[controller][0]
    needed = sum(v is None and f in required for facts in d["axes"].values() for f, v in facts.items())
    blanks = sum(v is None for facts in d["axes"].values() for v in facts.values())
    blanks += sum(v is None for v in d.get("options", {}).values())
    write_text(path, json.dumps(d, indent=1) + "\n")
    return path, needed, blanks - needed
