"""The parts of a machine description: axes and their units, mimic joints, the
kinematics' result types, the bundled machines, tool axes, and how axis values fill a
Pinocchio configuration. :mod:`vecpin.kinematics.machine` builds machines from them."""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Literal, NamedTuple, Sequence

import numpy as np
import pinocchio as pin

from vecpin.errors import InputError, MachineError
from vecpin.kinematics.bundled import _bundled_path, bundled_machines  # noqa: F401  (named here too)

SPINDLE_LINK = "spindle"
WORKPIECE_LINK = "workpiece"
TOOL_DIRECTION = np.array([0.0, 0.0, -1.0])  # default tool axis in the tool link frame
#: tool links named like ROS-Industrial tool flanges: the tool points along +z of tool0, +x of flange
ROS_FLANGE_LINKS = ("tool0", "flange")
#: campaign CSV columns an axis must not be named like (case-sensitive: "X" is fine)
RESERVED_NAMES = ("x", "y", "z", "tool", "time", "temperature", "instrument", "station", "r", "pivot",
                  "target", "point")
#: load options of bundled machines whose URDF (kept as published) has no 'spindle'
BUNDLED_OPTIONS = {"ur5": {"tool_link": "tool0"}, "ur10": {"tool_link": "tool0"}}

Frame = Literal["base", "workpiece"]


@dataclass(frozen=True)
class Axis:
    """One actuated joint (an independent axis) of the machine.

    ``lower``/``upper`` are the URDF limits in SI (m or rad); ``direction`` is the
    joint axis in the joint frame. ``index`` is the position in vecpin's axis order
    (the column order of every ``q`` array), ``idx_q`` the index in Pinocchio's
    configuration vector, ``joint_id`` Pinocchio's joint id. ``side`` is "head" (on
    the path to a tool link), "table" (on the path to the workpiece only) or "both".
    """

    name: str
    kind: Literal["linear", "rotary"]
    lower: float
    upper: float
    direction: tuple[float, float, float]
    index: int
    idx_q: int
    joint_id: int
    side: Literal["head", "table", "both"] = "head"

    @property
    def unit(self) -> str:
        """The user unit of this axis: ``"mm"`` or ``"deg"``."""
        return "mm" if self.kind == "linear" else "deg"

    @property
    def scale(self) -> float:
        """SI value per user unit (0.001 m/mm or pi/180 rad/deg)."""
        return 1e-3 if self.kind == "linear" else math.pi / 180.0

    def to_si(self, value_user):
        return np.asarray(value_user, dtype=float) * self.scale

    def to_user(self, value_si):
        return np.asarray(value_si, dtype=float) / self.scale

    @property
    def lower_user(self) -> float:
        return float(self.lower / self.scale)

    @property
    def upper_user(self) -> float:
        return float(self.upper / self.scale)

    @property
    def travel(self) -> float:
        """Travel in SI (m or rad)."""
        return self.upper - self.lower

    @property
    def multiturn(self) -> bool:
        """True for a rotary axis that travels more than one turn (2 pi rad, with 1e-9 rad
        to spare so a travel of exactly one turn written in degrees is not one): the axes
        whose errors may repeat every turn (Fourier series, modulo tables)."""
        return self.kind == "rotary" and self.travel > 2 * math.pi + 1e-9


@dataclass(frozen=True)
class MimicJoint:
    """A joint that follows an axis: value = multiplier * q[axis] + offset [m or rad]."""

    name: str
    axis: str
    multiplier: float
    offset: float


class TipKinematics(NamedTuple):
    """Batched tool-point kinematics in one frame (SI).

    ``tip``: (N, 3) tool-tip (target) positions [m]; ``rotation``: (N, 3, 3) tool-link
    orientations; ``spindle``: (N, 3) tool-link origins (gauge-line points) [m];
    ``jacobian``: (N, 3, n) d tip / d q [m/m or m/rad], or ``None`` when not requested;
    ``tool_dir``: (N, 3) unit tool direction (d tip / d tool length); ``frame``: the frame
    all of these are expressed in ("base" or "workpiece").
    """

    tip: np.ndarray
    rotation: np.ndarray
    spindle: np.ndarray
    jacobian: np.ndarray | None
    tool_dir: np.ndarray
    frame: str


KINEMATICS_ROWS = 50_000   # rows of one piece of Machine.kinematics (Pinocchio's Jacobians: 6 x columns floats a row)


def kinematics_in_pieces(kinematics, q, tool, jacobian, frame, point, offset) -> TipKinematics:
    """``kinematics`` (:meth:`Machine.kinematics`) of :data:`KINEMATICS_ROWS` rows at a
    time, joined: the memory of one piece's Jacobians, not of every row's (a million rows
    would hold 6 x columns x 8 bytes each at once). q (N, n), tool (N,), point int or (N,),
    offset None, (3,) or (N, 3) as there."""
    N, K = len(q), KINEMATICS_ROWS
    if offset is not None:
        offset = np.broadcast_to(np.asarray(offset, float), (N, 3))
    order = np.lexsort(q.T[::-1])   # rows of one pose (every tool's) side by side: its Jacobians computed once
    back = np.empty(N, int)
    back[order] = np.arange(N)
    parts = [kinematics(q[o], tool[o], jacobian, frame=frame, point=point if np.ndim(point) == 0 else point[o],
                        offset=None if offset is None else offset[o]) for o in (order[k:k + K] for k in range(0, N, K))]
    return TipKinematics(*(None if parts[0][j] is None else np.concatenate([p[j] for p in parts])[back]
                           for j in range(5)), parts[0].frame)


