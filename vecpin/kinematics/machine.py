"""Machines: a URDF serial chain loaded into Pinocchio, nominal tool-tip kinematics.

A vecpin machine is a serial chain from the base link to a link named ``spindle``
whose origin lies on the gauge line; the tool points along −z of ``spindle``
(the seed's tool vector ``p_Tl`` with ``u = (0, 0, -1)``, Paper I eq. 9). The
*axes* are the actuated (prismatic or revolute) joints of that chain, in chain
order from the base.

Internally everything is SI (m, rad) in the machine base frame; the user-facing
unit of an axis is mm (linear) or degrees (rotary), see :class:`Axis`.

Kinematics are computed by Pinocchio, one call per pose (the Python loop costs
about 4 µs a pose); tool length enters in closed form so one forward pass serves
every tool.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Literal, NamedTuple

import numpy as np
import pinocchio as pin

from vecpin.errors import MachineError

SPINDLE_LINK = "spindle"
TOOL_DIRECTION = np.array([0.0, 0.0, -1.0])  # in the spindle frame

_JOINT_KINDS = {"prismatic": "linear", "revolute": "rotary"}


@dataclass(frozen=True)
class Axis:
    """One actuated joint of the chain.

    ``lower``/``upper`` are the URDF limits in SI (m or rad); ``direction`` is the
    joint axis in the joint frame. ``index`` is the position in chain order (the
    column order of every ``q`` array in vecpin), ``idx_q`` the index in Pinocchio's
    configuration vector.
    """

    name: str
    kind: Literal["linear", "rotary"]
    lower: float
    upper: float
    direction: tuple[float, float, float]
    index: int
    idx_q: int
    joint_id: int

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


class TipKinematics(NamedTuple):
    """Batched tool-tip kinematics in the machine base frame (SI).

    ``tip``: (N, 3) tool-tip positions [m]; ``rotation``: (N, 3, 3) spindle
    orientations; ``spindle``: (N, 3) gauge-line points [m]; ``jacobian``: (N, 3, n)
    d tip / d q [m/m or m/rad], or ``None`` when not requested.
    """

    tip: np.ndarray
    rotation: np.ndarray
    spindle: np.ndarray
    jacobian: np.ndarray | None


def bundled_machines() -> list[str]:
    """Names of the machines shipped in ``robots/``."""
    return sorted(p.name[:-5] for p in resources.files("vecpin.robots").iterdir() if p.name.endswith(".urdf"))


def _bundled_path(name: str) -> Path | None:
    res = resources.files("vecpin.robots").joinpath(name + ".urdf")
    return Path(str(res)) if res.is_file() else None


class Machine:
    """A machine tool loaded from URDF into Pinocchio.

    Build with :meth:`load` (bundled name or path), :meth:`from_urdf_file` or
    :meth:`from_urdf_string`.
    """

    def __init__(self, urdf_xml: str, source: str = "<string>", urdf_path: Path | None = None):
        self.urdf_xml = urdf_xml
        self.source = source
        self.urdf_path = urdf_path  # the file it came from, if any
        try:
            model = pin.buildModelFromXML(urdf_xml)
        except Exception as exc:  # pinocchio raises RuntimeError/ValueError with its own text
            raise MachineError(f"{source}: not a readable URDF ({exc})") from None
        self.model: pin.Model = model
        self.name: str = model.name
        if not model.existFrame(SPINDLE_LINK):
            raise MachineError(f"{source}: no link named '{SPINDLE_LINK}' (the gauge-line link the tool is mounted to)")
        self.spindle_frame_id: int = model.getFrameId(SPINDLE_LINK)
        self.axes: tuple[Axis, ...] = self._chain_axes()
        self._data = model.createData()
        self._idx_q = np.array([a.idx_q for a in self.axes])

    # ------------------------------------------------------------------ loading
    @classmethod
    def load(cls, name_or_path: str | Path) -> "Machine":
        """Load a bundled machine by name (see :func:`bundled_machines`) or a URDF file."""
        p = Path(name_or_path)
        if p.suffix.lower() == ".urdf" or p.exists():
            return cls.from_urdf_file(p)
        bundled = _bundled_path(str(name_or_path))
        if bundled is None:
            raise MachineError(
                f"'{name_or_path}' is neither a URDF file nor a bundled machine "
                f"(bundled: {', '.join(bundled_machines())})")
        m = cls.from_urdf_file(bundled)
        m.source = str(name_or_path)
        return m

    @classmethod
    def from_urdf_file(cls, path: str | Path) -> "Machine":
        path = Path(path)
        if not path.is_file():
            raise MachineError(f"{path}: no such URDF file")
        return cls(path.read_text(), source=str(path), urdf_path=path)

    @classmethod
    def from_urdf_string(cls, xml: str, source: str = "<string>") -> "Machine":
        return cls(xml, source=source)

    def _chain_axes(self) -> tuple[Axis, ...]:
        model = self.model
        # joints on the path base -> spindle
        chain = []
        j = model.frames[self.spindle_frame_id].parentJoint
        while j > 0:
            chain.append(j)
            j = model.parents[j]
        chain.reverse()
        off_chain = [model.names[j] for j in range(1, model.njoints) if j not in chain]
        if off_chain:
            raise MachineError(
                f"{self.source}: joints {off_chain} are not on the chain from the base to '{SPINDLE_LINK}'; "
                "a vecpin machine is a single serial chain (make other joints fixed)")
        axes = []
        for i, jid in enumerate(chain):
            jm = model.joints[jid]
            short = jm.shortname()
            if jm.nq != 1 or jm.nv != 1:
                hint = " (a URDF 'continuous' joint: declare it 'revolute' with wide limits)" if jm.nq == 2 else ""
                raise MachineError(f"{self.source}: joint '{model.names[jid]}' is {short}, not a 1-DoF axis{hint}")
            if "Prismatic" in short or short.startswith("JointModelP"):
                kind = "linear"
            elif "Revolute" in short or short.startswith("JointModelR"):
                kind = "rotary"
            else:
                raise MachineError(f"{self.source}: joint '{model.names[jid]}' has unsupported type {short}")
            lo = float(model.lowerPositionLimit[jm.idx_q])
            hi = float(model.upperPositionLimit[jm.idx_q])
            if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
                raise MachineError(f"{self.source}: joint '{model.names[jid]}' needs finite limits with lower < upper")
            direction = _joint_direction(jm)
            axes.append(Axis(model.names[jid], kind, lo, hi, direction, i, jm.idx_q, jid))
        if not axes:
            raise MachineError(f"{self.source}: no actuated joint between the base and '{SPINDLE_LINK}'")
        return tuple(axes)

    # ------------------------------------------------------------------ facts
    @property
    def n_axes(self) -> int:
        return len(self.axes)

    @property
    def axis_names(self) -> list[str]:
        return [a.name for a in self.axes]

    def axis(self, name: str) -> Axis:
        for a in self.axes:
            if a.name == name:
                return a
        raise MachineError(f"machine '{self.name}' has no axis '{name}' (axes: {', '.join(self.axis_names)})")

    @property
    def lower(self) -> np.ndarray:
        return np.array([a.lower for a in self.axes])

    @property
    def upper(self) -> np.ndarray:
        return np.array([a.upper for a in self.axes])

    def to_si(self, q_user: np.ndarray) -> np.ndarray:
        """(N, n) axis commands in mm/deg -> m/rad."""
        return np.asarray(q_user, float) * np.array([a.scale for a in self.axes])

    def to_user(self, q_si: np.ndarray) -> np.ndarray:
        """(N, n) axis commands in m/rad -> mm/deg."""
        return np.asarray(q_si, float) / np.array([a.scale for a in self.axes])

    def gauge_offset(self) -> float:
        """Distance [m] from the last axis' joint frame to the gauge line along the tool (T_offset)."""
        f = self.model.frames[self.spindle_frame_id]
        return float(f.placement.translation @ (f.placement.rotation @ TOOL_DIRECTION))

    # ------------------------------------------------------------------ kinematics
    def full_q(self, q: np.ndarray) -> np.ndarray:
        """Map chain-ordered axis values (n,) or (N, n) to Pinocchio's configuration order."""
        q = np.asarray(q, float)
        out = np.zeros(q.shape[:-1] + (self.model.nq,))
        out[..., self._idx_q] = q
        return out

    def kinematics(self, q: np.ndarray, tool: np.ndarray | float = 0.0, jacobian: bool = True) -> TipKinematics:
        """Nominal tool tip for N poses.

        q: (N, n) axis commands [m, rad] in chain order; tool: (N,) or scalar tool
        length [m] from the gauge line. Returns :class:`TipKinematics` in the base frame.
        The Jacobian is d tip / d q (linear velocity of the tool tip), from
        Pinocchio's spindle-frame Jacobian shifted to the tip.
        """
        q = np.atleast_2d(np.asarray(q, float))
        n_pose = q.shape[0]
        tool = np.broadcast_to(np.asarray(tool, float), (n_pose,))
        H, J6 = frame_poses(self.model, self._data, self.spindle_frame_id, self.full_q(q), jacobian)
        R = H[:, :3, :3]
        spindle = H[:, :3, 3]
        r = (R @ TOOL_DIRECTION) * tool[:, None]  # gauge line -> tip, base frame
        tip = spindle + r
        J = shift_to_point(J6, r)[:, :, self._idx_v()] if jacobian else None
        return TipKinematics(tip, R, spindle, J)

    def joint_frames(self, q: np.ndarray, axis: str) -> np.ndarray:
        """(N,4,4) placements in the base frame of an axis' joint frame after its motion."""
        q = np.atleast_2d(np.asarray(q, float))
        jid = self.axis(axis).joint_id
        qf = self.full_q(q)
        out = np.empty((len(q), 4, 4))
        for i in range(len(q)):
            pin.forwardKinematics(self.model, self._data, qf[i])
            out[i] = self._data.oMi[jid].homogeneous
        return out

    def _idx_v(self) -> np.ndarray:
        return np.array([self.model.joints[a.joint_id].idx_v for a in self.axes])

    def tool_tip(self, q: np.ndarray, tool: np.ndarray | float = 0.0) -> np.ndarray:
        """(N, 3) nominal tool-tip positions [m] in the base frame."""
        return self.kinematics(q, tool, jacobian=False).tip

    def describe(self) -> str:
        """Human summary: axes with kinds and limits (user units), frames."""
        lines = [f"machine {self.name}  ({self.source})",
                 f"  {self.n_axes} axes in chain order (base -> spindle):"]
        for a in self.axes:
            d = " ".join(f"{v:g}" for v in a.direction)
            lines.append(f"    {a.name:<8s} {a.kind:<7s} axis [{d}]  limits {a.lower_user:12.4f} .. {a.upper_user:12.4f} {a.unit}")
        lines.append(f"  gauge line: link '{SPINDLE_LINK}', {self.gauge_offset()*1e3:.3f} mm from the last axis frame; tool along -z")
        frames = [f.name for f in self.model.frames if f.type == pin.FrameType.BODY]
        lines.append(f"  links: {', '.join(frames)}")
        return "\n".join(lines)


