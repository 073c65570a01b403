"""What a simulated campaign measures: the design (commands, tools, stations, nests,
targets, ball bar, repeated points, validation commands; Paper I's by default), checked
with the parameter named, and the commands it draws outside the exclusion zones."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import qmc

from vecpin.errors import InputError, VecpinError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import MAX_ID, PAPER_I_TOOLS_MM, min_rows
from vecpin.planning.zones import check_zone_axes, zone_bounds

SIMULATION_BYTES_PER_ROW = 3000  # peak memory of a simulation per row (measured: 2.9 GB for 1,000,000 rows)
MAX_ROWS = 1_300_000  # rows one simulation holds: about 4 GB at the peak


@dataclass
class Design:
    """What to measure. ``exclude``: list of {axis: (lo, hi)} in mm/deg; a
    command inside every interval of a zone is not measured. ``method``: "random",
    "sobol" or "halton" for the identification commands (validation is always Halton).
    ``seconds_per_point`` (settle + measure) and ``feed_m_per_s`` (moves) make ``time``."""

    n_commands: int = 295
    tools_mm: tuple[float, ...] = PAPER_I_TOOLS_MM
    n_validation: int = 35
    method: str = "random"
    exclude: list[dict[str, tuple[float, float]]] = field(default_factory=list)
    seconds_per_point: float = 15.0
    feed_m_per_s: float = 0.1
    repeat_points: int = 0   # after the campaign: this many commands, each measured ...
    repeat_times: int = 0    # ... this many times, in a new random order each sequence (eq. 22)
    stations: int = 1        # tracker positions; every command is measured from each
    ballbar_points: int = 0  # ball bar rows on a sphere about one pivot (eq. 63-64)
    ballbar_radius_mm: float = 254.0
    ballbar_sigma_mm: float = 0.0025
    nests: int | None = None   # reflectors in table nests read at every command (None: 3 on a machine with a workpiece)
    targets_mm: tuple = ()     # reflector offsets (x, y, z) [mm] in the tool link frame, read at every command
    known_targets: bool = False  # the campaign carries the target offsets (else the fit finds them)
    all_points: bool = True    # measure every tool point of a machine with several (Spar Mill's two spindles)

    def n_nests(self, machine: Machine) -> int:
        return (3 if machine.has_workpiece else 0) if self.nests is None else int(self.nests)

    def check(self, machine: Machine, planned_rows: int | None = None, files: bool = False) -> None:
        """Refuse, before any work, a design that is too large to hold or, with ``files``,
        whose files vecpin could not read back (names the parameter).
        ``planned_rows``: the rows of a plan measured instead of drawn commands."""
        need = min_rows(machine.n_axes) if files else 1
        _whole("n_validation", self.n_validation, need, f"a campaign of a {machine.n_axes}-axis machine needs at "
               f"least {need} rows" if files else "validation commands")
        _whole("stations", self.stations, 1, "tracker positions", MAX_ID + 1)
        _whole("ballbar_points", self.ballbar_points, 0, "ball bar rows")
        if self.nests is not None:
            _whole("nests", self.nests, 0, "table nests")
        tools = np.asarray(self.tools_mm, float)
        if tools.size == 0 or not np.all(np.isfinite(tools)) or np.any(tools < 0) or np.any(tools > 10_000):
            raise InputError(f"`tools_mm` {' '.join(f'{t:g}' for t in tools)}: tool lengths are mm from the gauge line, "
                             "0 .. 10000 (e.g. 214.88 312.86)")
        if np.all(tools < 1.0):
            raise InputError(f"`tools_mm` {' '.join(f'{t:g}' for t in tools)}: every length is below 1 mm; tool lengths "
                             "are mm (e.g. 214.88 312.86), not metres")
        if len(np.unique(np.round(tools, 6))) < tools.size:
            raise InputError(f"`tools_mm` {' '.join(f'{t:g}' for t in tools)}: two tools of the same length measure the "
                             "same point twice; give different lengths")
        if self.repeat_points or self.repeat_times:
            if int(self.repeat_points) != self.repeat_points or int(self.repeat_times) != self.repeat_times or \
                    self.repeat_points < 1 or self.repeat_times < 2:
                raise InputError(f"`repeat_points` {self.repeat_points:g}, `repeat_times` {self.repeat_times:g}: at least 1 "
                                 "command, each measured at least 2 times")
            if planned_rows is None and self.repeat_points > self.n_commands:
                raise InputError(f"`repeat_points` {self.repeat_points:g}, `repeat_times` {self.repeat_times:g}: the "
                                 "repeated points are taken "
                                 f"from the campaign's commands, at most `n_commands` ({self.n_commands})")
        for zone in self.exclude:
            check_zone_axes(machine, zone, "exclude")
        if self.method not in ("random", "sobol", "halton"):
            raise InputError(f"`method` {self.method}: random, sobol or halton")
        if planned_rows is None:
            _whole("n_commands", self.n_commands, 1, "commands")
            per_station = self.n_commands * len(tools)
            if files and per_station < need:
                raise InputError(f"`n_commands` {self.n_commands}: {per_station} rows ({self.n_commands} commands x "
                                 f"{len(tools)} tools), but a campaign of a {machine.n_axes}-axis machine needs at "
                                 f"least {need}; give `n_commands` {math.ceil(need / len(tools))} or more")
            repeats = min(self.repeat_points, self.n_commands) * self.repeat_times
        else:
            per_station, repeats = planned_rows, 0
        rows = per_station * self.stations + self.ballbar_points + repeats + self.n_validation
        if rows > MAX_ROWS:
            raise InputError(f"the design has {rows:,} rows (`n_commands` x `tools_mm` x `stations`, `repeat_points`, "
                             f"`ballbar_points`, `n_validation`); vecpin simulates at most {MAX_ROWS:,} rows at once (these would need "
                             f"about {rows * SIMULATION_BYTES_PER_ROW / 1e9:.0f} GB of memory); simulate fewer")


def _whole(option: str, value, lowest: int, what: str, highest: int | None = None) -> None:
    if int(value) != value or value < lowest or (highest is not None and value > highest):
        top = f" .. {highest}" if highest is not None else " or more"
        raise InputError(f"`{option}` {value}: a whole number {lowest}{top} ({what})")


def design_commands(machine: Machine, n: int, rng: np.random.Generator, method: str = "random",
                    exclude=(), scramble_seed: int | None = None) -> np.ndarray:
    """n commands [m, rad] over the axis limits, outside every exclusion zone."""
    zones = [_zone_si(machine, z) for z in exclude]
    out = np.empty((0, machine.n_axes))
    for _attempt in range(50):
        m = max(2 * (n - len(out)), 16)
        if method == "random":
            u = rng.random((m, machine.n_axes))
        elif method in ("sobol", "halton"):
            seed = scramble_seed if scramble_seed is not None else int(rng.integers(2**31))
            eng = qmc.Sobol(machine.n_axes, seed=seed) if method == "sobol" else qmc.Halton(machine.n_axes, seed=seed)
            u = eng.random(2 ** math.ceil(math.log2(m))) if method == "sobol" else eng.random(m)
        else:
            raise VecpinError(f"unknown design method '{method}' (random, sobol, halton)")
        q = machine.lower + u * (machine.upper - machine.lower)
        keep = np.ones(len(q), bool)
        for lo, hi in zones:
            keep &= ~np.all((q >= lo) & (q <= hi), axis=1)
        out = np.vstack([out, q[keep]])
        if len(out) >= n:
            return out[:n]
    raise InputError("`exclude`: the exclusion zones leave (almost) no room for commands; make them smaller")


def _zone_si(machine: Machine, zone: dict[str, tuple[float, float]]):
    """(low, high) [m, rad] of an exclusion zone (see :func:`vecpin.planning.zones.zone_bounds`)."""
    return zone_bounds(machine, zone)
