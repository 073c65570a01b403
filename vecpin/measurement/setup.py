"""The measurement setup: where the instruments stand relative to the machine.

Tracker stations: ``p_tracker = R (exp3(e_rot) p + e_trans) + t`` maps a machine-frame
point p [m] into the frame of a tracker station; (R, t) come from the rigid
registration of the nominal kinematics and the small correction ``e`` (eq. 10's
``E_0`` for station 0) is identified with the model. Ball bar pivots: the centre
sockets [m] in the machine frame.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from vecpin.kinematics.so3 import exp3, right_jacobian, skew

POSE_NAMES = ("dx", "dy", "dz", "ex", "ey", "ez")


@dataclass(frozen=True)
class Setup:
    """The tracker pose of station 0 (``R``, ``t``, correction ``e0``: dx, dy, dz [m],
    ex, ey, ez [rad]); ``stations``: other tracker positions {id: (R, t, e)};
    ``pivots``: ball bar centre sockets {id: centre (3,) [m], machine frame};
    ``nests``: table nests {id: position (3,) [m], workpiece frame}; ``targets``: tool
    targets whose offsets the fit estimates {id: offset (3,) [m], tool link frame};
    ``std``: standard deviations [m] of the fitted nest and target coordinates by
    unknown name (``nest<id>.x``, ``target<id>.y``, ...); ``nest_heights``: {nest id:
    height [m] of its reflector's centre above the table face}, where the user gave them
    (the nests then tell where the table's face is: the frame the tables keep);
    ``nest_height_sd``: {nest id: standard deviation [m] of that height's reading} (a nest
    given a height without one: :data:`~vecpin.measurement.nestheights.GAUGE_SD_MM`);
    ``nest_z_cov``: the fitted nests' z coordinates' covariance [m^2] ({"ids": [...], "cov":
    (N,N)}, from the fit; empty where it is not known); ``face_sweep``: {linear axis: (distance
    [m], the indicator's change [m], + when pushed in as the command increases, its standard
    deviation [m])}: the table face's parallelism read with an indicator swept along that axis
    (:mod:`vecpin.measurement.tableface`), where the user gave it.

    Frozen: vecpin never changes a setup it is given (the likelihood places its stations,
    pivots, nests and targets in a :meth:`copy`; the fit returns a new one); change one with
    :func:`dataclasses.replace`."""

    R: np.ndarray
    t: np.ndarray
    e0: np.ndarray = field(default_factory=lambda: np.zeros(6))
    stations: dict = field(default_factory=dict)
    pivots: dict = field(default_factory=dict)
    nests: dict = field(default_factory=dict)
    targets: dict = field(default_factory=dict)
    std: dict = field(default_factory=dict)
    nest_heights: dict = field(default_factory=dict)
    nest_height_sd: dict = field(default_factory=dict)
    nest_z_cov: dict = field(default_factory=dict)
    face_sweep: dict = field(default_factory=dict)

    def copy(self) -> "Setup":
        """The same setup with containers of its own (adding a station, pivot, nest or target
        to the copy leaves this one as it is; the arrays are shared, never written)."""
        return replace(self, stations=dict(self.stations), pivots=dict(self.pivots), nests=dict(self.nests),
                       targets=dict(self.targets), std=dict(self.std), nest_heights=dict(self.nest_heights),
                       nest_height_sd=dict(self.nest_height_sd), nest_z_cov=dict(self.nest_z_cov),
                       face_sweep=dict(self.face_sweep))

    def pose(self, station: int = 0):
        """(R, t, e) of a station."""
        return (self.R, self.t, self.e0) if station == 0 else self.stations[station]

    def to_tracker(self, p: np.ndarray, station: int = 0) -> np.ndarray:
        R, t, e = self.pose(station)
        return to_station(p, R, t, e)[0]


def to_station(p: np.ndarray, R: np.ndarray, t: np.ndarray, e: np.ndarray, jacobian: bool = False):
    """Machine-frame points p (N,3) [m] in a station's frame ``R (exp3(e_rot) p + e_trans) + t``.

    Returns (y (N,3), dy/dp (3,3) or None, dy/de (N,3,6) or None)."""
    R0 = exp3(e[3:])
    y = (p @ R0.T + e[:3]) @ R.T + t
    if not jacobian:
        return y, None, None
    RR = R @ R0
    de = np.empty((len(y), 3, 6))
    de[:, :, :3] = R
    de[:, :, 3:] = -(RR @ skew(p)) @ right_jacobian(e[3:])
    return y, RR, de


def station_reading(p: np.ndarray, R: np.ndarray, t: np.ndarray, e: np.ndarray, terms=None):
    """What a station reads at machine-frame points p (N,3) [m]: :func:`to_station`, then the
    tracker-frame effects ``terms(y) -> (shift (N,3) [m], d shift / d y (N,3,3))`` moving the
    reading in the station's frame (an instrument shift). The one prediction of a tracker
    reading, for the likelihood and for ``predict(frame="tracker")``.

    Returns (y (N,3), dy/dp (3,3) or (N,3,3), dy/de (N,3,6))."""
    y, RR, de = to_station(p, R, t, e, jacobian=True)
    if terms is None:
        return y, RR, de
    shift, grad = terms(y)
    M = np.eye(3) + grad
    return y + shift, M @ RR, M @ de
