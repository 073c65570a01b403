"""The campaign in memory: measured rows of one machine, in measurement order, SI.

:class:`Campaign` holds ``q`` [m, rad], ``tool`` [m], ``xyz`` [m] (tracker frame) and the
per-row instrument columns; :mod:`vecpin.measurement.campaign` reads and writes it as the
interchange CSV (mm and degrees).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

INSTRUMENTS = ("tracker", "ballbar", "nest")


def min_rows(n_axes: int) -> int:
    """Fewest rows any fit could use: the smallest model (a constant offset per axis,
    the gauge line and the 6 tracker-frame corrections) has n + 7 unknowns and each
    row gives 3 equations; one more row leaves a residual to judge the fit by."""
    return math.ceil((n_axes + 7) / 3) + 1


@dataclass
class Campaign:
    """Measured tool tips of one machine, rows in measurement order (SI units).

    q: (N, n) axis commands [m, rad], chain order of ``axis_names``;
    tool: (N,) tool lengths [m]; xyz: (N, 3) tracker-frame positions [m];
    extra: optional per-row columns (``time`` [s], ``temperature`` [°C], others as read);
    point: (N,) tool point index; target: (N,) target or nest id ("" = the tool tip);
    targets: known tool-target offsets {id: (3,) [m] in the tool link frame}.
    """

    axis_names: list[str]
    q: np.ndarray
    tool: np.ndarray
    xyz: np.ndarray
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    source: str = "<memory>"
    instrument: np.ndarray | None = None   # (N,) "tracker" / "ballbar"; None: all tracker
    station: np.ndarray | None = None      # (N,) tracker position id
    radius: np.ndarray | None = None       # (N,) ball bar radius [m] (NaN on tracker rows)
    pivot: np.ndarray | None = None        # (N,) ball bar pivot id (-1 on tracker rows)
    lines: np.ndarray | None = None        # (N,) line number of each row in its file (header = 1)
    point: np.ndarray | None = None        # (N,) tool point index (0: the first tool link)
    target: np.ndarray | None = None       # (N,) target id on tracker rows, nest id on nest rows ("" = none)
    targets: dict = field(default_factory=dict)  # known tool-target offsets {id: (3,) [m], tool link frame}
    # (n,) True on the rotary axes when ``q`` holds readings of a machine's axes (read from a
    # file for a machine): poses read twice are compared within the readings' resolution
    # (:func:`~vecpin.measurement.repeatability.reading_groups`); None: exact commands
    rotary: np.ndarray | None = None

    def __post_init__(self):
        n = len(self.tool)
        if self.instrument is None:
            self.instrument = np.full(n, "tracker", dtype=object)
        if self.station is None:
            self.station = np.zeros(n, int)
        if self.radius is None:
            self.radius = np.full(n, np.nan)
        if self.pivot is None:
            self.pivot = np.full(n, -1, int)
        if self.lines is None:
            self.lines = np.arange(2, n + 2)
        if self.point is None:
            self.point = np.zeros(n, int)
        if self.target is None:
            self.target = np.full(n, "", dtype=object)

    def __len__(self) -> int:
        return len(self.tool)

    @property
    def tracker_rows(self) -> np.ndarray:
        return np.flatnonzero(self.instrument == "tracker")

    @property
    def ballbar_rows(self) -> np.ndarray:
        return np.flatnonzero(self.instrument == "ballbar")

    @property
    def nest_rows(self) -> np.ndarray:
        """Rows measuring a reflector in a table nest (tracker readings of a workpiece point)."""
        return np.flatnonzero(self.instrument == "nest")

    @property
    def plain(self) -> bool:
        """True when every row is a tool tip (no nest, no target, tool point 0): the
        rows the nominal tool tip alone predicts."""
        return not (len(self.nest_rows) or np.any(self.point != 0) or np.any(self.target != ""))

    def primary(self) -> "Campaign":
        """The tracker rows of station 0: the rows one tracker pose describes (itself when
        the campaign is not mixed)."""
        if not self.mixed:
            return self
        return self.subset(self.tracker_rows[self.station[self.tracker_rows] == 0])

    @property
    def mixed(self) -> bool:
        """True when the campaign has ball bar rows or several tracker stations."""
        return bool(len(self.ballbar_rows) or len(self.nest_rows)
                    or len(np.unique(self.station[self.tracker_rows])) > 1)

    @property
    def time(self) -> np.ndarray | None:
        return self.extra.get("time")

    @property
    def temperature(self) -> np.ndarray | None:
        return self.extra.get("temperature")

    def subset(self, rows) -> "Campaign":
        """A campaign of the given rows (index array or boolean mask), order kept."""
        rows = np.asarray(rows)
        return Campaign(list(self.axis_names), self.q[rows], self.tool[rows], self.xyz[rows],
                        {k: v[rows] for k, v in self.extra.items()}, self.source,
                        self.instrument[rows], self.station[rows], self.radius[rows], self.pivot[rows],
                        self.lines[rows], self.point[rows], self.target[rows], dict(self.targets), self.rotary)

    def tool_lengths(self) -> np.ndarray:
        """Distinct tool lengths [m] (sorted)."""
        return np.unique(np.round(self.tool, 9))
