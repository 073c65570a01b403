"""Machines: a URDF kinematic tree, nominal tool-tip kinematics on one or two branches.

A vecpin machine is a URDF tree rooted at its base link (the machine frame):

* the **head branch(es)** from the base to the tool link(s): ``spindle`` by default,
  whose origin lies on the gauge line, the tool pointing along its -z (the seed's tool
  vector ``p_Tl`` with ``u = (0, 0, -1)``, Paper I eq. 9). A machine may have several
  tool points driven by one command set (Spar Mill 23: ``spindle`` and ``spindle_2``);
  any link can be named the tool link, with its tool axis (robots, the ROS-Industrial
  convention: ``tool0`` +z, ``flange`` +x out of the flange);
* optionally a **table branch** from the base to a link named ``workpiece`` (the table
  frame of a trunnion or rotary table). The tool tip that matters for machining is the
  tip *relative to the workpiece*, ``p_rel = T_bw(q)^-1 p_tip(q)``; a tracker standing
  on the floor sees the tip in the base frame.

The **axes** are the independent actuated joints (prismatic, revolute) on these
branches, in this order (the column order of every ``q`` array in vecpin): walking from
the base outward along the path to each tool link in turn (tool points in their order),
then along the path to ``workpiece``; a joint met again is not repeated. On a trunnion
XYZAC this gives X Y Z A C: head axes first, then table axes. ``<mimic>`` joints are not
axes: they follow their source axis (``value = multiplier * q_source + offset``).
Joints off these branches (gripper fingers, cable carriers) are fixed at zero, with a
note in :attr:`Machine.notes`.

Frames (argument ``frame``): ``"base"`` (what a floor tracker sees) or ``"workpiece"``
(what compensation tables correct). The default is ``"workpiece"`` on a machine with a
workpiece link and ``"base"`` otherwise; on a machine without a workpiece both are the
base frame.

Loading (the tree, tool links, workpiece, axes, notes) is :mod:`vecpin.kinematics.loading`'s.
Kinematics are Pinocchio's: the checked URDF text is loaded into a Pinocchio model
(:attr:`Machine.model`, ``<mimic>`` joints honoured), and one Pinocchio call per pose
gives the placements and Jacobians of the tool links and the workpiece
(:mod:`vecpin.kinematics.batch`); tool lengths, target offsets, the change to the
workpiece frame and the Jacobian algebra are numpy over all poses at once. Internally
everything is SI (m, rad); the user-facing unit of an axis is mm (linear) or degrees
(rotary), see :class:`~vecpin.kinematics.axes.Axis`.
"""
from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Sequence

import numpy as np
import pinocchio as pin

from vecpin.errors import InputError, MachineError
from vecpin.kinematics.axes import (SPINDLE_LINK, Axis, Frame, MimicJoint, TipKinematics, WorkpiecePoints,
                                    configuration_map, fill_configurations)
from vecpin.kinematics.axes import KINEMATICS_ROWS, kinematics_in_pieces
from vecpin.kinematics.batch import FrameProbes, apply, apply_transposed, point_velocities
from vecpin.kinematics.loading import bundled_file, machine_parts, urdf_file_text
from vecpin.kinematics.urdf import UrdfTree
from vecpin.units import to_mm

TIP_MEMO = 3   # nominal tool tips of this many large campaigns kept (Machine.tool_tip)


