"""How long a planned campaign takes, row by row, as its NC program runs it.

The program (:mod:`vecpin.planning.ncprogram`) visits the tool rows in order: the
retract axis lifts to its safe position, the other linear axes move to the next
approach position, then the rotary axes, the retract axis plunges, the final approach
runs at the approach feed, then the dwell for the tool target and one more dwell per
table nest read there (and, on a run that reads every point several times at one
standstill, a dwell per further reading, no move). Each rapid move takes the time of its slowest axis at its rapid
speed (no acceleration: a lower bound of the moves). A change of the target holder
(the program stops with ``M0``) costs ``holder_change_s`` (the operator swaps the
holder and the tracker locks on again); the stop where the tracker moves to another
station (a plan read from several stations) costs ``tracker_move_s`` (carry it to its
next stand, level it, let it settle and lock on again; a holder swapped there meanwhile).

The plan prints the total and the simulator stamps a planned campaign's rows with
these times, so both book the same campaign; it stamps the further readings of a point
in its validation run ``read_dwell_s`` apart too (:func:`reread_times`).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.plantemplate import PlanTemplate
from vecpin.planning.ncprogram import READ_DWELL_S, readings, retract_axis, safe_position, visits

HOLDER_CHANGE_S = 120.0  # s: swap the target holder at the M0 stop and let the tracker lock on again
TRACKER_MOVE_S = 1200.0  # s, ASSUMED: move the tracker to its next station, level it, let it settle, lock on


@dataclass
class ProgramTiming:
    """The NC program's settings that make its time: dwells [s] (``read_dwell_s`` per
    further reading of a point at its standstill), holder change [s], approach feed
    [mm/min], the retract axis and its safe position [mm], rapid speeds ``speed`` (n,)
    [m/s, rad/s] and approach ``steps`` (n,) [m, rad]."""

    speed: np.ndarray
    steps: np.ndarray
    dwell_s: float = 4.0
    nest_dwell_s: float = 15.0
    holder_change_s: float = HOLDER_CHANGE_S
    feed_mm_min: float = 1000.0
    safe_z_mm: float | None = None
    retract: str | None = None
    tracker_move_s: float = TRACKER_MOVE_S
    read_dwell_s: float = READ_DWELL_S

    def check(self) -> None:
        if not (np.isfinite(self.holder_change_s) and self.holder_change_s >= 0):
            raise InputError(f"`holder_change_s` {self.holder_change_s}: the time of a holder change in seconds >= 0")
        if not (np.isfinite(self.tracker_move_s) and self.tracker_move_s >= 0):
            raise InputError(f"`tracker_move_s` {self.tracker_move_s}: the time to move the tracker to another "
                             "station in seconds >= 0")


@dataclass
class CampaignTime:
    """Where a planned campaign's time goes [s]: rapid moves (lifts and plunges
    included), final approaches at the feed, dwells at the points and nests,
    ``changes`` holder changes and ``tracker_moves`` moves of the tracker to another station."""

    moves_s: float
    approach_s: float
    dwell_s: float
    changes: int
    change_s: float
    tracker_moves: int = 0
    tracker_move_s: float = TRACKER_MOVE_S

    @property
    def total_s(self) -> float:
        return (self.moves_s + self.approach_s + self.dwell_s + self.changes * self.change_s
                + self.tracker_moves * self.tracker_move_s)

    def line(self) -> str:
        moved = (f" + {self.tracker_moves} tracker move{'s' if self.tracker_moves != 1 else ''} to another station x "
                 f"{self.tracker_move_s / 60:.0f} min" if self.tracker_moves else "")
        return (f"campaign time {self.total_s / 3600:.2f} h: moves {self.moves_s / 60:.1f} min (rapid, lifts "
                f"included) + approaches {self.approach_s / 60:.1f} min + dwells {self.dwell_s / 60:.1f} min + "
                f"{self.changes} holder change{'s' if self.changes != 1 else ''} x {self.change_s / 60:.0f} min"
                + moved)

    def to_dict(self) -> dict:
        return {"total_h": round(self.total_s / 3600, 4), "moves_min": round(self.moves_s / 60, 4),
                "approaches_min": round(self.approach_s / 60, 4), "dwells_min": round(self.dwell_s / 60, 4),
                "holder_changes": self.changes, "holder_change_s": self.change_s,
                "tracker_moves": self.tracker_moves, "tracker_move_s": self.tracker_move_s}


def reread_times(t: np.ndarray, again: np.ndarray, read_dwell_s: float = READ_DWELL_S) -> np.ndarray:
    """Time stamps [s] ``t`` (N,) with every further reading of a point at its standstill
    (``again`` (N,) bool: :func:`~vecpin.planning.programroute.rereads`) ``read_dwell_s`` [s]
    after the reading before it, as the NC program dwells between them (:func:`row_times`);
    every other row keeps its time stamp."""
    idx = np.arange(len(t))
    first = np.maximum.accumulate(np.where(again, 0, idx))  # each row's first reading of its point
    return np.where(again, t[first] + (idx - first) * read_dwell_s, t)


def row_times(machine: Machine, template: PlanTemplate, timing: ProgramTiming,
              reads: int = 1) -> tuple[np.ndarray, CampaignTime]:
    """(time stamp [s] of every row of ``template``, at the end of its reading; the
    campaign's time) when the NC program runs it with ``timing``; ``reads``: every point
    read that many times at one standstill (:func:`~vecpin.planning.ncprogram.readings`:
    a dwell per reading, no move)."""
    t, took, _ = run_times(machine, template, timing, reads)
    return t, took


def run_times(machine: Machine, template: PlanTemplate, timing: ProgramTiming,
              reads: int = 1) -> tuple[np.ndarray, CampaignTime, CampaignTime]:
    """:func:`row_times` and the time of the same campaign reading every point once (its
    further readings at a standstill left out: the same moves, approaches and stops, the
    dwells of the first readings alone; with ``reads`` 1 the campaign's time)."""
    timing.check()
    r, up = retract_axis(machine, timing.retract)
    safe = safe_position(machine, r, up, timing.safe_z_mm)
    vs, end = visits(machine, template, timing.steps, r, up, safe, reads)
    v_user = machine.to_user(np.asarray(timing.speed, float)[None])[0]  # mm/s, deg/s
    lin = np.array([a.kind == "linear" for a in machine.axes])
    others = lin.copy()
    others[r] = False
    feed = timing.feed_mm_min / 60.0
    t = np.zeros(len(template))
    now = moves = approach = dwell = dwell_once = 0.0
    changes = tracker_moves = 0
    prev, cur_tool, cur_station = None, None, 0
    for v in vs:
        tool, station = float(template.tool[v.row]), int(template.stations[v.row])
        if cur_tool is not None and station != cur_station:    # a stop: the tracker moves (a holder swapped meanwhile)
            tracker_moves += 1
            now += timing.tracker_move_s
        elif cur_tool is not None and abs(tool - cur_tool) > 1e-9:  # a stop: the holder changes
            changes += 1
            now += timing.holder_change_s
        cur_tool, cur_station = tool, station
        if prev is not None:
            lift = v.lift if v.lift is not None else prev[r]
            step = abs(lift - prev[r]) / v_user[r]
            d = np.abs(v.a - prev) / v_user
            step += (d[others].max() if others.any() else 0.0) + (d[~lin].max() if (~lin).any() else 0.0)
            step += abs(lift - v.a[r]) / v_user[r]
            moves += step
            now += step
        a = np.abs(v.q - v.a)
        step = max(a.max() if a.size else 0.0, 0.0) / feed
        approach += step
        now += step
        for k, sec, _, again in readings(template, v, (timing.dwell_s, timing.nest_dwell_s, timing.read_dwell_s)):
            now += sec
            dwell += sec
            if not again:
                dwell_once += sec
            t[k] = now
        prev = v.q
    if end is not None and prev is not None:
        moves += abs(end - prev[r]) / v_user[r]
    took = CampaignTime(moves, approach, dwell, changes, timing.holder_change_s, tracker_moves, timing.tracker_move_s)
    return t, took, replace(took, dwell_s=dwell_once)
