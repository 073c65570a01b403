"""Compensated errors as a part sees them, and the report of a table plan.

:func:`compensated_errors`: the tool tip relative to the workpiece of an actual machine
(a model or a simulated truth) commanded through tables, judged in the part's frame
(:mod:`vecpin.measurement.partframe`), as the error's shape, or as it is.
:class:`CompensationReport`: rows of such errors on one set of points, printed as a table.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from vecpin.compensation.functions import FRAME, ActualMachine, nominal_tip
from vecpin.compensation.tables import TableSet
from vecpin.errors import VecpinError
from vecpin.kinematics.machine import Machine
from vecpin.measurement import partframe
from vecpin.measurement.registration import registered_errors
from vecpin.units import MM_PER_M


class ReportRow(NamedTuple):
    """One row of a :class:`CompensationReport`: volumetric errors [mm] over the report's points,
    in the part's frame (:data:`vecpin.measurement.partframe.FRAME_TEXT`).

    ``spread``: (mean over parameter draws, 16th, 84th percentile) [mm] of the mean
    error on machines that differ from the model by its parameter uncertainty, or None.
    ``shape``: the mean error [mm] with the best rigid motion of the whole volume removed
    (the error's shape, the seed's figure), or None."""

    label: str
    mean: float
    max: float
    tables: int = 0
    spread: tuple[float, float, float] | None = None
    shape: float | None = None


@dataclass
class CompensationReport:
    """Volumetric errors [mm] before and after compensation, every row on the same points.

    ``basis`` says what the rows are (e.g. "model-predicted at 1000 commands x 2 tools"):
    rows predicted by a model are a prediction for the model, not a measurement of the
    machine. ``notes`` are printed under the table (what the spread means, figures on
    other points such as the fit residual). Every mean and max is in the part's frame;
    the shape column beside it removes the best rigid motion as well."""

    rows: list[ReportRow] = field(default_factory=list)
    basis: str = ""
    notes: list[str] = field(default_factory=list)

    def add(self, label: str, err: np.ndarray, n_tables: int = 0,
            spread: tuple[float, float, float] | None = None, shape: np.ndarray | None = None) -> None:
        """A row from tool-tip errors (N,3) [m] in the part's frame, and ``shape``, the same
        errors with the best rigid motion removed (N,3) [m]."""
        d = np.linalg.norm(err, axis=1) * MM_PER_M
        s = None if shape is None else float(np.linalg.norm(shape, axis=1).mean() * MM_PER_M)
        self.rows.append(ReportRow(label, float(d.mean()), float(d.max()), n_tables, spread, s))

    def table(self) -> str:
        base = self.rows[0].mean
        with_spread = any(r.spread is not None for r in self.rows)
        with_shape = any(r.shape is not None for r in self.rows)
        width = max([38] + [len(r.label) for r in self.rows])
        head = f"  {'compensation':<{width}s} {'tables':>6s} {'mean mm':>9s} {'max mm':>9s} {'reduction':>9s}"
        if with_shape:
            head += f" {'shape mm':>9s}"
        if with_spread:
            head += f"   {'mean mm with parameter uncertainty [68%]':<40s}"
        lines = ([f"  {self.basis}"] if self.basis else []) + [head]
        for r in self.rows:
            red = "-" if r is self.rows[0] else f"{100 * (1 - r.mean / base):8.1f}%"
            line = f"  {r.label:<{width}s} {r.tables if r.tables else '':>6} {r.mean:9.4f} {r.max:9.4f} {red:>9s}"
            if with_shape:
                line += f" {r.shape:9.4f}" if r.shape is not None else f" {'':>9s}"
            if r.spread is not None:
                line += f"   {r.spread[0]:.4f} [{r.spread[1]:.4f}, {r.spread[2]:.4f}]"
            lines.append(line)
        lines += [f"  {n}" for n in self.notes]
        return "\n".join(lines)


JUDGED = ("part", "shape", "none")


def compensated_errors(actual: ActualMachine, machine: Machine, tables: TableSet | None,
                       q: np.ndarray, tool: np.ndarray, judged: str = "part", point=0) -> np.ndarray:
    """Tool-tip errors (N,3) [m], relative to the workpiece, of the actual machine under
    ``tables`` against the controller's nominal kinematics (with the changed T_offset);
    None: uncompensated. ``point``: tool point index, one or per row. The differential
    tables of twin drives turn their beams (:meth:`TableSet.turn_tips`).

    ``judged``: ``"part"`` (default), as a part set up on the table sees them (its origin
    probed, an edge aligned: a translation and a rotation about the spindle removed,
    :func:`vecpin.measurement.partframe.part_frame_errors`); ``"shape"``, the best rigid
    motion of the whole volume removed (the seed's volumetric error: the error's shape);
    ``"none"``, as they are."""
    if judged not in JUDGED:
        raise VecpinError(f"judged {judged!r}: one of {', '.join(JUDGED)}")
    return _judged(*_compensated_tips(actual, machine, tables, q, tool, point), machine, judged)


def part_and_shape(actual: ActualMachine, machine: Machine, tables: TableSet | None, q: np.ndarray,
                   tool: np.ndarray, point=0) -> tuple[np.ndarray, np.ndarray]:
    """(:func:`compensated_errors` judged "part", and judged "shape"), the machine commanded once."""
    nominal, tip = _compensated_tips(actual, machine, tables, q, tool, point)
    return _judged(nominal, tip, machine, "part"), _judged(nominal, tip, machine, "shape")


def _compensated_tips(actual: ActualMachine, machine: Machine, tables: TableSet | None, q: np.ndarray,
                      tool: np.ndarray, point) -> tuple[np.ndarray, np.ndarray]:
    """(the controller's nominal tips, the actual machine's tips under ``tables``) (N,3) [m]."""
    q = np.atleast_2d(np.asarray(q, float))
    tool = np.broadcast_to(np.asarray(tool, float), (len(q),))
    if tables is None:
        return nominal_tip(machine, q, tool, point), actual(q, tool, False, point)[0]
    qc = tables.apply(q)
    tip = tables.turn_tips(machine, qc, actual(qc, tool, False, point)[0], FRAME)  # twin drives turn their beam
    return nominal_tip(machine, q, tool + tables.gauge_offset_change, point), tip


def _judged(nominal: np.ndarray, tip: np.ndarray, machine: Machine, judged: str) -> np.ndarray:
    if judged == "part":
        return partframe.part_frame_errors(nominal, tip, partframe.spindle_axis(machine))
    if judged == "shape":
        return registered_errors(nominal, tip)
    return tip - nominal
