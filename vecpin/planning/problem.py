"""What a plan is asked for: the settings (user units, each checked with the parameter
named) and the problem they pose on a machine: the measurement set-up (the tracker and
the table nests), the holder lengths, the noise of the fit, the approach steps, the box
in axis space the commands may take and the axes' rapid speeds.

:func:`plan_problem` is where the set-up is decided: a proposal of nest places or
tracker stations for a machine with table axes belongs there."""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from vecpin.errors import InputError, VecpinWarning
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import PAPER_I_TOOLS_MM
from vecpin.measurement.noise import NoiseModel
from vecpin.models import ErrorModel, make_model
from vecpin.planning import route
from vecpin.planning.nestplacement import Placement, place_nests
from vecpin.planning.nests import check_nest_layout, check_nests, nest_positions
from vecpin.planning.planchecks import EXPECTED_ERROR_MM
from vecpin.planning.sightline import (DEFAULT_TARGET_CLEARANCE, DEFAULT_TOOL_RADIUS, default_tracker_placement,
                                       side_name)
from vecpin.planning.zones import Zone, check_zone_axes, clip_to_zone
from vecpin.units import MM_PER_M, M_PER_MM

MAX_POINTS = 10_000         # commands of one plan
MAX_CANDIDATES = 100_000    # candidate commands the D-optimal choice scores
# commands a plan with table nests (3 readings more per command) computes within a minute, and
# the slowest bundled table machine measured (benchmarks/bench_planning.py, whole `plan` process)
TABLE_MINUTE_POINTS = 5_500
TABLE_LARGEST = "head_table_bc with 3 nests: 96 s at 10000 commands, 56 s at 5500, on a 2-core machine"
AUTO_ORDER = 6              # the order a plan takes for `order` auto: Paper I's, before any data can choose
BASES = ("auto", "chebyshev", "fourier", "fourier_trend", "spline", "pspline", "smooth")  # the fit's, planned as :func:`planned_model` says


