"""Boxes in axis space: exclusion zones (collision avoidance, Paper I Fig. 6 "CA") and
measurement zones (a machine calibrated in zones, Section 2.6).

A zone is written ``AXIS=LO:HI[,AXIS=LO:HI...]`` in mm and degrees, e.g.
``X=0:500,B=-111:-80``; axes not named are unbounded. A command lies in the zone when
every named axis is inside its interval (bounds included).
"""
from __future__ import annotations

import numpy as np

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine
from vecpin.units import MM_PER_M

Zone = dict[str, tuple[float, float]]  # axis name -> (low, high) in mm or deg


def parse_zone(text: str, option: str = "exclude") -> Zone:
    """'X=0:500,B=-111:-80' -> {'X': (0.0, 500.0), 'B': (-111.0, -80.0)} (mm/deg); errors name the
    parameter ``option``."""
    zone: Zone = {}
    for part in str(text).split(","):
        try:
            name, rng_ = part.split("=")
            a, b = rng_.split(":")
            name = name.strip()
            if not name:
                raise ValueError
            lo, hi = float(a), float(b)
            if not (np.isfinite(lo) and np.isfinite(hi)):
                raise ValueError
        except ValueError:
            raise InputError(f"`{option}` '{text}': an exclusion zone or measurement zone is written "
                             "AXIS=LO:HI[,AXIS=LO:HI...] in mm/deg, e.g. X=0:500,B=-111:-80") from None
        if not lo < hi:
            raise InputError(f"`{option}` '{text}': {name}={a.strip()}:{b.strip()} is empty; write the lower end first "
                             f"({name}={b.strip()}:{a.strip()})")
        if name in zone:
            raise InputError(f"`{option}` '{text}': axis {name} appears twice in one zone")
        zone[name] = (lo, hi)
    return zone


def check_zone_axes(machine: Machine, zone: Zone, option: str = "exclude") -> None:
    """Every axis a zone names is an axis of ``machine`` (the parameter ``option`` named when not)."""
    for name in zone:
        if name not in machine.axis_names:
            raise InputError(f"`{option}`: machine '{machine.name}' has no axis '{name}' (axes: "
                             f"{', '.join(machine.axis_names)})")
    check_zone_units(machine, zone, option)


def check_zone_units(machine: Machine, zone: Zone, option: str) -> None:
    """A zone on a linear axis narrower than 1/20 of its travel whose ends times 1000 lie in
    the travel and span a fifth of it or more was written in metres: refused, naming the
    parameter ``option``, the axis and the likely unit (mm/deg are the zone's units)."""
    for name, (a, b) in zone.items():
        if name not in machine.axis_names:
            continue
        ax = machine.axis(name)
        if ax.kind == "rotary":
            continue
        lo, hi = ax.lower_user, ax.upper_user
        span = hi - lo
        wide = (b - a) * MM_PER_M
        if (span > 0 and b - a <= span / 20 and wide >= span / 5
                and all(lo - span / 10 <= v * MM_PER_M <= hi + span / 10 for v in (a, b))):
            raise InputError(f"`{option}` {name}={a:g}:{b:g}: {b - a:g} mm is about 1/1000 of {name}'s travel "
                             f"{span:.1f} mm ({lo:g} to {hi:g} mm): metres? Zones are mm/deg "
                             f"({name}={a * MM_PER_M:g}:{b * MM_PER_M:g} if it was in metres)")


def zone_bounds(machine: Machine, zone: Zone) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) (n,) [m, rad] of a zone; unnamed axes get bounds beyond their limits."""
    lo = machine.lower.copy() - 1.0
    hi = machine.upper.copy() + 1.0
    for name, (a, b) in zone.items():
        ax = machine.axis(name)
        lo[ax.index], hi[ax.index] = sorted((float(ax.to_si(a)), float(ax.to_si(b))))
    return lo, hi


def inside(machine: Machine, q: np.ndarray, zones) -> np.ndarray:
    """(N,) True where a command q (N,n) [m, rad] lies in any of the zones."""
    q = np.atleast_2d(np.asarray(q, float))
    hit = np.zeros(len(q), bool)
    for z in zones:
        lo, hi = zone_bounds(machine, z)
        hit |= np.all((q >= lo) & (q <= hi), axis=1)
    return hit


def clip_to_zone(machine: Machine, zone: Zone | None) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) [m, rad] of the axis space a measurement zone leaves (the whole travel
    without one); a zone reaching beyond a limit is cut at the limit."""
    lo, hi = machine.lower.copy(), machine.upper.copy()
    if zone:
        zl, zh = zone_bounds(machine, zone)
        lo, hi = np.maximum(lo, zl), np.minimum(hi, zh)
        bad = np.flatnonzero(hi <= lo)
        if bad.size:
            a = machine.axes[bad[0]]
            raise InputError(f"`zone`: the interval of {a.name} lies outside its limits "
                             f"[{a.lower_user:g}, {a.upper_user:g}] {a.unit}")
    return lo, hi


def zone_text(zone: Zone) -> str:
    """``X=0:400,Y=-100:100`` (mm/deg) of a zone, as :func:`parse_zone` reads it."""
    return ",".join(f"{a}={lo:g}:{hi:g}" for a, (lo, hi) in zone.items())
