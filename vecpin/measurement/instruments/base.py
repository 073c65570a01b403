"""The interface every instrument implements, and the registry.

An instrument turns the machine-frame points that a model predicts for its rows into
*equations*: at most three per row (padded to three, so every instrument's rows stack
into one (N, 3) array), each with

* the residual ``r`` = measured - predicted, in the instrument's own coordinates;
* ``dr/dp``: its derivative with respect to the predicted machine-frame point;
* ``dr/du``: its derivative with respect to the instrument's own unknowns (station
  pose corrections, pivot centres), which the fit estimates beside the model;
* ``S``: the instrument's noise covariance;
* a *metric* residual in metres (a point difference, a range or a radius) that
  reports and cross-validation quote.

An instrument also says which machine point its rows measure (:meth:`Instrument.request`,
a :class:`~vecpin.measurement.instruments.points.PointRequest`): a point on the tool
(the tip, or a target off the tool axis) or a point fixed on the table (a nest), with
the unknowns of that point (target offsets, nest positions) named after its own.

The likelihood (:mod:`vecpin.identification.likelihood`) asks the model for those
points, adds the machine's own positioning noise, whitens and stacks the equations.
To add an instrument, write one module with a subclass of :class:`Instrument` and
decorate it with :func:`register_instrument`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

REGISTRY: dict[str, type["Instrument"]] = {}
ROW_KINDS: dict[str, list[str]] = {}  # campaign 'instrument' column value -> instrument names


def register_instrument(cls: type["Instrument"]) -> type["Instrument"]:
    """Make an instrument available by its ``name`` (decorator)."""
    REGISTRY[cls.name] = cls
    ROW_KINDS.setdefault(cls.row_kind, []).append(cls.name)
    return cls


@dataclass
class Equations:
    """Equations of n rows, padded to 3 per row (SI).

    r (n,3); dr_dp (n,3,3) w.r.t. the machine-frame point; dr_du (n,3,U) w.r.t. the
    block's unknowns; S (n,3,3) noise covariance (identity on padded equations);
    valid (3,) bool: the equations each row really has; metric (n,3) and dmetric_dp
    (n,3,3): the reported residual [m]; dr_dy (n,3,3) or None: w.r.t. the point in the
    instrument frame (tracker rows, for tracker-frame effects); dmetric_du (n,3,U);
    y (n,3) or None: the predicted point in the instrument frame."""

    r: np.ndarray
    dr_dp: np.ndarray
    dr_du: np.ndarray
    S: np.ndarray
    valid: np.ndarray
    metric: np.ndarray
    dmetric_dp: np.ndarray
    dr_dy: np.ndarray | None = None
    dmetric_du: np.ndarray | None = None
    y: np.ndarray | None = None


class Instrument:
    """One kind of measurement row.

    ``name``: the instrument's name (the instrument choices of the noise model); ``row_kind``: the
    campaign's ``instrument`` column value of its rows ("tracker", "ballbar");
    ``n_equations``: equations per row (1..3); ``group_by``: the campaign column whose value
    splits the rows into blocks that share unknowns (None: one block). Subclasses implement
    :meth:`unknowns` and :meth:`equations`."""

    name: ClassVar[str] = "instrument"
    row_kind: ClassVar[str] = "tracker"
    n_equations: ClassVar[int] = 3
    description: ClassVar[str] = ""
    group_by: ClassVar[str | None] = None

    def __init__(self, noise):
        self.noise = noise  # vecpin.measurement.noise.NoiseModel: the instrument's settings

    @property
    def valid(self) -> np.ndarray:
        return np.arange(3) < self.n_equations

    def groups(self, campaign, rows: np.ndarray) -> dict[int, np.ndarray]:
        """Rows split by what shares unknowns (a tracker station, a pivot): by the value of the
        campaign's ``group_by`` column."""
        if self.group_by is None:
            return {0: rows}
        values = getattr(campaign, self.group_by)[rows]
        return {int(k): rows[values == k] for k in np.unique(values)}

    def unknowns(self, campaign, rows: np.ndarray, nominal: np.ndarray, setup) -> list[str]:
        """Names of the block's own unknowns; sets their starting values in ``setup``."""
        return []

    def request(self, campaign, rows: np.ndarray, setup):
        """(PointRequest, names of the point's unknowns): the points the rows measure.
        Default: the tool tip (or a tool target) of the row's tool point."""
        from vecpin.measurement.instruments.points import tool_request
        return tool_request(campaign, rows, setup, 0)

    def equations(self, campaign, rows: np.ndarray, p: np.ndarray, setup, u: np.ndarray,
                  tracker_terms=None) -> Equations:
        """Equations of the rows given the predicted machine-frame points p (n,3) and the
        block's own unknowns u (those :meth:`unknowns` named)."""
        raise NotImplementedError

    def pad(self, n: int) -> dict:
        """Zero arrays of the padded shapes for n rows."""
        S = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
        return {"r": np.zeros((n, 3)), "dr_dp": np.zeros((n, 3, 3)), "S": S, "metric": np.zeros((n, 3)),
                "dmetric_dp": np.zeros((n, 3, 3))}


def instrument_for(name: str, noise):
    from vecpin.errors import InputError
    try:
        return REGISTRY[name](noise)
    except KeyError:
        raise InputError(f"unknown instrument '{name}' (known: {', '.join(REGISTRY)})") from None
