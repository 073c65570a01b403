"""Random kinematic layouts of machine tools and arms, written as URDF files (SI: m, rad).

Conventions copied from the bundled robots (as a user reads them): a machine tool's tool link is
``spindle`` (the tool along its -z, origin on the gauge line), the table side ends in a
``workpiece`` link; an arm's flange is ``tool0`` (the tool along its +z), base ``base_link``.
A twin-drive gantry axis is ONE joint, as in the bundled ``master_mill`` (two motors are a
controller matter); its yaw is an error the campaign may carry (``gantry_skew``).

Kinds: ``head`` (X Y Z + two head rotaries), ``table`` (X Y Z on the tool side, trunnion A/C or
B/C on the table), ``head_table`` (one rotary each), ``gantry`` (twin-drive Y, X, Z, two head
rotaries), ``arm`` (6R, UR-like Denavit-Hartenberg frames with random lengths).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

KINDS = ("head", "table", "head_table", "gantry", "arm")
UNIT = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}
ROTARY_ABOUT = {"A": "x", "B": "y", "C": "z"}


@dataclass
class Joint:
    """One URDF joint: origin (m, rad: xyz and roll-pitch-yaw) in the parent link, axis in the child."""

    name: str
    kind: str                     # "prismatic", "revolute" or "fixed"
    parent: str
    child: str
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    lower: float = 0.0            # m or rad
    upper: float = 0.0

    @property
    def actuated(self) -> bool:
        return self.kind != "fixed"


@dataclass
class Layout:
    """A machine: its joints, the chain to the tool link and (table machines) to ``workpiece``."""

    name: str
    kind: str
    joints: list[Joint]
    tool_chain: list[str]                    # joint names base -> tool link
    table_chain: list[str] = field(default_factory=list)   # joint names base -> workpiece
    tool_link: str = "spindle"
    tool_axis: tuple[float, float, float] = (0.0, 0.0, -1.0)
    twin_axis: str | None = None             # the twin-drive gantry axis

    def joint(self, name: str) -> Joint:
        return next(j for j in self.joints if j.name == name)

    @property
    def axes(self) -> list[Joint]:
        """Actuated joints in URDF order (the campaign's command columns)."""
        return [j for j in self.joints if j.actuated]

    def linear(self) -> list[Joint]:
        return [j for j in self.axes if j.kind == "prismatic"]

    def rotary(self) -> list[Joint]:
        return [j for j in self.axes if j.kind == "revolute"]


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def _linear(rng, name: str, parent: str, child: str, travel: tuple[float, float],
            xyz=(0.0, 0.0, 0.0)) -> Joint:
    span = _u(rng, *travel)
    lower = round(-span * _u(rng, 0.0, 1.0), 4)
    return Joint(name, "prismatic", parent, child, xyz, (0.0, 0.0, 0.0), UNIT[name.lower()],
                 lower, round(lower + span, 4))


def _rotary(name: str, parent: str, child: str, lo_deg: float, hi_deg: float, xyz=(0.0, 0.0, 0.0)) -> Joint:
    return Joint(name, "revolute", parent, child, xyz, (0.0, 0.0, 0.0), UNIT[ROTARY_ABOUT[name]],
                 float(np.radians(round(lo_deg))), float(np.radians(round(hi_deg))))


def _offset(rng, lateral: float, down: tuple[float, float]) -> tuple[float, float, float]:
    return (round(_u(rng, -lateral, lateral), 4), round(_u(rng, -lateral, lateral), 4), round(-_u(rng, *down), 4))


def _head_rotaries(rng, parent: str, second: str) -> list[Joint]:
    """C about z, then A (about x) or B (about y), then the gauge line to ``spindle``."""
    c_span = _u(rng, 200.0, 360.0)
    tilt = _u(rng, 90.0, 120.0)
    return [_rotary("C", parent, "c_head", -c_span, c_span),
            _rotary(second, "c_head", "tilt_head", -tilt, tilt, _offset(rng, 0.003, (0.0, 0.15))),
            Joint("gauge_line", "fixed", "tilt_head", "spindle", _offset(rng, 0.002, (0.12, 0.45)))]


def _xyz(rng, travels, z_height: float = 0.0) -> list[Joint]:
    return [_linear(rng, "X", "base", "x_slide", travels[0]),
            _linear(rng, "Y", "x_slide", "y_slide", travels[1]),
            _linear(rng, "Z", "y_slide", "z_slide", travels[2], (0.0, 0.0, round(z_height, 4)))]


def _head(rng, name: str) -> Layout:
    joints = _xyz(rng, ((0.6, 3.0), (0.5, 2.0), (0.4, 1.2)), _u(rng, 0.3, 0.9))
    joints += _head_rotaries(rng, "z_slide", str(rng.choice(["A", "B"])))
    return Layout(name, "head", joints, [j.name for j in joints])


def _gantry(rng, name: str) -> Layout:
    joints = [_linear(rng, "Y", "base", "gantry_beam", (2.0, 8.0)),
              _linear(rng, "X", "gantry_beam", "x_carriage", (1.5, 4.0), (0.0, 0.0, round(_u(rng, 1.0, 2.0), 4))),
              _linear(rng, "Z", "x_carriage", "z_ram", (0.5, 1.5))]
    joints += _head_rotaries(rng, "z_ram", str(rng.choice(["A", "B"])))
    return Layout(name, "gantry", joints, [j.name for j in joints], twin_axis="Y")


def _tool_side_xyz(rng) -> list[Joint]:
    joints = _xyz(rng, ((0.4, 1.2), (0.3, 0.9), (0.3, 0.7)), _u(rng, 0.5, 0.9))
    return joints


def _table(rng, name: str) -> Layout:
    tool = _tool_side_xyz(rng)
    tool.append(Joint("gauge_line", "fixed", "z_slide", "spindle"))
    tilt = str(rng.choice(["A", "B"]))
    h = _u(rng, 0.04, 0.15)
    c_turns = float(rng.choice([360.0, 720.0]))
    table = [_rotary(tilt, "base", "tilt_table", -_u(rng, 20.0, 40.0), _u(rng, 90.0, 115.0), (0.0, 0.0, round(h, 4))),
             _rotary("C", "tilt_table", "c_table", -c_turns, c_turns, (round(_u(rng, -0.003, 0.003), 4), 0.0,
                                                                        round(-h + _u(rng, -0.01, 0.01), 4))),
             Joint("table_face", "fixed", "c_table", "workpiece")]
    return Layout(name, "table", tool + table, [j.name for j in tool], [j.name for j in table])


def _head_table(rng, name: str) -> Layout:
    tool = _tool_side_xyz(rng)
    second = str(rng.choice(["A", "B"]))
    tilt = _u(rng, 90.0, 115.0)
    tool += [_rotary(second, "z_slide", "tilt_head", -tilt, tilt),
             Joint("gauge_line", "fixed", "tilt_head", "spindle", _offset(rng, 0.002, (0.15, 0.4)))]
    c_turns = float(rng.choice([360.0, 720.0]))
    centre = (round(_u(rng, -0.3, 0.3), 4), round(_u(rng, -0.3, 0.3), 4), 0.0)
    table = [_rotary("C", "base", "c_table", -c_turns, c_turns, centre),
             Joint("table_face", "fixed", "c_table", "workpiece")]
    return Layout(name, "head_table", tool + table, [j.name for j in tool], [j.name for j in table])


def _arm(rng, name: str) -> Layout:
    """6R arm in UR-like DH frames: joint i+1's origin is (a_i, 0, d_i) with roll alpha_i."""
    d1, a2, a3 = _u(rng, 0.08, 0.3), -_u(rng, 0.3, 0.8), -_u(rng, 0.3, 0.7)
    d4, d5, d6 = _u(rng, 0.08, 0.2), _u(rng, 0.07, 0.13), _u(rng, 0.05, 0.12)
    rows = [(0.0, 0.0, 0.0), (0.0, d1, np.pi / 2), (a2, 0.0, 0.0), (a3, 0.0, 0.0),
            (0.0, d4, np.pi / 2), (0.0, d5, -np.pi / 2)]
    joints, parent = [], "base_link"
    for i, (a, d, alpha) in enumerate(rows, start=1):
        span = _u(rng, 60.0, 150.0)
        centre = _u(rng, -30.0, 30.0)
        j = Joint(f"joint_{i}", "revolute", parent, f"link_{i}", (round(a, 5), 0.0, round(d, 5)),
                  (float(alpha), 0.0, 0.0), (0.0, 0.0, 1.0),
                  float(np.radians(round(centre - span))), float(np.radians(round(centre + span))))
        joints.append(j)
        parent = f"link_{i}"
    joints.append(Joint("flange", "fixed", parent, "tool0", (0.0, 0.0, round(d6, 5))))
    return Layout(name, "arm", joints, [j.name for j in joints], tool_link="tool0", tool_axis=(0.0, 0.0, 1.0))


BUILDERS = {"head": _head, "table": _table, "head_table": _head_table, "gantry": _gantry, "arm": _arm}


def draw_layout(rng: np.random.Generator, kind: str | None = None, name: str = "unseen") -> Layout:
    """A random layout of the given kind (or a kind drawn uniformly)."""
    kind = kind or str(rng.choice(KINDS))
    return BUILDERS[kind](rng, name)


def _f(v: float) -> str:
    return f"{v:.17g}"


def to_urdf(layout: Layout) -> str:
    """The layout as URDF text (SI), one link per joint child; no visuals."""
    base = "base_link" if layout.kind == "arm" else "base"
    tool_dir = "+z" if layout.tool_axis[2] > 0 else "-z"
    lines = ['<?xml version="1.0"?>',
             f"<!-- Layout: {layout.kind}, drawn at random by benchmarks/generator (issue 40). Units: SI (m, rad).",
             f"     The tool points along {tool_dir} of link '{layout.tool_link}'. -->",
             f'<robot name="{layout.name}">', f'  <link name="{base}"/>']
    for j in layout.joints:
        lines.append(f'  <joint name="{j.name}" type="{j.kind}">')
        lines.append(f'    <parent link="{j.parent}"/><child link="{j.child}"/>')
        lines.append(f'    <origin xyz="{" ".join(_f(v) for v in j.xyz)}" rpy="{" ".join(_f(v) for v in j.rpy)}"/>')
        if j.actuated:
            lines.append(f'    <axis xyz="{" ".join(_f(v) for v in j.axis)}"/>')
            lines.append(f'    <limit lower="{_f(j.lower)}" upper="{_f(j.upper)}" effort="1000" velocity="1"/>')
        lines.append("  </joint>")
        lines.append(f'  <link name="{j.child}"/>')
    lines.append("</robot>")
    return "\n".join(lines) + "\n"