@dataclass
class PlanSettings:
    """What to plan (user units where a user types them).

    ``n_commands``: commands, each measured with every holder length ``tools_mm`` [mm];
    ``model``/``order``/``basis``: the model the campaign is for (``model="auto"``: 6dof on
    a machine with table axes, whose tilt and wobble only nest readings see, ap elsewhere;
    ``order="auto"``: :data:`AUTO_ORDER`; the plan's settings carry the kind and order
    chosen, ``chosen`` names the settings vecpin chose); ``noise``: the fit's
    noise model (default: spherical tracker noise); ``tracker_mm`` (3,) [mm] machine base
    frame (default: 2 m beyond the workspace on the side the tips are seen from); ``exclude``: exclusion zones;
    ``zone``: measurement zone; ``method``: "doptimal" or "random"; ``approach``:
    below/above/both/none with distances ``approach_mm`` [mm], ``approach_deg`` [deg];
    ``repeat_points`` x ``repeat_times``: repeated points at the start and at the end;
    ``sight``: test the line of sight (``tool_radius_mm``, ``target_clearance_mm``; on an arm
    ``tool_radius_mm`` is also the holder's radius in the collision check of every pose);
    ``rapid_mm_min``/``rapid_deg_min``: rapid speeds (default: URDF velocity limits);
    ``candidates``: candidate commands (default :func:`default_candidates`); ``validation_points``:
    quasi-random commands the predicted error is judged on; ``n_validation``: the
    commands of the validation run (inside the zone, free and in sight with the first
    holder; measured with and without the tables); ``nests``: table nests read
    at every command (None: 3 on a machine with a workpiece frame, else 0) at default
    places, or ``nest_mm`` {id: (x, y, z) [mm], workpiece frame} as the user placed them;
    ``expected_error_mm``: the machine's mean uncompensated error [mm] as a tracker sees
    it (best-fit rigid motion removed), which the plan's predicted error must stay well
    below (:mod:`~vecpin.planning.planchecks`)."""

    n_commands: int = 100
    tools_mm: tuple[float, ...] = PAPER_I_TOOLS_MM
    model: str = "ap"
    order: int | str = 4
    basis: str = "auto"
    noise: NoiseModel | None = None
    tracker_mm: tuple[float, float, float] | None = None
    exclude: list[Zone] = field(default_factory=list)
    zone: Zone | None = None
    method: str = "doptimal"
    approach: str = "below"
    approach_mm: float = 5.0
    approach_deg: float = 1.0
    repeat_points: int = 0
    repeat_times: int = 0
    sight: bool = True
    geometry: str = "auto"
    tool_radius_mm: float = DEFAULT_TOOL_RADIUS * MM_PER_M
    target_clearance_mm: float = DEFAULT_TARGET_CLEARANCE * MM_PER_M
    rapid_mm_min: float | None = None
    rapid_deg_min: float | None = None
    candidates: int | None = None
    validation_points: int = 500
    n_validation: int = 35
    seed: int = 0
    nests: int | None = None
    nest_mm: dict[str, tuple[float, float, float]] | None = None
    expected_error_mm: float = EXPECTED_ERROR_MM
    place_nests: bool = True  # default nests placed for the line of sight, a second station proposed (nestplacement)
    chosen: tuple[str, ...] = ()  # the settings given as auto that vecpin chose ("model", "order"), as messages say

    def nest_places(self, machine: Machine) -> dict[str, np.ndarray]:
        """{nest id: (3,) [m], workpiece frame} of the plan (checked, names the option)."""
        if self.nest_mm:
            if self.nests is not None and self.nests != len(self.nest_mm):
                raise InputError(f"`nests` {self.nests} but {len(self.nest_mm)} `nest_mm` positions given: give one or "
                                 "the other (or the same count)")
            out = {k: np.asarray(v, float) * M_PER_MM for k, v in self.nest_mm.items()}
            check_nests(machine, out, "nest_mm")
            check_nest_layout(machine, out, "nest_mm")
            return out
        n = (3 if machine.has_workpiece else 0) if self.nests is None else self.nests
        check_nests(machine, {str(k): 0 for k in range(n)}, "nests")
        if n == 1:
            raise InputError("`nests` 1: one nest gives the table's place but not its turn; plan at least 3 (or 0)")
        return nest_positions(machine, n)

    def check(self) -> None:
        """Every option inside its meaning, before any work (names the option)."""
        if self.n_commands < 1:
            raise InputError(f"`n_commands` {self.n_commands}: plan at least one command")
        if self.n_commands > MAX_POINTS:
            raise InputError(f"`n_commands` {self.n_commands}: at most {MAX_POINTS} commands (at 15 s a point, "
                             f"{self.n_commands * len(self.tools_mm) * 15 / 3600:.0f} h of tracker time); plan fewer")
        tools = np.asarray(self.tools_mm, float)
        if tools.size == 0 or not np.all(np.isfinite(tools)) or tools.min() < 0 or tools.max() > 10_000:
            raise InputError("`tools_mm`: holder lengths are mm from the gauge line, 0 .. 10000 (e.g. 214.88,312.86)")
        if tools.max() < 1.0 and tools.max() > 0:
            raise InputError(f"`tools_mm` {','.join(f'{t:g}' for t in tools)}: holders shorter than 1 mm from the "
                             f"gauge line: metres? Give them in mm ({','.join(f'{t * 1000:g}' for t in tools)} if "
                             "they were in metres)")
        if len(np.unique(np.round(tools, 6))) < tools.size:
            raise InputError(f"`tools_mm` {','.join(f'{t:g}' for t in tools)}: two holders of the same length measure the "
                             "same point twice; give different lengths (they separate the tool-axis errors)")
        if self.method not in ("doptimal", "random"):
            raise InputError(f"`method` '{self.method}': doptimal or random")
        if (self.repeat_points or self.repeat_times) and (self.repeat_points < 1 or self.repeat_times < 2):
            raise InputError(f"`repeat_points` {self.repeat_points}, `repeat_times` {self.repeat_times}: at least 1 command, each "
                             "measured at least 2 times")
        if self.repeat_points > self.n_commands:
            raise InputError(f"`repeat_points` {self.repeat_points}, `repeat_times` {self.repeat_times}: the repeated "
                             "points are taken from the "
                             f"planned commands, at most `n_commands` ({self.n_commands})")
        if self.order != "auto" and not (isinstance(self.order, (int, np.integer)) and self.order >= 0):
            raise InputError(f"`order` {self.order!r}: a whole number >= 0, or auto")
        if self.basis not in BASES:
            raise InputError(f"`basis` '{self.basis}': one of {', '.join(BASES)}")
        if self.tracker_mm is not None and not np.all(np.isfinite(np.asarray(self.tracker_mm, float))):
            raise InputError("`tracker_mm`: three finite numbers, mm")
        if self.candidates is not None and not self.n_commands <= self.candidates <= MAX_CANDIDATES:
            raise InputError(f"`candidates` {self.candidates}: between `n_commands` ({self.n_commands}) and "
                             f"{MAX_CANDIDATES} candidate commands")
        if not (np.isfinite(self.expected_error_mm) and self.expected_error_mm > 0):
            raise InputError(f"`expected_error_mm` {self.expected_error_mm}: the machine's mean uncompensated error, mm > 0")
        if not 1 <= self.n_validation <= MAX_POINTS:
            raise InputError(f"`n_validation` {self.n_validation}: 1 .. {MAX_POINTS} validation commands")
        if self.seed < 0:
            raise InputError(f"`seed` {self.seed}: a whole number >= 0")
        for option, v in (("tool_radius_mm", self.tool_radius_mm), ("target_clearance_mm", self.target_clearance_mm)):
            if not (np.isfinite(v) and v >= 0):
                raise InputError(f"`{option}` {v}: a length in mm >= 0")
        for option, v in (("rapid_mm_min", self.rapid_mm_min), ("rapid_deg_min", self.rapid_deg_min)):
            if v is not None and not (np.isfinite(v) and v > 0):
                raise InputError(f"`{option}` {v}: a rapid speed > 0")

    def check_model(self, machine: Machine, n_parameters: int) -> None:
        """The planned rows can determine the model: at least as many equations as unknowns."""
        rows = self.n_commands * len(self.tools_mm) + self.repeat_points * self.repeat_times
        eq = 3 * rows if self.noise is None or self.noise.instrument != "range" else rows
        if n_parameters + 6 > eq:
            order = (f"`order` auto (the default: order {self.order} before any data, as Paper I)"
                     if "order" in self.chosen else f"`order` {self.order}")
            table = "with" if machine.has_workpiece else "without"
            model = (f" (`model` auto, the default: {self.model} for a machine {table} table axes)"
                     if "model" in self.chosen else "")
            points = f"`n_commands` {self.n_commands}" + (" (the default)" if self.n_commands == PlanSettings.n_commands
                                                          else "")
            raise InputError(f"{order}: the {self.model} model of order {self.order} of {machine.name}{model} has "
                             f"{n_parameters + 6} unknowns, but {points} x {len(self.tools_mm)} holders give {eq} "
                             "equations; plan more `n_commands` or a lower `order`")


