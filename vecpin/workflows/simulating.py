"""Simulate a campaign on a true machine and summarise it (the ``simulate`` command)."""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from vecpin.errors import InputError
from vecpin.fileio import OutputSet, check_output_dir
from vecpin.kinematics.machine import Machine
from vecpin.measurement.nestheights import NEST_HEIGHTS_FILE, nest_heights_csv
from vecpin.measurement.registration import registered_errors, spans_plane
from vecpin.measurement.tableface import SWEEP_SD_UM, TABLE_FACE_FILE, swept_axes, sweep_ends, table_face_csv
from vecpin.measurement.tableframe import nest_shape, registers_table, table_tips
from vecpin.models.recorded import STILL_SHARE
from vecpin.planning.nests import VALIDATION_READS
from vecpin.planning.problem import check_tracker_units
from vecpin.simulation.simulate import Design, Simulation, simulate
from vecpin.workflows.summary import error_summary
from vecpin.units import MM_PER_M

MAX_TRACKER_MM = 100_000.0  # a tracker position farther than 100 m from the machine base is not a setup
SWEEP_MM = 300.0            # the simulated indicator's sweep of the table's face: this far, or the measured box's width


@dataclass
class SimulationRun:
    simulation: Simulation
    design: Design
    paths: dict[str, Path]
    seed: int = 0
    planned: bool = False
    gauge_change: float = 0.0  # m, the tables' T_offset change (compensated run)
    validation_from: str = ""  # where the validation commands come from, when not quasi-random over the travel

    def lines(self) -> list[str]:
        sim, design = self.simulation, self.design
        m = sim.truth.machine
        full = sim.campaign
        c = full.primary()  # the summary: station 0's tracker rows
        offset = np.array([sim.targets.get(t, np.zeros(3)) for t in c.target]) if sim.targets else None
        nominal = m.tool_tip(c.q, c.tool, frame="base", point=c.point, offset=offset)
        true_tip = sim.truth.tool_tip(c.q, c.tool, point=c.point, offset=offset)
        more = ""
        if full.mixed:
            k = len(np.unique(full.station[full.instrument != "ballbar"])) - 1
            parts = [f"{k} more station{'s' if k != 1 else ''}" if k else "",
                     f"{full.nest_rows.size} table nest rows ({len(sim.nests)} nests)" if full.nest_rows.size else "",
                     f"{full.ballbar_rows.size} ball bar rows" if full.ballbar_rows.size else ""]
            more = f" + {len(full) - len(c)} rows: " + (", ".join(p for p in parts if p) or "other instruments")
        dist = np.linalg.norm(c.xyz, axis=1)
        what = (f"the plan's rows in its order, holders {', '.join(f'{t * MM_PER_M:g}' for t in c.tool_lengths())} mm"
                if self.planned else f"{design.n_commands} commands x {len(design.tools_mm)} tools "
                f"{', '.join(f'{t:g}' for t in design.tools_mm)} mm")
        out = [f"simulated {m.name}, seed {self.seed}: {len(c)} rows{more} ({what}), "
               f"{len(sim.validation)} validation rows" + (f" ({len(sim.validation.tracker_rows) // VALIDATION_READS} commands, each at the tool and "
                                                           f"at {len(sim.nests)} nests, every point read "
                                                           f"{VALIDATION_READS} times at standstill)"
                                                           if len(sim.validation.nest_rows) else "")
               + (f" from {self.validation_from}" if self.validation_from else ""),
               error_summary("true vs nominal tip (machine base frame)", (true_tip - nominal) * MM_PER_M),
               error_summary("uncompensated, measured (tracker frame)", registered_errors(nominal, c.xyz) * MM_PER_M)
               if spans_plane(nominal) else "  (the tool tips stand still in the base frame: every axis moves the table)",
               f"  tracker range {dist.min():.2f} .. {dist.max():.2f} m (station 0); campaign takes {full.time[-1] / 3600:.2f} h"]
        if sim.nests:   # what a user knows of the nests: the height of each reflector above the table's face
            out.append(f"  table nests, reflector centres above the table's face, mm (the fit's nest heights, in "
                       f"{NEST_HEIGHTS_FILE}: the tables then keep the face square to the spindle; :0, a simulation's "
                       "heights are exact): " + " ".join(f"{k}={float(p[2]) * MM_PER_M:.4f}:0"
                                                         for k, p in sorted(sim.nests.items())))
        if m.has_workpiece:
            rel = sim.truth.tool_tip(c.q, c.tool, frame="workpiece", point=c.point, offset=offset)
            out.append(error_summary("true vs nominal tip relative to the workpiece", registered_errors(
                m.tool_tip(c.q, c.tool, frame="workpiece", point=c.point, offset=offset), rel) * MM_PER_M))
        if sim.targets:
            out.append("  tool targets (true offsets, tool link frame, mm): " + "; ".join(
                f"{k} " + ", ".join(f"{v * MM_PER_M:.3f}" for v in o) for k, o in sim.targets.items()))
        out += hall_lines(sim)
        if sim.compensated is not None:
            for label, run, g in (("validation run, uncompensated", sim.validation, 0.0),
                                  ("validation run through the tables", sim.compensated, self.gauge_change)):
                out.append(run_summary(m, label, run, g))
        out += [f"  wrote {p}  ({k})" for k, p in self.paths.items()]
        return out