class Machine:
    """A machine loaded from URDF: axes, tool points, optional workpiece branch.

    Build with :meth:`load` (bundled name or path), :meth:`from_urdf_file` or
    :meth:`from_urdf_string`. ``tool_link``: the tool link name, a comma-separated list
    or a sequence of names (several tool points driven by the same commands); default
    ``spindle`` plus ``spindle_2``, ``spindle_3``, ... when present. ``tool_axis``:
    "+x", "-x", "+y", "-y", "+z" or "-z" of the tool link; default -z, or the ROS-Industrial
    convention's direction out of the flange: +z of ``tool0``, +x of ``flange``."""

    def __init__(self, urdf_xml: str, source: str = "<string>", urdf_path: Path | None = None, *,
                 tool_link: str | Sequence[str] | None = None, tool_axis: str | None = None):
        self.urdf_xml = urdf_xml
        self.source = source
        self.urdf_path = urdf_path  # the file it came from, if any
        parts = machine_parts(urdf_xml, source, tool_link, tool_axis)
        self.tree: UrdfTree = parts.tree
        self.notes: list[str] = parts.notes
        self.name: str = parts.tree.name
        self.tool_links: tuple[str, ...] = parts.tool_links
        self.tool_axis: np.ndarray = parts.tool_axis
        self.tool_axis_name: str = parts.tool_axis_name
        self.workpiece_link: str | None = parts.workpiece_link
        self.model: pin.Model = parts.model
        self._mimic_in_model = parts.mimic_in_model
        self.axes: tuple[Axis, ...] = parts.axes
        self.mimic_joints: tuple[MimicJoint, ...] = parts.mimic_joints
        self._data = self.model.createData()
        self.spindle_frame_id: int = self.model.getFrameId(self.tool_links[0], pin.FrameType.BODY)
        self._build_kinematics()

    # ------------------------------------------------------------------ loading (vecpin.kinematics.loading)
    @classmethod
    def load(cls, name_or_path: str | Path, *, tool_link: str | Sequence[str] | None = None,
             tool_axis: str | None = None) -> "Machine":
        """Load a bundled machine by name (see :func:`~vecpin.kinematics.axes.bundled_machines`) or a URDF file."""
        if not isinstance(name_or_path, (str, Path)) or not str(name_or_path):
            raise MachineError(f"{name_or_path!r}: give a bundled machine's name or the path of a URDF file")
        p = Path(name_or_path)
        if p.suffix.lower() in (".urdf", ".xacro", ".xml") or p.exists():
            return cls.from_urdf_file(p, tool_link=tool_link, tool_axis=tool_axis)
        path, tool_link, tool_axis, note = bundled_file(str(name_or_path), tool_link, tool_axis)
        m = cls.from_urdf_file(path, tool_link=tool_link, tool_axis=tool_axis)
        m.source = str(name_or_path)
        if note:
            m.notes.insert(0, note)
        return m

    @classmethod
    def from_urdf_file(cls, path: str | Path, *, tool_link: str | Sequence[str] | None = None,
                       tool_axis: str | None = None) -> "Machine":
        path = Path(path)
        return cls(urdf_file_text(path), source=str(path), urdf_path=path, tool_link=tool_link, tool_axis=tool_axis)

    @classmethod
    def from_urdf_string(cls, xml: str, source: str = "<string>", *, tool_link: str | Sequence[str] | None = None,
                         tool_axis: str | None = None) -> "Machine":
        return cls(xml, source=source, tool_link=tool_link, tool_axis=tool_axis)

    @property
    def load_options(self) -> dict[str, str]:
        """The options that reproduce this machine from its URDF (for model files)."""
        return {"tool_link": ",".join(self.tool_links), "tool_axis": self.tool_axis_name}

    def model_without_mimic(self) -> pin.Model:
        """The URDF as a Pinocchio model whose ``<mimic>`` joints are ordinary joints (one
        configuration entry each): the base of :class:`~vecpin.kinematics.errorframes.ErrorFrames`,
        which gives every mimic joint its own error transform."""
        if not self._mimic_in_model:
            return self.model
        if self._plain_model is None:
            self._plain_model = pin.buildModelFromXML(self.urdf_xml)
        return self._plain_model

    def _build_kinematics(self) -> None:
        """Probe frames on the tool links and the workpiece, and the maps between vecpin's
        axis values and Pinocchio's configuration and Jacobian columns."""
        model = self.model
        self._plain_model: pin.Model | None = None
        frames = {}
        for link in self.tool_links + ((self.workpiece_link,) if self.workpiece_link else ()):
            f = model.frames[model.getFrameId(link, pin.FrameType.BODY)]
            frames[link] = (f.parentJoint, f.placement)
        self._probes = FrameProbes(model, frames)
        self._joint_probes: FrameProbes | None = None
        self._frame_placements = {link: pin.SE3(pl) for link, (_, pl) in frames.items()}
        self._fill, self._gain = configuration_map(model, self.axes, self.mimic_joints, self._mimic_in_model)
        self._G_tool = np.stack([self._gain * self._probes.moves(t)[:, None] for t in self.tool_links])  # (P, c, n)
        self._G_wp = (self._gain * self._probes.moves(self.workpiece_link)[:, None] if self.workpiece_link
                      else np.zeros_like(self._gain))

    # ------------------------------------------------------------------ facts
    @property
    def n_axes(self) -> int:
        return len(self.axes)

    @property
    def axis_names(self) -> list[str]:
        return [a.name for a in self.axes]

    def rotary_mask(self) -> np.ndarray:
        """(n,) True on the rotary axes, chain order."""
        return np.array([a.kind == "rotary" for a in self.axes], bool)

    def axis(self, name: str) -> Axis:
        for a in self.axes:
            if a.name == name:
                return a
        raise MachineError(f"machine '{self.name}' has no axis '{name}' (axes: {', '.join(self.axis_names)})")

    @property
    def has_workpiece(self) -> bool:
        """True when the machine has a table branch (a ``workpiece`` link)."""
        return self.workpiece_link is not None

    @property
    def default_frame(self) -> str:
        """"workpiece" on a machine with a workpiece link, else "base"."""
        return "workpiece" if self.has_workpiece else "base"

    @property
    def head_axes(self) -> list[str]:
        return [a.name for a in self.axes if a.side != "table"]

    @property
    def table_axes(self) -> list[str]:
        return [a.name for a in self.axes if a.side != "head"]

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

    def gauge_offset(self, point: int = 0) -> float:
        """Distance [m] along the tool from the last axis' joint frame on the way to tool
        point ``point`` to its gauge line (T_offset)."""
        pl = self._frame_placements[self.tool_links[point]]
        return float(pl.translation @ (pl.rotation @ self.tool_axis))

    @property
    def layout(self) -> str:
        """Short layout description: the URDF's ``layout:`` comment line, else derived."""
        return self.tree.layout_tag or self.derived_layout()

    def derived_layout(self) -> str:
        """Layout from the structure: axis letters, where the rotaries are, tool points."""
        names = self.axis_names
        word = "".join(names) if all(len(n) == 1 for n in names) else f"{self.n_axes} axes"
        rot = [a for a in self.axes if a.kind == "rotary"]
        if len(rot) == self.n_axes and self.n_axes >= 4 and not self.has_workpiece:
            out = f"{self.n_axes}-axis arm"
        else:
            out = word
            head_rot = [a.name for a in rot if a.side != "table"]
            table_rot = [a.name for a in rot if a.side != "head"]
            if table_rot:
                out += f", table rotaries {', '.join(table_rot)}"
            if head_rot:
                out += f", head rotaries {', '.join(head_rot)}"
        if len(self.tool_links) > 1:
            out += f", {len(self.tool_links)} tool points ({', '.join(self.tool_links)})"
        return out

    # ------------------------------------------------------------------ kinematics
    def full_q(self, q: np.ndarray) -> np.ndarray:
        """Map axis values (n,) or (N, n) to Pinocchio's configuration vector of :attr:`model`
        (mimic joints follow their source; joints off the branches at Pinocchio's neutral, 0)."""
        return fill_configurations(self._probes.neutral[:self.model.nq], self._fill, np.asarray(q, float))

    def _jacobians(self, q: np.ndarray) -> np.ndarray:
        """(N, 6, nv_extended) Pinocchio world Jacobians of the probed model for q (N, n)."""
        return self._probes.jacobians(fill_configurations(self._probes.neutral, self._fill, q))

    def _frame(self, frame: str | None) -> str:
        if frame is None:
            return self.default_frame
        if frame not in ("base", "workpiece"):
            raise InputError(f"frame '{frame}': choose 'base' (the machine frame a floor tracker sees) "
                             "or 'workpiece' (the table frame)")
        return frame

    def _points(self, point, N: int) -> np.ndarray | int:
        P = len(self.tool_links)
        if np.ndim(point) == 0:
            k = int(point)
            if not 0 <= k < P:
                raise InputError(f"tool point {k} out of range (tool points: {', '.join(self.tool_links)})")
            return k
        pt = np.asarray(point)
        if pt.shape != (N,) or not np.issubdtype(pt.dtype, np.integer):
            raise InputError(f"point: one integer tool-point index per pose ({N}), got shape {pt.shape}")
        if pt.size and (pt.min() < 0 or pt.max() >= P):
            raise InputError(f"tool point index out of range 0..{P - 1} (tool points: {', '.join(self.tool_links)})")
        return pt

    def _tool_placements(self, probes: FrameProbes, J6: np.ndarray, pt) -> tuple[np.ndarray, np.ndarray]:
        """(R, p) of the tool link of every row in the base frame; rows grouped by tool point."""
        if np.ndim(pt) == 0:
            return probes.placement(J6, self.tool_links[pt])
        N = len(J6)
        R = np.empty((N, 3, 3))
        p = np.empty((N, 3))
        for k in np.unique(pt):
            rows = pt == k
            R[rows], p[rows] = probes.placement(J6[rows], self.tool_links[k])
        return R, p

    def _tip(self, probes: FrameProbes, J6: np.ndarray, pt, tool: np.ndarray,
             offset: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(R, o, u, tip) in the base frame from ``probes``' joint Jacobians J6: the tool link's
        rotation (N, 3, 3) and origin (N, 3) [m], the tool axis (N, 3) and the tool point (N, 3)
        [m] at ``tool`` (N,) [m] along the axis plus ``offset`` (3,) or (N, 3) [m] in the tool link."""
        R, o = self._tool_placements(probes, J6, pt)
        local = tool[:, None] * self.tool_axis
        if offset is not None:
            local = local + np.broadcast_to(np.asarray(offset, float), (len(tool), 3))
        return R, o, R @ self.tool_axis, o + apply(R, local)

    def kinematics(self, q: np.ndarray, tool: np.ndarray | float = 0.0, jacobian: bool = True, *,
                   frame: Frame | None = None, point: int | np.ndarray = 0,
                   offset: np.ndarray | None = None) -> TipKinematics:
        """Nominal tool point for N poses.

        q: (N, n) axis commands [m, rad] in axis order; tool: (N,) or scalar tool length
        [m] from the gauge line along the tool axis; offset: (3,) or (N, 3) further target
        offset [m] in the tool link frame (a reflector off the tool axis; d tip / d offset
        is ``rotation``); point: tool point index (int) or one per pose (N,) into
        :attr:`tool_links`; frame: "base" or "workpiece" (default :attr:`default_frame`).

        Pinocchio gives the tool link and workpiece placements and the joint Jacobian columns (one call per
        pose, :data:`KINEMATICS_ROWS` rows at a time). The Jacobian d tip / d q is the velocity of the tip
        point ``v0 + w × tip`` summed over the columns that move the tool link (a mimic joint's column counts
        for its source axis). Relative to the workpiece, ``p_rel = R_w^T (p_tip - p_w)`` and ``d p_rel =
        R_w^T (d p_tip - d p_w - w_w × (p_tip - p_w))``, where the bracket is the tip's velocity minus that
        of the workpiece-fixed point at the tip, so columns shared by both branches cancel."""
        q = np.atleast_2d(np.asarray(q, float))
        N = q.shape[0]
        frame = self._frame(frame)
        pt = self._points(point, N)
        tool = np.broadcast_to(np.asarray(tool, float), (N,))
        if N > KINEMATICS_ROWS:   # a piece of the rows at a time
            return kinematics_in_pieces(self.kinematics, q, tool, jacobian, frame, pt, offset)
        J6 = self._jacobians(q)
        R, o, u, tip = self._tip(self._probes, J6, pt, tool, offset)
        relative = frame == "workpiece" and self.has_workpiece
        J = None
        if jacobian:
            G = self._G_tool[pt] - self._G_wp if relative else self._G_tool[pt]  # (c, n) or (N, c, n)
            J = point_velocities(J6, tip, self._probes.n_columns) @ G
        if relative:
            Rw, pw = self._probes.placement(J6, self.workpiece_link)
            RwT = np.swapaxes(Rw, 1, 2)
            tip = apply_transposed(Rw, tip - pw)
            o = apply_transposed(Rw, o - pw)
            R = RwT @ R
            u = apply_transposed(Rw, u)
            if jacobian:
                J = RwT @ J
        return TipKinematics(tip, R, o, J, u, frame)

    def tool_tip(self, q: np.ndarray, tool: np.ndarray | float = 0.0, *, frame: Frame | None = None,
                 point: int | np.ndarray = 0, offset: np.ndarray | None = None) -> np.ndarray:
        """(N, 3) nominal tool-tip positions [m] (default frame: :attr:`default_frame`). A
        campaign of more than :data:`KINEMATICS_ROWS` rows is asked for its nominal tips by
        several checks and by every fit: the last :data:`TIP_MEMO` such answers are kept (keyed
        by a BLAKE2 digest of the arrays asked, not copies of them) and returned as copies."""
        q = np.atleast_2d(np.asarray(q, float))
        if len(q) <= KINEMATICS_ROWS:
            return self.kinematics(q, tool, jacobian=False, frame=frame, point=point, offset=offset).tip
        if self._frame(frame) == "base":   # the tool link placements kept: the tip as kinematics computes it
            R, o = self.tool_placements(q, point)
            local = np.broadcast_to(np.asarray(tool, float), (len(q),))[:, None] * self.tool_axis
            return o + apply(R, local if offset is None else local + np.broadcast_to(np.asarray(offset, float),
                                                                                     (len(q), 3)))
        return self._memo(("tip", frame), (q, tool, point, 0.0 if offset is None else offset), lambda: self.kinematics(
            q, tool, jacobian=False, frame=frame, point=point, offset=offset).tip).copy()

    def tool_placements(self, q: np.ndarray, point: int | np.ndarray = 0) -> tuple[np.ndarray, np.ndarray]:
        """(R (N,3,3), origin (N,3) [m]) of the tool link (tool point ``point``) in the base frame
        for commands q (N, n) [m, rad]. A campaign of more than :data:`KINEMATICS_ROWS` rows asks
        for them several times (its nominal tips, the fit's starting values): the last
        :data:`TIP_MEMO` answers are kept (keyed by a BLAKE2 digest of the arrays asked)."""
        q = np.atleast_2d(np.asarray(q, float))
        pt = np.asarray(point)
        if pt.ndim and pt.size and np.all(pt == pt.flat[0]):   # one tool point on every row: one key, one answer
            point = int(pt.flat[0])

        def compute():
            kin = self.kinematics(q, 0.0, jacobian=False, frame="base", point=point)
            return kin.rotation, kin.spindle
        R, o = compute() if len(q) <= KINEMATICS_ROWS else self._memo(("placements",), (q, point), compute)
        return R.copy(), o.copy()

    def _memo(self, what: tuple, arrays: tuple, compute):
        """``compute()``, kept for the last :data:`TIP_MEMO` keys (``what`` and a digest of ``arrays``)."""
        digest = hashlib.blake2b(repr(what).encode())
        for v in arrays:
            a = np.ascontiguousarray(v)
            digest.update(f"{a.dtype}{a.shape}".encode())
            digest.update(a.tobytes())
        key = digest.digest()
        memo = self.__dict__.setdefault("_tip_memo", {})
        if key not in memo:
            memo[key] = compute()
            while len(memo) > TIP_MEMO:
                memo.pop(next(iter(memo)))
        return memo[key]

    def workpiece_pose(self, q: np.ndarray) -> np.ndarray:
        """(N, 4, 4) pose T_bw of the workpiece frame in the base frame (identity without one)."""
        q = np.atleast_2d(np.asarray(q, float))
        out = np.broadcast_to(np.eye(4), (len(q), 4, 4)).copy()
        if self.has_workpiece:
            out[:, :3, :3], out[:, :3, 3] = self._probes.placement(self._jacobians(q), self.workpiece_link)
        return out

    def workpiece_points(self, q: np.ndarray, p_wp: np.ndarray, jacobian: bool = True) -> WorkpiecePoints:
        """Points fixed in the workpiece frame (table nests, targets), in the base frame.

        q: (N, n) [m, rad]; p_wp: (3,) or (N, 3) [m] in the workpiece frame. Returns
        positions (N,3) [m], d/dq (N,3,n) and d/dp_wp (N,3,3). Without a workpiece link
        the points are fixed in the base frame (d/dq = 0, d/dp_wp = I).
        """
        q = np.atleast_2d(np.asarray(q, float))
        N = q.shape[0]
        p = np.broadcast_to(np.asarray(p_wp, float), (N, 3))
        if not self.has_workpiece:
            J_q = np.zeros((N, 3, self.n_axes)) if jacobian else None
            J_p = np.broadcast_to(np.eye(3), (N, 3, 3)).copy() if jacobian else None
            return WorkpiecePoints(p.copy(), J_q, J_p)
        J6 = self._jacobians(q)
        Rw, pw = self._probes.placement(J6, self.workpiece_link)
        xyz = pw + apply(Rw, p)
        if not jacobian:
            return WorkpiecePoints(xyz, None, None)
        return WorkpiecePoints(xyz, point_velocities(J6, xyz, self._probes.n_columns) @ self._G_wp, Rw)

    def joint_frames(self, q: np.ndarray, axis: str) -> np.ndarray:
        """(N,4,4) placements in the base frame of an axis' joint frame after its motion."""
        q = np.atleast_2d(np.asarray(q, float))
        a = self.axis(axis)
        if self._joint_probes is None:
            self._joint_probes = FrameProbes(self.model, {b.name: (b.joint_id, pin.SE3.Identity()) for b in self.axes})
        probes = self._joint_probes
        out = np.broadcast_to(np.eye(4), (len(q), 4, 4)).copy()
        J6 = probes.jacobians(fill_configurations(probes.neutral, self._fill, q))
        out[:, :3, :3], out[:, :3, 3] = probes.placement(J6, a.name)
        return out

    def describe(self) -> str:
        """Human summary: layout, axes with kinds, sides and limits (user units), frames, notes."""
        order = "head branch (base -> tool) then table branch (base -> workpiece)" if self.has_workpiece \
            else "chain order from the base"
        lines = [f"machine {self.name}  ({self.source})",
                 f"  layout: {self.layout}",
                 f"  {self.n_axes} axes, {order}:"]
        width = max([8] + [len(a.name) for a in self.axes] + [len(mj.name) for mj in self.mimic_joints])
        for a in self.axes:
            d = " ".join(f"{v:g}" for v in a.direction)
            lines.append(f"    {a.name:<{width}s} {a.kind:<7s} {a.side:<5s} axis [{d}]  limits "
                         f"{a.lower_user:12.4f} .. {a.upper_user:12.4f} {a.unit}")
        for mj in self.mimic_joints:
            off = f" {mj.offset:+g}" if mj.offset else ""
            lines.append(f"    {mj.name:<{width}s} follows {mj.axis}: {mj.name} = {mj.multiplier:g} * {mj.axis}{off}")
        for k, link in enumerate(self.tool_links):
            what = "gauge line: link" if link.startswith(SPINDLE_LINK) else "tool link:"
            lines.append(f"  {what} '{link}' (tool point {k}), {to_mm(self.gauge_offset(k)):.3f} mm from the "
                         f"last axis frame; tool along {self.tool_axis_name}")
        if self.has_workpiece:
            lines.append(f"  workpiece: link '{self.workpiece_link}' (table axes {', '.join(self.table_axes)}); "
                         "tool tips relative to it by default")
        frames = [f.name for f in self.model.frames if f.type == pin.FrameType.BODY]
        lines.append(f"  links: {', '.join(frames)}")
        for note in self.notes:
            lines.append(f"  note: {note}")
        return "\n".join(lines)


def as_machine(machine, name: str = "machine") -> Machine:
    """``machine`` as a :class:`Machine`: a Machine as it is, a bundled machine's name or a URDF path
    loaded (:meth:`Machine.load`); anything else refused naming the argument ``name``. The one coercion the
    facade (:mod:`vecpin.workflows.facade`) and the fit's arguments (:mod:`vecpin.fitting.problem`) share."""
    if isinstance(machine, (str, Path)):
        return Machine.load(machine)
    if not isinstance(machine, Machine):
        raise InputError(f"`{name}` {type(machine).__name__}: give a Machine, a bundled machine's name or a URDF path")
    return machine
