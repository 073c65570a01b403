"""Table nests: the tracker reads a reflector sitting in a nest fixed on the machine
table, whose position in the workpiece (table) frame is unknown and found by the fit.

A floor tracker sees only the tool in the base frame, and the tool does not move when
a table axis turns: the table axes of a trunnion or rotary-table machine are seen only
through points on the table. Nest rows (campaign ``instrument`` = ``nest``, the nest id
in ``target``) are tracker readings like any other (same stations, read the same way:
Cartesian, spherical or range) of a workpiece point instead of the tool tip.
"""
from __future__ import annotations

from vecpin.measurement.instruments.base import REGISTRY, register_instrument
from vecpin.measurement.instruments.points import nest_request
from vecpin.measurement.instruments.tracker import TrackerInstrument


@register_instrument
class NestTracker(TrackerInstrument):
    name = "nest"
    row_kind = "nest"
    n_equations = 3
    description = "tracker reading of a reflector in a table nest (position in the workpiece frame unknown)"

    def __init__(self, noise, reading: TrackerInstrument | None = None):
        super().__init__(noise)
        self.reading = reading or REGISTRY[noise.instrument](noise)
        self.n_equations = self.reading.n_equations

    def read_with(self, reading: TrackerInstrument) -> None:
        """Read the nest rows as the tracker rows are read (cartesian, spherical, range)."""
        self.reading = reading
        self.n_equations = reading.n_equations

    def observe(self, x, y):
        return self.reading.observe(x, y)

    def request(self, campaign, rows, setup):
        return nest_request(campaign, rows, setup, 0)