def frame_poses(model: pin.Model, data: pin.Data, frame_id: int, configurations: np.ndarray,
                jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """Placements (N,4,4) of one frame and, if asked, its LOCAL_WORLD_ALIGNED Jacobians
    (N,6,nv) [linear; angular] for N Pinocchio configurations: one Pinocchio call per pose."""
    n = len(configurations)
    H = np.empty((n, 4, 4))
    if not jacobian:
        for i in range(n):
            pin.forwardKinematics(model, data, configurations[i])
            H[i] = pin.updateFramePlacement(model, data, frame_id).homogeneous
        return H, None
    J6 = np.empty((n, 6, model.nv))
    for i in range(n):
        J6[i] = pin.computeFrameJacobian(model, data, configurations[i], frame_id, pin.LOCAL_WORLD_ALIGNED)
        H[i] = data.oMf[frame_id].homogeneous
    return H, J6


def shift_to_point(J6: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Linear-velocity Jacobian (N,3,nv) of a point rigidly offset by r (N,3) from the
    frame origin: v_point = v + w x r."""
    return J6[:, :3, :] - np.cross(r[:, :, None], J6[:, 3:, :], axisa=1, axisb=1, axisc=1)


def _joint_direction(jm) -> tuple[float, float, float]:
    short = jm.shortname()
    for suffix, vec in (("X", (1.0, 0.0, 0.0)), ("Y", (0.0, 1.0, 0.0)), ("Z", (0.0, 0.0, 1.0))):
        if short.endswith(suffix) and ("Unaligned" not in short):
            return vec
    ax = np.asarray(jm.extract().axis if hasattr(jm, "extract") else jm.axis, float)
    return tuple(float(v) for v in ax)
