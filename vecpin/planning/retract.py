"""The retract axis of a measurement program: the linear axis that lifts the tool off the
work, and its safe machine position (mm, machine coordinates)."""
from __future__ import annotations

import math

import numpy as np

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine


def retract_axis(machine: Machine, name: str | None = None) -> tuple[int, int]:
    """(index, sign) of the axis that lifts the tool off the work: ``name``, or the linear
    axis whose motion is most nearly along the tool at zero rotary angles (mid-travel
    linear axes; relative to the workpiece on a machine with table axes); ``sign`` +1
    when its + direction moves the tool back from the work, else -1."""
    lin = [a for a in machine.axes if a.kind == "linear"]
    if name is not None and name not in [a.name for a in lin]:
        raise InputError(f"`retract` {name}: not a linear axis of {machine.name} "
                         f"({', '.join(a.name for a in lin) or 'it has none'})")
    if not lin:
        raise InputError(f"machine {machine.name} has no linear axis to retract the tool with")
    q = np.array([(a.lower + a.upper) / 2 if a.kind == "linear" or not a.lower <= 0 <= a.upper else 0.0
                  for a in machine.axes])
    k = machine.kinematics(q[None], 0.0)
    J, u = k.jacobian[0], k.tool_dir[0]
    along = {a.index: -float(J[:, a.index] @ u) / max(float(np.linalg.norm(J[:, a.index])), 1e-12) for a in lin}
    if name is not None:
        i = machine.axis(name).index
    else:
        i = max(along, key=lambda j: (round(abs(along[j]), 6), machine.axes[j].upper - machine.axes[j].lower))
        if abs(along[i]) < 0.7:
            raise InputError(f"machine {machine.name}: no linear axis runs along the tool at zero rotary angles; "
                             "give `retract`")
    if abs(along[i]) < 1e-6:
        raise InputError(f"`retract` {name}: it does not move the tool along its axis")
    return i, 1 if along[i] > 0 else -1


def safe_position(machine: Machine, axis: int, sign: int, safe_z_mm: float | None) -> float:
    """The retract axis' safe machine position [mm]: ``safe_z_mm`` (inside the travel), or
    the end of the travel away from the work."""
    a = machine.axes[axis]
    lo, hi = a.lower_user, a.upper_user
    if safe_z_mm is None:
        return round(hi if sign > 0 else lo, 3)
    if not (math.isfinite(safe_z_mm) and lo - 1e-9 <= safe_z_mm <= hi + 1e-9):
        raise InputError(f"`safe_z_mm` {safe_z_mm:g}: not a position inside the travel of {a.name} ({lo:g} to {hi:g} mm, "
                         "machine coordinates)")
    return round(float(safe_z_mm), 3)


__all__ = ["retract_axis", "safe_position"]
