"""What a controller's table compensation can hold, as plain data for the table layer.

The compensation layer chooses and discretises tables; it must not know controller
file formats (those live in :mod:`vecpin.export`, one layer up). The export layer
describes each controller by a :class:`ControllerLimits` (its defaults, overridden
from a machine's controller profile) and the workflow passes it down to
:func:`vecpin.compensation.plan.plan_tables`.

Every check here runs before any heavy computation, so an impossible request
(``points=10000000``, more tables than the controller has) fails at once with the
limit, its source and what to change.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Callable

from vecpin.compensation.selection import Constraints
from vecpin.compensation.tables import table_name
from vecpin.errors import ControllerLimitError, InputError

# vecpin's own ceiling on points per table: beyond it the generic files (one CSV row per
# point and table) grow past ~100 MB and the discretisation past ~1 GB of memory.
VECPIN_MAX_POINTS = 100_000
DEFAULT_POINTS = 1024


@dataclass(frozen=True)
class ControllerLimits:
    """Table limits of one controller (counts per table, not bytes).

    ``max_cross_tables``: cross tables (input axis != output axis) the controller
    holds, ``None`` when no limit is known; ``cross_tables=False``: it holds pitch
    tables only (LinuxCNC). ``max_cross_points`` / ``max_pitch_points``: points per
    table (``None``: set by machine data, unknown here). ``resampled``: the writer
    puts every table on the controller's own grid (Fanuc), so ``points`` is only the
    internal resolution. ``one_cross_table_per_output``: at most one cross table per
    compensated axis (Beckhoff ``kw.crosscomp`` has one master per slave list).
    ``fixed``: names of limits that a profile may lower but never raise (828D).
    ``no_circular`` / ``forbid_output``: selection constraints of the controller.
    ``source``: where the numbers come from (printed with every limit error).
    ``products``: the controller multiplies a table by another (Siemens ``$AN_CEC_MULT_BY_TABLE``):
    each product term takes two of its cross tables. ``products_caveat``: why the controller's
    meaning of a product is not certain ('': it is; else product terms are written only when asked for).
    ``hold``: for a controller that resamples (``resampled``), ``hold(tables, machine)``
    gives a table set as the controller will hold it (the export layer writes its files
    and reads them back), so that the subset search can judge its best sets as written;
    None: the tables are held as planned. Not compared, not printed.
    """

    name: str
    max_cross_tables: int | None = None
    max_cross_points: int | None = None
    max_pitch_points: int | None = None
    cross_tables: bool = True
    one_cross_table_per_output: bool = False
    resampled: bool = False
    no_circular: bool = False
    forbid_output: tuple[str, ...] = ()
    fixed: tuple[str, ...] = ()
    source: str = ""
    products: bool = False
    products_caveat: str = ""
    hold: Callable | None = field(default=None, compare=False, repr=False)

    # ------------------------------------------------------------------ overrides
    def overridden(self, values: dict, where: str = "profile") -> "ControllerLimits":
        """A copy with limits from a controller profile (``{"max_cross_points": 500}``).
        Unknown names and raising a fixed limit are errors naming ``where``."""
        allowed = {"max_cross_tables", "max_cross_points", "max_pitch_points", "no_circular", "forbid_output"}
        changes = {}
        for key, value in values.items():
            if key not in allowed:
                raise InputError(f"{where}: limit '{key}' is not a table limit (known: {', '.join(sorted(allowed))})")
            if key in ("no_circular",):
                if not isinstance(value, bool):
                    raise InputError(f"{where}: limit '{key}' is true or false, not {value!r}")
            elif key == "forbid_output":
                if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                    raise InputError(f"{where}: limit 'forbid_output' is a list of axis names")
                value = tuple(value)
            elif value is not None and (not isinstance(value, int) or isinstance(value, bool) or value < 0):
                raise InputError(f"{where}: limit '{key}' is a whole number >= 0 or null, not {value!r}")
            old = getattr(self, key)
            if key in self.fixed and (value is None or (old is not None and value > old)):
                raise ControllerLimitError(f"{where}: {self.name} has a fixed {key} = {old} ({self.source}); "
                                           f"a profile may lower it, not raise it to {value}")
            changes[key] = value
        return dataclasses.replace(self, **changes)

    # ------------------------------------------------------------------ points
    @property
    def max_points(self) -> int:
        """Points per table that every table of a set must respect (vecpin's ceiling at most)."""
        if self.resampled:
            return VECPIN_MAX_POINTS
        caps = [c for c in (self.max_cross_points if self.cross_tables else None, self.max_pitch_points)
                if c is not None]
        return min(caps + [VECPIN_MAX_POINTS])

    @property
    def default_points(self) -> int:
        return min(DEFAULT_POINTS, self.max_points)

    def points(self, points: int | None, option: str = "points") -> int:
        """The points per table to use: ``points`` checked against the limits, or the default
        (``option``: the parameter the messages name)."""
        if points is None:
            return self.default_points
        if isinstance(points, bool) or not isinstance(points, int):
            raise InputError(f"`{option}` is a whole number of points per table, not {points!r}")
        if points < 2:
            raise InputError(f"`{option}` {points}: a table needs at least 2 points")
        if points > self.max_points:
            why = (f"vecpin's ceiling of {VECPIN_MAX_POINTS} points per table (larger files are of no use to a "
                   "controller)" if self.max_points == VECPIN_MAX_POINTS else
                   f"{self.name} holds at most {self.max_points} points per table ({self.source})")
            raise ControllerLimitError(f"`{option}` {points}: {why}; use `{option}` {self.max_points} or fewer")
        return points

    # ------------------------------------------------------------------ tables
    def cross_limit(self, axis_names: list[str]) -> int | None:
        """Cross tables this controller holds on a machine with these axes (None: no limit)."""
        if not self.cross_tables:
            return 0
        caps = [c for c in (self.max_cross_tables,
                            len(axis_names) if self.one_cross_table_per_output else None) if c is not None]
        return min(caps) if caps else None

    def needs_selection(self, axis_names: list[str]) -> bool:
        """True when the controller cannot take every cross table (a subset must be chosen)."""
        n_cross = len(axis_names) * (len(axis_names) - 1)
        k = self.cross_limit(axis_names)
        return bool(self.no_circular or self.forbid_output or self.one_cross_table_per_output
                    or (k is not None and k < n_cross))

    def constraints(self, max_tables: int | None = None, no_circular: bool | None = None, forbid_output=(),
                    axis_names: list[str] | None = None) -> Constraints:
        """Selection constraints: ``max_tables`` cross tables (default: the controller's
        limit), the controller's own rules plus the user's. ``axis_names`` is needed
        when the controller takes one cross table per output axis."""
        limit = self.cross_limit(list(axis_names or [])) if axis_names is not None else self.max_cross_tables
        if not self.cross_tables:
            raise ControllerLimitError(f"{self.name} takes pitch tables only ({self.source}): no cross tables to "
                                       "choose (leave out `max_tables`)")
        k = max_tables if max_tables is not None else limit
        if k is None:
            raise InputError(f"{self.name}: give the number of cross tables to choose (`max_tables`)")
        if k < 0:
            raise InputError(f"`max_tables` {k}: give a number >= 0")
        if limit is not None and k > limit:
            raise ControllerLimitError(f"{self.name} allows at most {limit} cross tables, not {k} ({self.source}): "
                                       f"use `max_tables` {limit} or fewer")
        pairs: tuple[tuple[str, str], ...] = ()
        if self.one_cross_table_per_output and axis_names is not None:
            output = {table_name(o, i): o for o in axis_names for i in axis_names if o != i}
            pairs = tuple((a, b) for a in output for b in output if a < b and output[a] == output[b])
        return Constraints(k, tuple(self.forbid_output) + tuple(forbid_output), (),
                           self.no_circular if no_circular is None else bool(no_circular or self.no_circular), pairs)

    def check_tables(self, tables) -> None:
        """Raise :class:`ControllerLimitError` when a :class:`~vecpin.compensation.tables.TableSet`
        does not fit (count of cross tables, points per table)."""
        cross = [t for t in tables.tables if not t.is_pitch]
        names = ", ".join(t.name for t in cross)
        if cross and not self.cross_tables:
            raise ControllerLimitError(f"{self.name} takes pitch tables only ({self.source}); this set has cross "
                                       f"tables {names}")
        if self.max_cross_tables is not None and len(cross) > self.max_cross_tables:
            raise ControllerLimitError(f"{self.name} allows {self.max_cross_tables} cross tables ({self.source}); this "
                                       f"set has {len(cross)} ({names}): choose a subset (`max_tables`)")
        if self.one_cross_table_per_output:
            outs = [t.output_axis for t in cross]
            dup = sorted({o for o in outs if outs.count(o) > 1})
            if dup:
                raise ControllerLimitError(f"{self.name} takes one cross table per compensated axis ({self.source}); "
                                           f"this set has several for {', '.join(dup)}")
        if self.resampled:
            return
        for t in tables.tables:
            cap = self.max_pitch_points if t.is_pitch else self.max_cross_points
            if cap is not None and len(t.values) > cap:
                kind = "pitch" if t.is_pitch else "cross"
                raise ControllerLimitError(f"{self.name}: {kind} table {t.name} has {len(t.values)} points, at most "
                                           f"{cap} ({self.source}): use `points` {cap}")


NO_LIMITS = ControllerLimits("generic", source="vecpin's generic files: no controller limit", products=True)