@dataclass
class PlanProblem:
    """What a plan is planned for, checked before any work: the machine and its
    ``settings``; the measurement set-up: ``tracker`` (3,) [m] machine base frame
    (``tracker_side``: the side a default tracker stands on, "" when given), ``nests``
    {id: (3,) [m], workpiece frame}; the holder lengths ``tools`` (H,) [m]; the fit's
    ``noise``; the approach ``steps`` (n,) [m, rad]; the box ``lo``, ``hi`` (n,)
    [m, rad] the commands may take (the measurement zone, room for the approach); the
    rapid ``speed`` (n,) [m/s, rad/s] of every axis."""

    machine: Machine
    settings: PlanSettings
    tracker: np.ndarray
    tracker_side: str
    nests: dict[str, np.ndarray]
    tools: np.ndarray
    noise: NoiseModel
    steps: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    speed: np.ndarray
    placement: Placement | None = None


def plan_problem(machine: Machine, s: PlanSettings) -> PlanProblem:
    """Check the settings against ``machine`` and fix the measurement set-up (tracker and
    table nests: the stage where a proposal of nest places or tracker stations fits), the
    approach steps, the box the commands may take and the axes' rapid speeds."""
    s.check()
    if s.model == "auto":  # before any data: the kind a table machine needs, else Paper I's
        s = replace(s, model="6dof" if machine.has_workpiece else "ap", chosen=s.chosen + ("model",))
    if s.order == "auto":
        s = replace(s, order=AUTO_ORDER, chosen=s.chosen + ("order",))
    for z in s.exclude:
        check_zone_axes(machine, z, "exclude")
    if s.zone:
        check_zone_axes(machine, s.zone, "zone")
    nests = s.nest_places(machine)  # checked before any work
    if nests and s.n_commands > TABLE_MINUTE_POINTS:
        warnings.warn(VecpinWarning(
            f"`n_commands` {s.n_commands}: a plan with table nests of more than {TABLE_MINUTE_POINTS} commands takes more "
            f"than a minute to compute (measured: {TABLE_LARGEST}); plan at most {TABLE_MINUTE_POINTS} for an answer "
            "within a minute"), stacklevel=2)
    if s.tracker_mm is None:
        tracker, azimuth = default_tracker_placement(machine)
        side = side_name(azimuth)
    else:
        check_tracker_units(machine, s.tracker_mm)
        tracker, side = np.asarray(s.tracker_mm, float) * M_PER_MM, ""
    placement = None
    if s.place_nests and s.sight and len(nests) >= 3 and not s.nest_mm:  # nests and stations that see the table
        placement = place_nests(machine, tracker, len(nests), s.tools_mm[0] * M_PER_MM, seed=s.seed,
                                geometry=s.geometry, tool_radius=s.tool_radius_mm * M_PER_MM,
                                target_clearance=s.target_clearance_mm * M_PER_MM)
        nests = placement.nests
    steps = route.approach_steps(machine, s.approach_mm, s.approach_deg)
    lo, hi = clip_to_zone(machine, s.zone)
    alo, ahi = route.approach_margin(machine, s.approach, steps)
    lo, hi = np.maximum(lo, alo), np.minimum(hi, ahi)
    if np.any(hi <= lo):
        raise InputError("the measurement zone leaves no room for the approach moves: widen `zone` or shorten "
                         "`approach_mm`/`approach_deg`")
    return PlanProblem(machine, s, tracker, side, nests, np.array(s.tools_mm, float) * M_PER_MM,
                       s.noise or NoiseModel.default(machine, "spherical"), steps, lo, hi,
                       route.axis_speeds(machine, s.rapid_mm_min, s.rapid_deg_min), placement)


