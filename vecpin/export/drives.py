"""Twin-drive axes: a gantry axis driven by two motors gets its tables for both drives.

The Master Mill's X (seed Section 2.5) is one axis of the kinematics with two drives,
AX1 leading and AX8 following; the controller compensates each drive, so every table
that corrects X is loaded twice: 25 tables of a 5-axis machine become 30 (the five that
correct X, for the following drive too). The controller profile declares the
following drive (``"following"`` under the axis, see :mod:`vecpin.export.profile`).

For the writers the following drive is one more axis: :func:`expand` gives an
:class:`ExportMachine` (the machine plus an axis per following drive, named ``X2``,
copying the leading axis' travel) and the table set with the copies; every format then
writes it with its own rules (a pitch table of the following drive is read from its own
encoder, i.e. input = itself).

A gantry skew (:class:`~vecpin.models.effects.gantry_skew.GantrySkew`: a rotation by
``theta(q)`` after the axis, about one of its frame axes) is what two drives can
correct by moving apart: with the drives at ``-s/2`` and ``+s/2`` from the beam's
centre (``s`` the separation, profile ``drive_separation_mm``), the rotation moves
drive d by ``theta (w x r_d) . x`` along the axis (``w`` the rotation axis, ``x`` the
axis direction), so the leading drive gets ``+k theta`` and the following ``-k theta``
with ``k = (w x s) . x / 2``: plus/minus half the separation times the angle. theta is
a sum of one function per other axis (eq. 23-24), so the differential is one table per
input axis for each drive. :func:`twin_drives` puts the differential into the table set
(:class:`~vecpin.compensation.tables.TwinDrive`), so ``tables.json`` carries it and the
simulator and ``verify`` turn the beam with it.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from vecpin.compensation.tables import CompensationTable, TableSet, TwinDrive, table_grid
from vecpin.export.profile import ControllerProfile, twin_axes
from vecpin.kinematics.machine import Machine
from vecpin.units import MM_PER_M, from_mm


def following_name(machine, axis: str) -> str:
    """The vecpin name of an axis' following drive: ``X2`` (``X_following`` if X2 exists)."""
    name = f"{axis}2"
    return name if name not in machine.axis_names else f"{axis}_following"


class ExportMachine:
    """The machine as the writers see it: its axes plus one per following drive (a copy
    of the leading axis under the following drive's name). Anything else is the machine's."""

    def __init__(self, machine, extra: dict[str, str]):
        self._machine = machine
        self.leading = dict(extra)  # following drive name -> leading axis
        self.axes = tuple(machine.axes) + tuple(
            dataclasses.replace(machine.axis(a), name=f, index=machine.n_axes + k)
            for k, (f, a) in enumerate(extra.items()))

    def __getattr__(self, name):
        return getattr(self._machine, name)

    # the machine's own facts of its axes, over the axes with the following drives
    n_axes = Machine.n_axes
    axis_names = Machine.axis_names
    axis = Machine.axis
    lower = Machine.lower
    upper = Machine.upper

    def joint_frames(self, q: np.ndarray, axis: str) -> np.ndarray:
        n = self._machine.n_axes
        return self._machine.joint_frames(np.atleast_2d(q)[:, :n], self.leading.get(axis, axis))


def twin_drives(machine, profile: ControllerProfile,
                differential: dict[str, list[CompensationTable]] | None = None) -> list[TwinDrive]:
    """The profile's twin-drive axes as :class:`TwinDrive` (following drive's name, the
    separation [m] or None, the ``differential`` tables of the leading drive, if any)."""
    out = []
    for a in twin_axes(profile):
        sep = profile.axis(a).drive_separation_mm
        out.append(TwinDrive(a, following_name(machine, a), None if sep is None else from_mm(np.asarray(sep, float)),
                             list((differential or {}).get(a, []))))
    return out


def expand(tables: TableSet, machine, profile: ControllerProfile,
           differential: dict[str, list[CompensationTable]] | None = None):
    """(tables for the writers, ExportMachine, profile): every table whose output is a
    twin-drive axis copied for its following drive (a pitch table: input = the drive
    itself), the ``differential`` tables (per twin axis: tables of the *leading* drive,
    added to the leading drive and subtracted from the following; default: those of
    ``tables.drives``) folded in."""
    twins = twin_axes(profile)
    if not twins:
        return tables, machine, profile
    if differential is None:
        differential = {d.axis: d.differential for d in tables.drives if d.differential}
    extra = {following_name(machine, a): a for a in twins}
    xm = ExportMachine(machine, extra)
    out = [CompensationTable(t.input_axis, t.output_axis, t.start, t.step, t.values.copy(), t.modulo)
           for t in tables.tables]
    for f, a in extra.items():
        for t in tables.tables:
            if t.output_axis == a:
                out.append(CompensationTable(f if t.is_pitch else t.input_axis, f, t.start, t.step, t.values.copy(),
                                             t.modulo))
        for d in (differential or {}).get(a, []):
            for sign, drive in ((1.0, a), (-1.0, f)):
                _add(out, d.input_axis, drive, d, sign)
    axes = dict(profile.axes)
    for f, a in extra.items():
        axes[f] = profile.axis(a).following
    prof = dataclasses.replace(profile, axes=axes)
    return TableSet(xm.axis_names, out, tables.gauge_offset_change, tables.source), xm, prof