def hall_lines(sim: Simulation) -> list[str]:
    """The hall's temperature [°C] the campaign and the validation runs saw (mean and range)."""
    def span(c):
        t = c.temperature
        return f"{t.mean():.2f} degC ({t.min():.2f} .. {t.max():.2f})"
    runs = [("campaign", sim.campaign), ("validation run", sim.validation)]
    runs += [("run through the tables", sim.compensated)] if sim.compensated is not None else []
    return ["  hall temperature (sensor): " + "; ".join(f"{k} {span(c)}" for k, c in runs if c.temperature is not None)]


def run_summary(machine: Machine, label: str, run, gauge_change: float = 0.0) -> str:
    """One line of a validation run's measured error: relative to the table when it read
    table nests (:mod:`vecpin.measurement.tableframe`, the nests' shape from the run), else
    at the tool tip; registered rigidly."""
    if machine.has_workpiece and registers_table(run):
        tt = table_tips(run, nest_shape(run))
        c = run.subset(tt.rows)
        nominal = machine.tool_tip(c.q, c.tool + gauge_change, frame="workpiece")
        return error_summary(label + " (tip relative to the table)", registered_errors(nominal, tt.tip) * MM_PER_M)
    c = run.primary()
    if machine.has_workpiece and len(run.nest_rows):   # two nests: no table pose, and the tool alone says nothing
        return (f"  {label}: not judged here (fewer than three nests give no table pose at a command; the tool tip "
                "alone does not show the table axes' errors)")
    return error_summary(label, registered_errors(machine.tool_tip(c.q, c.tool + gauge_change, frame="base"), c.xyz)
                         * MM_PER_M)


def simulate_to_dir(machine: Machine, out_dir: str | Path, seed: int = 0, design: Design | None = None,
                    effects: list | None = None, **truth_options) -> SimulationRun:
    """Simulate a campaign (see :func:`vecpin.simulation.simulate.simulate`; ``plan``,
    ``tables``, ``truth`` and the truth options pass through) and write its files."""
    check_output_dir(out_dir)
    design = design or Design()
    plan = truth_options.get("plan")
    if truth_options.get("validation_commands") is not None:
        design = replace(design, n_validation=len(truth_options["validation_commands"]))
    design.check(machine, None if plan is None else len(plan[1] if isinstance(plan, tuple) else plan.tool), files=True)  # files vecpin can read back
    _check_tracker(truth_options.get("tracker_position"))
    check_lengths(machine, truth_options.get("tracker_position"), design)
    sim = simulate(machine, seed=seed, design=design, effects=effects or None, **truth_options)
    tables = truth_options.get("tables")
    with OutputSet(out_dir) as out:
        files = sim.write_into(out)
        if sim.nests:   # as the operator measures them: the reflectors' heights above the table's face (the fit's)
            files["nest_heights"] = out.write_text(NEST_HEIGHTS_FILE, nest_heights_csv(sim.nests, measured=True))
            readings = simulated_table_face(sim, seed)
            if readings:   # the table face's parallelism read with a dial test indicator, as the plan asks
                files["table_face"] = out.write_text(TABLE_FACE_FILE, table_face_csv(readings, readings))
    return SimulationRun(sim, design, files, seed, truth_options.get("plan") is not None,
                         0.0 if tables is None else tables.gauge_offset_change,
                         "the plan's validation run (its validation.csv)"
                         if truth_options.get("validation_commands") is not None else "")


