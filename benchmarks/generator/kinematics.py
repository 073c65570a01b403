"""The truth's forward kinematics: numpy homogeneous transforms, errors as small rigid motions.

Independent of pinocchio and vecpin. For N poses at once: each joint contributes its origin
(xyz, roll-pitch-yaw about fixed x, y, z as URDF defines it), its motion (a translation along
or a rotation about its axis by the joint position) and then, for an actuated joint, its error:
an exact rigid motion exp([eps]x) with translation delta, both in the joint's own moved frame
(the seed's E_k after T_k, Paper I eq. 3, here without linearisation).
SI throughout: m, rad.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from scipy.spatial.transform import Rotation

from .layouts import Joint, Layout

# error(q) -> (N, 6): delta x, y, z (m) and eps x, y, z (rad) of one joint, in its moved frame
ErrorFn = Callable[[Mapping[str, np.ndarray]], np.ndarray]


def rpy_matrix(rpy: tuple[float, float, float]) -> np.ndarray:
    """URDF origin rotation: Rz(yaw) Ry(pitch) Rx(roll)."""
    return Rotation.from_euler("xyz", rpy).as_matrix()


def origin(j: Joint, n: int, scale: np.ndarray | None = None) -> np.ndarray:
    """(n, 4, 4) origin transform of a joint; ``scale`` (n,) stretches its translation (thermal)."""
    t = np.tile(np.eye(4), (n, 1, 1))
    t[:, :3, :3] = rpy_matrix(j.rpy)
    xyz = np.asarray(j.xyz, dtype=float)
    t[:, :3, 3] = xyz[None, :] * (1.0 if scale is None else scale[:, None])
    return t


def motion(j: Joint, q: np.ndarray) -> np.ndarray:
    """(n, 4, 4) joint motion by q (m or rad) along/about its unit axis."""
    n = len(q)
    t = np.tile(np.eye(4), (n, 1, 1))
    axis = np.asarray(j.axis, dtype=float)
    if j.kind == "prismatic":
        t[:, :3, 3] = q[:, None] * axis[None, :]
    elif j.kind == "revolute":
        t[:, :3, :3] = Rotation.from_rotvec(q[:, None] * axis[None, :]).as_matrix()
    return t


def error_transform(e: np.ndarray) -> np.ndarray:
    """(n, 4, 4) exact rigid motion of an error 6-vector (n, 6): translation e[:3], rotation vector e[3:]."""
    n = len(e)
    t = np.tile(np.eye(4), (n, 1, 1))
    t[:, :3, :3] = Rotation.from_rotvec(e[:, 3:]).as_matrix()
    t[:, :3, 3] = e[:, :3]
    return t


def chain(layout: Layout, names: list[str], q: Mapping[str, np.ndarray],
          errors: Mapping[str, list[ErrorFn]] | None = None,
          q_actual: Mapping[str, np.ndarray] | None = None,
          origin_scale: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
    """(n, 4, 4) pose of the last link of the chain ``names`` in the base frame.

    q: commanded joint positions (SI, arrays of n) given to the error functions; q_actual: where
    the joints really are (backlash, thermal scale, repeatability), default q; errors: per joint a
    list of error functions summed; origin_scale: per joint a factor on its origin translation.
    """
    n = len(next(iter(q.values())))
    qa = q_actual or q
    t = np.tile(np.eye(4), (n, 1, 1))
    for name in names:
        j = layout.joint(name)
        t = t @ origin(j, n, None if origin_scale is None else origin_scale.get(name))
        if not j.actuated:
            continue
        t = t @ motion(j, np.asarray(qa[name], dtype=float))
        fns = (errors or {}).get(name, [])
        if fns:
            e = sum(f(q) for f in fns)
            t = t @ error_transform(np.asarray(e, dtype=float))
    return t


def tool_points(layout: Layout, q: Mapping[str, np.ndarray], tool_m: np.ndarray, **kw) -> np.ndarray:
    """(n, 3) tool tip in the base frame, m: ``tool_m`` along the tool axis of the tool link."""
    t = chain(layout, layout.tool_chain, q, **kw)
    local = np.asarray(layout.tool_axis, dtype=float)[None, :] * np.asarray(tool_m, dtype=float)[:, None]
    return np.einsum("nij,nj->ni", t[:, :3, :3], local) + t[:, :3, 3]


def table_points(layout: Layout, q: Mapping[str, np.ndarray], local: np.ndarray, **kw) -> np.ndarray:
    """(n, 3) points fixed in ``workpiece`` (local (n, 3), m) in the base frame."""
    t = chain(layout, layout.table_chain, q, **kw)
    return np.einsum("nij,nj->ni", t[:, :3, :3], local) + t[:, :3, 3]