def _add(tables: list[CompensationTable], input_axis: str, output_axis: str, d: CompensationTable, sign: float):
    """Add ``sign * d`` to the table (input, output), on its grid, or append it."""
    for t in tables:
        if t.input_axis == input_axis and t.output_axis == output_axis:
            t.values = t.values + sign * d(t.positions)
            return
    tables.append(CompensationTable(input_axis, output_axis, d.start, d.step, sign * d.values, d.modulo))


def fold(tables: TableSet, machine, profile: ControllerProfile) -> TableSet:
    """Back from the writers' tables (as read from the files) to the machine's axes: the
    correction of a twin-drive axis is the mean of its drives' and half their difference
    is the differential (leading minus following, :attr:`TableSet.drives`). A set with
    no table for a following drive (``tables.json``) is already on the machine's axes."""
    twins = twin_axes(profile)
    lead = {following_name(machine, a): a for a in twins}
    if not any(t.output_axis in lead for t in tables.tables):
        return tables
    groups: dict[tuple[str, str], list[CompensationTable]] = {}
    for t in tables.tables:
        o = lead.get(t.output_axis, t.output_axis)
        i = lead.get(t.input_axis, t.input_axis)
        groups.setdefault((i, o), []).append(t)
    out, differential = [], {}
    for (i, o), ts in groups.items():
        ref = ts[0]
        vals = np.mean([t(ref.positions) for t in ts], axis=0)
        if o in twins and len(ts) == 1:  # a table on one drive only moves the gantry by half of it
            vals = vals / 2
            d = vals if ts[0].output_axis == o else -vals  # leading only: +half; following only: -half
        else:
            by_out = {t.output_axis: t(ref.positions) for t in ts}
            d = (by_out[o] - by_out[next(f for f, a in lead.items() if a == o)]) / 2 if o in twins else 0.0
        if o in twins and np.any(d != 0):
            differential.setdefault(o, []).append(CompensationTable(i, o, ref.start, ref.step, d, ref.modulo))
        out.append(CompensationTable(i, o, ref.start, ref.step, vals, ref.modulo))
    return TableSet(list(machine.axis_names), out, tables.gauge_offset_change, tables.source,
                    twin_drives(machine, profile, differential))


def skew_differential(model, profile: ControllerProfile, n_points: int) -> tuple[dict, list, list[str]]:
    """The gantry skews of ``model`` that the twin drives can take, as differential tables.

    Returns (per twin axis: the leading drive's tables [m], one per input axis; the
    effects taken, whose parameters the other tables must no longer carry; notes). A
    skew about an axis that the drives cannot turn (parallel to the separation or to
    the axis) stays with the other tables, with a note."""
    from vecpin.models.effects.base import axis_chebyshev
    m = model.machine
    tables: dict[str, list[CompensationTable]] = {}
    taken, notes = [], []
    for e, sl in model.effect_slices():
        if e.name != "gantry_skew":
            continue
        a = e.axes[0]
        p = profile.axis(a)
        if p.following is None or p.drive_separation_mm is None:
            notes.append(f"{e.label}: no twin drives with a separation for {a} in the profile "
                         "('following', 'drive_separation_mm'): the skew stays in the other tables")
            continue
        q0 = np.clip(np.zeros(m.n_axes), m.lower, m.upper)[None]
        F = m.joint_frames(q0, a)[0]
        w = F[:3, "xyz".index(e.about)]
        x = F[:3, :3] @ np.asarray(m.axis(a).direction, float)
        s = from_mm(np.asarray(p.drive_separation_mm, float))
        k = float(np.cross(w, s) @ x) / 2
        if abs(k) < 1e-6 * max(np.linalg.norm(s), 1e-9):
            notes.append(f"{e.label}: the drives of {a} cannot turn the gantry about {e.about} (the rotation axis is "
                         "parallel to the drive separation or to the axis): the skew stays in the other tables")
            continue
        theta = model.b_[sl]
        for j, other in enumerate(e.others):
            ax = m.axis(other)
            start, step = table_grid(ax, n_points, False)
            pos = start + step * np.arange(n_points)
            qq = np.zeros((n_points, m.n_axes))
            qq[:, ax.index] = pos
            ang = axis_chebyshev(m, other, qq, e.order) @ theta[j * e.order:(j + 1) * e.order]
            tables.setdefault(a, []).append(CompensationTable(other, a, start, step, k * ang))
        taken.append(e)
        notes.append(f"{e.label}: a differential table between the drives of {a} per input axis "
                     f"({', '.join(e.others)}): leading drive {k * MM_PER_M:+.1f} mm x angle [rad], following the "
                     "opposite (half the drive separation times the angle)")
    return tables, taken, notes
