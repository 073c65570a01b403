"""Layout variants of the bundled machines: the same URDF with chosen axis limits.

The bundled rotary axes travel at most about +-400 deg; machines whose rotary axes
turn several times (cable-free heads, multi-turn tables) are made by editing the
``<limit>`` of joints in the URDF text. :data:`LAYOUTS` names one variant per
bundled kinematic layout with a rotary travel beyond +-360 deg, plus the originals.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET

from vecpin.errors import InputError
from vecpin.kinematics.machine import Machine

# name: (bundled machine, {axis: (lower, upper) in mm or deg})
LAYOUTS: dict[str, tuple[str, dict[str, tuple[float, float]]]] = {
    "portal_xyzcb": ("flow_xyzcb", {}),                          # C -272..272 deg (more than a turn)
    "portal_xyzcb_c720": ("flow_xyzcb", {"C": (-720.0, 720.0)}),  # C four turns
    "head_xyzab": ("cincinnati_20v", {}),                        # small AB head, +-25 deg
    "head_xyzab_b540": ("cincinnati_20v", {"B": (-540.0, 540.0)}),
    "head_xyzab_snk_a450": ("snk_120v", {"A": (-450.0, 450.0)}),
    "gantry_xyzca": ("ingersoll_xyzca", {}),                     # C -400..400 deg
    "gantry_xyzca_c720": ("ingersoll_xyzca", {"C": (-720.0, 720.0)}),
}


def machine_with_limits(name_or_path: str, limits: dict[str, tuple[float, float]], name: str | None = None) -> Machine:
    """A :class:`Machine` from a bundled name or URDF path with the limits of some axes
    replaced: ``limits`` maps an axis (joint) name to (lower, upper) in mm (linear) or
    degrees (rotary). The robot is renamed ``name`` (default: the original name plus
    the changed limits, e.g. ``flow_xyzcb_C-720_720``)."""
    base = Machine.load(name_or_path)
    if not limits:
        return base
    root = ET.fromstring(base.urdf_xml)
    joints = {j.get("name"): j for j in root.findall("joint")}
    tag = []
    for axis, (lo, hi) in limits.items():
        j = joints.get(axis)
        if j is None or j.get("type") not in ("prismatic", "revolute"):
            raise InputError(f"{base.source}: no axis '{axis}' to change the limits of (axes: {', '.join(base.axis_names)})")
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            raise InputError(f"limits of {axis}: need lower < upper, got {lo}..{hi}")
        scale = 1e-3 if j.get("type") == "prismatic" else math.pi / 180.0
        lim = j.find("limit")
        lim.set("lower", repr(lo * scale))
        lim.set("upper", repr(hi * scale))
        tag.append(f"{axis}{lo:g}_{hi:g}")
    root.set("name", name or f"{base.name}_{'_'.join(tag)}")
    xml = '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode")
    return Machine.from_urdf_string(xml, source=f"{base.source} with {', '.join(tag)}")


def layout(name: str) -> Machine:
    """A machine of :data:`LAYOUTS` by name."""
    if name not in LAYOUTS:
        raise InputError(f"unknown layout '{name}' (choose {', '.join(LAYOUTS)})")
    src, limits = LAYOUTS[name]
    return machine_with_limits(src, limits, name=name if limits else None)