def planned_model(machine: Machine, s: PlanSettings) -> ErrorModel:
    """The model a plan is made for: ``s.model`` of order ``s.order`` with the basis
    ``s.basis`` as the fit takes it, fixed before any data: ``auto`` and ``fourier``, a
    Fourier series per turn on rotary axes travelling more than a turn and Chebyshev
    elsewhere; ``chebyshev``, ``fourier_trend`` and ``spline`` as
    :func:`vecpin.selection.choice.fixed_model` builds them; ``pspline`` as the spline of
    the same knots (its smoothing, chosen from the data, only adds information), and so is
    ``smooth`` (its smoothness prior only adds information)."""
    if s.basis in ("auto", "fourier", "chebyshev"):
        return make_model(s.model, machine, s.order, basis="chebyshev" if s.basis == "chebyshev" else "fourier")
    from vecpin.selection.choice import fixed_model
    return fixed_model(machine, s.model, "spline" if s.basis in ("pspline", "smooth") else s.basis, s.order)


def check_tracker_units(machine: Machine, tracker_mm, option: str = "tracker_mm") -> None:
    """A tracker position [mm, machine base frame] whose every coordinate is within 1/100 of
    the machine's longest linear travel of the origin (a tracker standing in the machine)
    was typed in metres: refused, naming the parameter ``option`` and the likely unit."""
    if tracker_mm is None:
        return
    p = np.asarray(tracker_mm, float)
    spans = [a.upper_user - a.lower_user for a in machine.axes if a.kind == "linear"]
    top = float(np.abs(p).max()) if p.size and np.all(np.isfinite(p)) else 0.0
    if spans and 0 < top <= max(spans) / 100:
        raise InputError(f"`{option}` {','.join(f'{v:g}' for v in p)}: the tracker {top:g} mm or less from the "
                         f"machine origin, inside a machine whose travel reaches {max(spans):.0f} mm: metres? The "
                         f"position is mm, machine base frame ({','.join(f'{v * 1000:g}' for v in p)} if it was "
                         "in metres)")


def check_safe_height(machine: Machine, axis: int, up: int, safe_z_mm: float | None) -> None:
    """A safe height [mm, machine coordinates] of the retract axis that lies within 1/100 of
    the travel from the end toward the work, where the value times 1000 would lie inside the
    travel, was typed in metres: refused, the likely unit named (``safe_z_mm``)."""
    if safe_z_mm is None or not np.isfinite(safe_z_mm) or safe_z_mm == 0:
        return
    a = machine.axes[axis]
    lo, hi = a.lower_user, a.upper_user
    span = hi - lo
    depth = (safe_z_mm - lo) if up > 0 else (hi - safe_z_mm)   # how far from the end toward the work
    if span > 0 and depth <= span / 100 and lo <= safe_z_mm * 1000 <= hi:
        raise InputError(f"`safe_z_mm` {safe_z_mm:g}: {safe_z_mm:g} mm is {depth:g} mm from the end of {a.name}'s "
                         f"travel toward the work ({lo:g} to {hi:g} mm), not a safe height; "
                         f"{safe_z_mm * 1000:g} mm would be inside the travel: metres? Give it in mm, machine "
                         "coordinates")
