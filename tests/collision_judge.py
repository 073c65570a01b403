"""An independent judge of the target holder against a machine's geometry, for the tests
of vecpin's programs: written from the URDF specification and nothing of vecpin's (it
imports no vecpin code). The machine's URDF is posed with Pinocchio
(``buildModelFromUrdf``, ``buildGeomFromUrdf``: the collision geometry, else the visual
one, as a URDF without ``<collision>`` elements is drawn) and every solid is tested
against the holder with Coal (hpp-fcl, ``collide``): the holder is a capsule of radius
``radius`` [m] along the tool axis from the gauge line (the origin of the tool frame the
URDF's comment names) to the target's centre at the holder's length.

The solids of the tool frame's own link and of the links the URDF's comment names as
the flange (the spindle nose, an arm's last link the holder is clamped to) are its seat,
not obstacles; every other solid is one. Positions are given as the programs give them: per URDF joint
name, mm for a prismatic joint and degrees for a revolute one (machine coordinates:
the joint's own value)."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin

ROBOTS = Path(__file__).resolve().parents[1] / "robots"


class Judge:
    """The holder against the solids of ``urdf`` (a path): ``tool_frame`` the URDF link at
    the gauge line, ``tool_axis`` (3,) the direction the tool points in that frame,
    ``seat`` the links whose solids hold the holder (besides the tool frame's own)."""

    def __init__(self, urdf: Path, tool_frame: str, tool_axis, seat: tuple[str, ...] = (), radius: float = 0.0005):
        self.model = pin.buildModelFromUrdf(str(urdf))
        gm = pin.buildGeomFromUrdf(self.model, str(urdf), pin.GeometryType.COLLISION, package_dirs=[str(urdf.parent)])
        if gm.ngeoms == 0:
            gm = pin.buildGeomFromUrdf(self.model, str(urdf), pin.GeometryType.VISUAL,
                                       package_dirs=[str(urdf.parent)])
        assert gm.ngeoms > 0, f"{urdf}: no geometry to judge with"
        self.geom = gm
        self.frame = self.model.getFrameId(tool_frame)
        assert self.frame < self.model.nframes, f"{urdf}: no frame {tool_frame}"
        self.axis = np.asarray(tool_axis, float) / np.linalg.norm(tool_axis)
        self.radius = float(radius)
        self.data = self.model.createData()
        self.gdata = pin.GeometryData(gm)
        self.prismatic = {j.get("name") for j in ET.parse(urdf).getroot().iter("joint") if j.get("type") == "prismatic"}
        self.own = {k for k, o in enumerate(gm.geometryObjects)
                    if self.model.frames[o.parentFrame].name in (tool_frame, *seat)}

    def q(self, position: dict) -> np.ndarray:
        """Pinocchio's configuration of a position {joint: mm or deg}."""
        q = pin.neutral(self.model)
        for j in range(1, self.model.njoints):
            name, jm = self.model.names[j], self.model.joints[j]
            if jm.nq == 0:
                continue
            v = float(position[name])
            if name in self.prismatic:
                q[jm.idx_q] = v / 1000.0
            elif jm.nq == 2:     # a continuous joint: (cos, sin)
                q[jm.idx_q:jm.idx_q + 2] = np.cos(np.radians(v)), np.sin(np.radians(v))
            else:
                q[jm.idx_q] = np.radians(v)
        return q

    def hits(self, position: dict, holder: float) -> list[str]:
        """Names of the solids the holder of length ``holder`` [m] meets at ``position``."""
        pin.framesForwardKinematics(self.model, self.data, self.q(position))
        pin.updateGeometryPlacements(self.model, self.data, self.geom, self.gdata)
        M = self.data.oMf[self.frame]
        gauge = M.translation
        d = M.rotation @ self.axis
        capsule = coal.Capsule(self.radius, holder)
        R = _z_to(d)
        tf = coal.Transform3s(R, gauge + d * holder / 2)
        out = []
        for k, o in enumerate(self.geom.geometryObjects):
            if k in self.own:
                continue
            P = self.gdata.oMg[k]
            T = coal.Transform3s(P.rotation, P.translation)
            if _collide(capsule, tf, o.geometry, T):
                out.append(o.name)
        return out

    def colliding(self, positions: list[dict], holders) -> list[tuple[int, list[str]]]:
        """(index, solids) of every position whose holder meets a solid."""
        holders = np.broadcast_to(np.asarray(holders, float), (len(positions),))
        out = []
        for i, (p, h) in enumerate(zip(positions, holders)):
            hit = self.hits(p, float(h))
            if hit:
                out.append((i, hit))
        return out


def _collide(a, ta, b, tb) -> bool:
    req, res = coal.CollisionRequest(), coal.CollisionResult()
    return coal.collide(a, ta, b, tb, req, res) > 0


def _z_to(d: np.ndarray) -> np.ndarray:
    """A rotation taking the z axis to the unit vector ``d``."""
    z = np.array([0.0, 0.0, 1.0])
    v, c = np.cross(z, d), float(z @ d)
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + K + K @ K / (1 + c)


# the tool frame and axis each URDF's comment names (robots/*.urdf)
TOOLS = {"trunnion_xyzac": ("spindle", (0, 0, -1), ()), "xyzac_trt": ("spindle", (0, 0, -1), ()),
         "ur5": ("tool0", (0, 0, 1), ("link_6",))}   # tool0: the flange at the end of link_6


def judge(name: str, radius: float = 0.0005) -> Judge:
    """The judge of a bundled machine ``name``."""
    frame, axis, seat = TOOLS[name]
    return Judge(ROBOTS / f"{name}.urdf", frame, axis, seat, radius)