class WorkpiecePoints(NamedTuple):
    """Points fixed in the workpiece frame, expressed in the base frame (SI).

    ``xyz`` (N,3) [m]; ``J_q`` (N,3,n) d xyz / d q; ``J_p`` (N,3,3) d xyz / d p_wp (the
    workpiece orientation); Jacobians ``None`` when not requested.
    """

    xyz: np.ndarray
    J_q: np.ndarray | None
    J_p: np.ndarray | None


def parse_tool_axis(text: str) -> np.ndarray:
    """'+z', '-z', 'x', '-y', ... -> unit vector in the tool link frame."""
    m = re.fullmatch(r"\s*([+-]?)\s*([xyzXYZ])\s*", str(text))
    if not m:
        raise InputError(f"`tool_axis` '{text}': write one of +x, -x, +y, -y, +z, -z "
                         "(the tool link's axis the tool points along)")
    v = np.zeros(3)
    v["xyz".index(m.group(2).lower())] = -1.0 if m.group(1) == "-" else 1.0
    return v


def _axis_name(v: np.ndarray) -> str:
    k = int(np.argmax(np.abs(v)))
    return ("-" if v[k] < 0 else "+") + "xyz"[k]


def _check_axis_name(name: str, source: str) -> None:
    if name in RESERVED_NAMES:
        raise MachineError(f"{source}: axis joint '{name}' is named like the campaign column '{name}' "
                           f"(reserved: {', '.join(RESERVED_NAMES)}); rename the joint in the URDF "
                           "(names are case-sensitive: 'X' is fine)")
    if re.search(r"[\s,\"']", name) or not name.isprintable():
        raise MachineError(f"{source}: axis joint '{name}' has a space, comma or quote in its name, which "
                           "breaks campaign CSV columns; rename the joint in the URDF")
    if not PLAIN_NAME.fullmatch(name):
        raise MachineError(f"{source}: axis joint {name!r} is not a plain name: an axis name becomes part of file "
                           "names and CSV cells, so it takes letters, digits, '_' and '-' only, starting with a "
                           "letter, digit or '_' (no path, no leading = + - @); rename the joint in the URDF")


def check_cell_names(names, what: str, source: str) -> tuple[str, ...]:
    """``names`` (tool links, ...) that vecpin copies into CSV cells: no comma, quote or
    control character, no leading = + - @ (a spreadsheet would evaluate the cell)."""
    for n in names:
        if not n or n[0] in "=+-@" or re.search(r"[,\"']", n) or not n.isprintable():
            raise MachineError(f"{source}: {what} {n!r} would be copied into CSV cells: a name without commas or "
                               "quotes, not starting with = + - @ (a spreadsheet would evaluate it); rename it")
    return tuple(names)


# A name that becomes part of a file name or a CSV cell (axes, NC axis names): no path
# separator, no dot, no leading character a spreadsheet evaluates (= + - @).
PLAIN_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_-]{0,63}")


def configuration_map(model: pin.Model, axes: Sequence[Axis], mimic_joints: Sequence[MimicJoint],
                      mimic_in_model: bool) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """How vecpin's axis values drive a Pinocchio model built from the machine's URDF.

    Returns ``fill = (idx_q, source, multiplier, offset)``: configuration entry
    ``idx_q[r]`` is ``multiplier[r] * q[source[r]] + offset[r]``, and ``gain``
    (nv_extended, n): Jacobian column c moves with axis k at rate ``gain[c, k]``.
    An axis joint has gain 1 on its column. A ``<mimic>`` joint that Pinocchio models
    as a mimic joint (``mimic_in_model``) reads its source's entry itself and has its own
    column already scaled by the multiplier (gain 1); one that is an ordinary joint of
    the model gets its value from the map and gain ``multiplier``.
    """
    index = {a.name: a.index for a in axes}
    rows: list[tuple[int, int, float, float]] = []
    gain = np.zeros((model.nvExtended, len(axes)))
    for jid in range(1, model.njoints):
        name = model.names[jid]
        jm = model.joints[jid]
        if name in index:
            rows.append((jm.idx_q, index[name], 1.0, 0.0))
            gain[jm.idx_vExtended, index[name]] = 1.0
    for mj in mimic_joints:
        jm = model.joints[model.getJointId(mj.name)]
        k = index[mj.axis]
        if mimic_in_model:
            gain[jm.idx_vExtended, k] = 1.0
        else:
            rows.append((jm.idx_q, k, mj.multiplier, mj.offset))
            gain[jm.idx_vExtended, k] = mj.multiplier
    a = np.array(rows, float).reshape(-1, 4)
    return (a[:, 0].astype(int), a[:, 1].astype(int), a[:, 2], a[:, 3]), gain


def fill_configurations(template: np.ndarray, fill: tuple[np.ndarray, ...], q: np.ndarray) -> np.ndarray:
    """Configurations (..., nq) from axis values q (..., n): ``template`` (Pinocchio's
    neutral configuration) with the entries of ``fill`` (see :func:`configuration_map`) set."""
    idx, src, mult, off = fill
    out = np.empty(q.shape[:-1] + template.shape)
    out[...] = template
    out[..., idx] = q[..., src] * mult + off
    return out


def is_arm(machine) -> bool:
    """True for a serial arm: a machine (anything with ``axes``) without linear axes, whose
    tool no axis lifts along (plans approach along the tool axis in joint space; tables,
    advice and names read as joints: J1, J2, ...)."""
    return not any(a.kind == "linear" for a in machine.axes)