def simulated_table_face(sim: Simulation, seed: int) -> dict[str, tuple[float, float, float]]:
    """{axis: (distance [mm], change [µm], sd [µm])}: a dial test indicator in the spindle read on the
    simulated true machine as the plan's ``table_face.csv`` asks (:mod:`vecpin.measurement.tableface`):
    each axis that moves across the table's face moved :data:`SWEEP_MM` (or the campaign's measured
    range of it) about the middle of that range, every rotary axis at 0 (or the end of its measured
    range nearest 0), the other axes mid-range, the campaign's shortest tool; the change is the true tip's
    height above the true table's face (the truth's workpiece frame, along the spindle at home) at the
    start less at the end, + pushed in, with a normal reading error of
    :data:`~vecpin.measurement.tableface.SWEEP_SD_UM` (stated in the file)."""
    m = sim.truth.machine
    q = sim.campaign.q
    lo, hi = q.min(axis=0), q.max(axis=0)
    still = hi - lo < STILL_SHARE * np.array([a.travel for a in m.axes])   # an axis that stood still: its travel
    lo, hi = np.where(still, m.lower, lo), np.where(still, m.upper, hi)
    rotary = np.array([a.kind == "rotary" for a in m.axes])
    mid = np.where(rotary, np.clip(0.0, lo, hi), 0.5 * (lo + hi))
    up = -m.kinematics(mid[None], 0.0, jacobian=False, frame="workpiece").tool_dir[0]
    tool = float(min(sim.campaign.tool_lengths()))
    rng = np.random.default_rng([seed, 2053])
    out = {}
    for name in swept_axes(m):
        k = m.axis_names.index(name)
        ends = sweep_ends(mid, lo, hi, k, SWEEP_MM / MM_PER_M)
        gap = sim.truth.tool_tip(ends, np.full(2, tool), frame="workpiece") @ up
        change = float(gap[0] - gap[1]) * 1e6 + rng.normal(0.0, SWEEP_SD_UM)
        out[name] = (float(ends[1, k] - ends[0, k]) * MM_PER_M, change, SWEEP_SD_UM)
    return out


def simulation_inputs(machine: Machine, plan: str | Path | None = None, tables: str | Path | None = None,
                      truth: str | Path | None = None, temperature_profile: str | None = None,
                      validation_after_h: float | None = None, thermal: str | Path | None = None) -> dict:
    """The files a simulation reads, as :func:`simulate_to_dir` takes them: ``plan`` (a
    plan's template, with its table nests and, from its folder, :func:`plan_companions`),
    ``tables`` (tables.json or its folder) and ``truth`` (truth.json of an earlier
    simulation of ``machine``); a key only for a file given. ``temperature_profile`` (its
    text, :func:`vecpin.simulation.temperature.parse_profile`), ``validation_after_h`` [h]
    and ``thermal`` (thermal.json: the controller's thermal terms, active in the run
    through the tables) make the ``hall``."""
    out: dict = {}
    if plan is not None:
        from vecpin.measurement.plantemplate import read_template
        out["plan"] = read_template(plan, machine)
        out |= plan_companions(machine, plan, out["plan"])  # its NC program's times, its validation run
    if tables is not None:
        from vecpin.workflows.verifying import load_tables
        out["tables"] = load_tables(tables, machine)[0]
    if temperature_profile is not None or validation_after_h is not None or thermal is not None:
        out["hall"] = _hall(temperature_profile, validation_after_h, thermal, tables)
    if truth is not None:
        from vecpin.simulation.truth import TrueMachine
        try:
            out["truth"] = TrueMachine.load(truth, machine)
        except (OSError, KeyError, ValueError) as exc:
            raise InputError(f"`truth` {truth}: not a truth file of {machine.name} ({exc})") from None
    return out


