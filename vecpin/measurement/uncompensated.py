"""The one uncompensated figure of a campaign: every command that prints the machine's
uncompensated error (``import``, ``assess``, ``fit``, the report) takes it from here."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.partframe import RunReference, part_frame_errors, spindle_axis
from vecpin.measurement.registration import registered_errors, spans_plane
from vecpin.units import norm_mm


@dataclass
class Uncompensated:
    """The uncompensated volumetric error of a campaign: the distance [mm] of each measured
    point from its nominal point in the part's frame (the readings taken into the machine's
    own reference frame, then a translation and a turn about the spindle removed:
    :class:`~vecpin.measurement.partframe.RunReference`), on ``campaign``'s rows ``rows``;
    ``shape_mm``: the same after one best rigid fit (the seed's 'uncompensated' figure)."""

    distances_mm: np.ndarray   # (n,) mm, one per row in ``rows``
    rows: np.ndarray           # (n,) row indices into the campaign handed in
    tool: np.ndarray           # (n,) tool lengths of those rows [m]
    shape_mm: np.ndarray | None = None   # (n,) mm, the best rigid motion removed instead
    table_tips: np.ndarray | None = None   # (n,3) [m] the measured tips relative to the table (workpiece frame),
                                           # where the figure is read through the table nests

    @property
    def table(self) -> bool:
        """True: the figure is of the tip relative to the table."""
        return self.table_tips is not None

    @property
    def mean_mm(self) -> float:
        return float(self.distances_mm.mean())

    @property
    def max_mm(self) -> float:
        return float(self.distances_mm.max())

    @property
    def mean_max_mm(self) -> tuple[float, float]:
        return self.mean_mm, self.max_mm

    def line(self) -> str:
        """The line every command prints alike (:func:`uncompensated_line`)."""
        return uncompensated_line(self.mean_mm, self.max_mm, len(self.rows), self.table)


def uncompensated_line(mean_mm: float, max_mm: float | None, rows: int | None, table: bool = False) -> str:
    """The uncompensated error as ``import``, ``assess`` and ``fit`` print it (mm); ``table``:
    the tip relative to the table."""
    where = "the tip relative to the table, " if table else ""
    how = f"nominal kinematics, {where}the part's frame, {rows} rows" if rows else "as given"
    mx = f", max {max_mm:.4f} mm" if max_mm is not None else ""
    return f"  uncompensated error ({how}): mean {mean_mm:.4f} mm{mx}"


def uncompensated(machine: Machine, campaign: Campaign, strict: bool = True) -> Uncompensated | None:
    """The one uncompensated figure of a campaign, the same for ``import``, ``assess`` and
    ``fit``. A machine with a table branch whose campaign reads table nests: the tip relative
    to the table (:func:`relative_to_table`), as ``evaluate`` judges it. Otherwise every tracker row of station 0 that reads the tool tip or a target of known
    offset (nest rows, ball bar rows and targets the fit must find are left out), the
    nominal tool points (base frame, m) against the readings (tracker frame, m) taken into
    the machine's reference frame and judged as a part sees them (:class:`Uncompensated`).
    Fewer than 3 such rows, or nominal points on a line (the tool of a machine whose every
    axis moves the table stands still): an InputError, or None when not ``strict``."""
    if machine.has_workpiece and len(campaign.nest_rows):
        rel = relative_to_table(machine, campaign)
        if rel is not None:
            return rel
    known = (campaign.target == "") | np.isin(campaign.target, list(campaign.targets))
    rows = np.flatnonzero((campaign.instrument == "tracker") & (campaign.station == 0) & known)
    if len(rows) < 3:
        if not strict:
            return None
        raise InputError(f"{campaign.source}: {len(rows)} tracker rows of station 0 read the tool tip or a known "
                         "target; the uncompensated error needs at least 3")
    offset = np.zeros((len(rows), 3))
    for i in np.flatnonzero(campaign.target[rows] != ""):   # rows of targets only (a million tool tips: no loop)
        offset[i] = campaign.targets[campaign.target[rows[i]]]
    nominal = machine.tool_tip(campaign.q[rows], campaign.tool[rows], frame="base", point=campaign.point[rows],
                               offset=offset if np.any(offset) else None)   # no offset: the tips the checks asked for
    if not spans_plane(nominal):
        if not strict:
            return None
        raise InputError(f"{campaign.source}: the nominal tool points of its rows lie on a line, so the readings "
                         "cannot be registered onto them: no uncompensated error at the tool")
    xyz, tool = campaign.xyz[rows], campaign.tool[rows]
    ref = RunReference(machine, campaign.q[rows], tool, nominal, xyz)
    err = norm_mm(part_frame_errors(nominal, ref(xyz), spindle_axis(machine)))
    return Uncompensated(err, rows, tool, norm_mm(registered_errors(nominal, xyz)))


def relative_to_table(machine: Machine, campaign: Campaign) -> Uncompensated | None:
    """The uncompensated error of the tip relative to the table, as a part on the table sees
    it: each command's table pose registered on the nests read at it (their shape fitted
    from this run alone: no model), the measured tip against the nominal tip in the workpiece
    frame, the run taken into the machine's reference frame and a part's set-up removed
    (:mod:`vecpin.measurement.tableframe`); ``rows``: the tool rows judged. None when no
    command has three or more nests not on a line, or the nominal tips lie on a line."""
    from vecpin.measurement.tableframe import table_nests, table_tips
    nests, refitted = table_nests([campaign])
    tt = table_tips(campaign, nests, refitted)
    if len(tt.rows) < 3:
        return None
    c = campaign.subset(tt.rows)
    offset = np.array([campaign.targets.get(str(t), np.zeros(3)) for t in c.target]) if np.any(c.target != "") else None
    nominal = machine.tool_tip(c.q, c.tool, frame="workpiece", point=c.point, offset=offset)
    if not spans_plane(nominal):
        return None
    ref = RunReference(machine, c.q, c.tool, nominal, tt.tip)
    err = norm_mm(part_frame_errors(nominal, ref(tt.tip), spindle_axis(machine)))
    return Uncompensated(err, tt.rows, c.tool, norm_mm(registered_errors(nominal, tt.tip)), tt.tip)