def _hall(profile: str | None, after_h: float | None, thermal, tables):
    """The simulation's hall from its options (see :func:`simulation_inputs`)."""
    from vecpin.compensation.thermal import ThermalTerms
    from vecpin.simulation.temperature import Hall, parse_profile
    if thermal is not None and tables is None:
        raise InputError(f"`thermal` {thermal}: the controller's thermal terms act in the run through the tables; "
                         "give the tables too")
    hall = Hall(None if profile is None else parse_profile(profile),
                600.0 if after_h is None else float(after_h) * 3600.0,
                None if thermal is None else ThermalTerms.load(thermal))
    hall.check()
    return hall


def plan_companions(machine: Machine, plan_path: str | Path, template) -> dict:
    """What a plan's folder holds beside its template ``plan_path`` for the simulator:
    ``plan_times`` (the rows' time stamps as the plan's NC program runs them, from
    plan.json) and ``read_dwell_s`` (its dwell per further reading of a point [s]: the
    validation run's further readings), ``validation_commands`` (its validation run,
    validation.csv, inside the plan's zone) and, on a plan read from several tracker
    stations, ``station_positions`` (plan.json's stations_mm, SI). A key is absent when
    its file is (a plan from an older vecpin)."""
    from vecpin.measurement.plantemplate import read_template
    from vecpin.planning.timing import row_times
    from vecpin.workflows.planning import plan_station_positions, plan_timing
    out = {}
    timing = plan_timing(plan_path)
    if timing is not None:
        out["plan_times"] = row_times(machine, template, timing)[0]
        out["read_dwell_s"] = timing.read_dwell_s
    stations = plan_station_positions(plan_path) if np.any(template.stations != 0) else None
    if stations is not None:
        for p in stations:
            _check_tracker(p)
        out["station_positions"] = stations
    v = Path(plan_path).with_name("validation.csv")
    if v.is_file() and Path(plan_path).name != "validation.csv":
        vt = read_template(v, machine)
        q = vt.q[vt.tool_rows]  # a command once: its further readings at standstill the simulator makes itself
        out["validation_commands"] = q[np.r_[True, np.any(q[1:] != q[:-1], axis=1)]] if len(q) else q
    return out


def check_lengths(machine: Machine, position, design: Design) -> None:
    """Lengths typed in metres: the tracker position (SI here, mm to the user) against the
    machine's travel, and target offsets [mm] all below 1 mm (a target that close to the tip
    is the tip; tens of mm in metres)."""
    if position is not None:
        check_tracker_units(machine, np.asarray(position, float) * MM_PER_M, "tracker_position")
    for t in design.targets_mm or ():
        v = np.asarray(t, float)
        if v.shape == (3,) and np.all(np.isfinite(v)) and 0 < np.abs(v).max() < 1.0:
            raise InputError(f"`targets_mm` {','.join(f'{x:g}' for x in v)}: a target offset below 1 mm from the tool "
                             f"tip: metres? Offsets are mm in the tool link frame "
                             f"({','.join(f'{x * 1000:g}' for x in v)} if they were in metres)")


def _check_tracker(position) -> None:
    """``tracker_position`` (SI here): finite and within a tracker's reach of the machine base."""
    if position is None:
        return
    p = np.asarray(position, float) * MM_PER_M
    if p.shape != (3,) or not np.all(np.isfinite(p)) or np.any(np.abs(p) > MAX_TRACKER_MM):
        raise InputError(f"`tracker_position` {','.join(f'{v:g}' for v in np.ravel(p))}: three finite numbers, the tracker "
                         f"position in mm, machine base frame, within {MAX_TRACKER_MM / 1000:g} m of the origin (a tracker reads points at "
                         "most 200 m away)")
