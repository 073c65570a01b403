"""A plain reference fitter written without vecpin (issue 43): numpy and the standard library only.

It reads a URDF (serial chain from the root link to the tool link ``spindle``, the tool along its
-z) and a campaign CSV (one column per actuated joint in mm / deg, ``tool`` mm, ``x, y, z`` mm in
the tracker frame), and fits ONE fixed model: per actuated joint six small error motions (three
translations, three rotations in the joint's moved frame, Paper I eq. 3), each a Chebyshev series
of a fixed order over the joint's travel (URDF limits), plus the tracker's pose (a rigid
registration, then six linearised unknowns) and a gauge-line offset along the tool. One linear
least-squares solve with a small ridge (no model choice, no noise model, no redundancy analysis):
what someone would write by hand to fit a machine from a laser-tracker campaign. Prints the rows,
the unknowns and the residual before and after (mm).

Run: python benchmarks/reference_fit.py URDF CSV [--order 6]
It imports nothing from vecpin: its whole process is the yardstick vecpin's default fit is timed
against (benchmarks/bench_fit_speed.py).
"""
import argparse
import csv
import xml.etree.ElementTree as ET

import numpy as np


def rpy_matrix(r: float, p: float, y: float) -> np.ndarray:
    """URDF origin rotation Rz(y) Ry(p) Rx(r)."""
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def read_chain(path: str, tool_link: str = "spindle") -> list[dict]:
    """The joints from the root to ``tool_link``: name, type, origin (R, t), axis, limits (SI)."""
    joints = {}
    for j in ET.parse(path).getroot().iter("joint"):
        o = j.find("origin")
        xyz = [float(v) for v in (o.get("xyz", "0 0 0") if o is not None else "0 0 0").split()]
        rpy = [float(v) for v in (o.get("rpy", "0 0 0") if o is not None else "0 0 0").split()]
        ax = j.find("axis")
        lim = j.find("limit")
        joints[j.find("child").get("link")] = {
            "name": j.get("name"), "type": j.get("type"), "parent": j.find("parent").get("link"),
            "R": rpy_matrix(*rpy), "t": np.array(xyz),
            "axis": np.array([float(v) for v in (ax.get("xyz") if ax is not None else "1 0 0").split()]),
            "limits": (float(lim.get("lower", 0)), float(lim.get("upper", 0))) if lim is not None else (0.0, 0.0)}
    chain, link = [], tool_link
    while link in joints:
        chain.append(joints[link])
        link = joints[link]["parent"]
    return chain[::-1]


def rotation(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations about a unit axis (Rodrigues)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * k + (1 - c) * (k @ k)


def kinematics(chain: list[dict], q: dict[str, np.ndarray], tool_m: np.ndarray):
    """Nominal tool tips (n, 3) in the base frame and, per actuated joint, the moved frame's
    rotation (n, 3, 3) and the tip's position in that frame (n, 3), for the error Jacobian."""
    n = len(tool_m)
    R, t = np.broadcast_to(np.eye(3), (n, 3, 3)).copy(), np.zeros((n, 3))
    frames = []
    for j in chain:
        t = t + R @ j["t"]
        R = R @ j["R"]
        if j["type"] == "prismatic":
            t = t + (R @ j["axis"]) * q[j["name"]][:, None]
        elif j["type"] in ("revolute", "continuous"):
            R = R @ rotation(j["axis"], q[j["name"]])
        if j["type"] != "fixed":
            frames.append((j, R.copy(), t.copy()))
    tip = t + R @ np.array([0.0, 0.0, -1.0]) * tool_m[:, None]
    direction = R @ np.array([0.0, 0.0, -1.0])
    return tip, direction, [(j, Rk, np.einsum("nji,nj->ni", Rk, tip - tk)) for j, Rk, tk in frames]


def chebyshev(x: np.ndarray, lo: float, hi: float, order: int) -> np.ndarray:
    """(n, order + 1) Chebyshev polynomials of x mapped from [lo, hi] to [-1, 1]."""
    u = np.clip((2 * x - lo - hi) / max(hi - lo, 1e-12), -1, 1)
    return np.polynomial.chebyshev.chebvander(u, order)


def kabsch(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """R, t minimising |R a + t - b| (rows)."""
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    R = vt.T @ np.diag([1, 1, d]) @ u.T
    return R, cb - R @ ca


def read_campaign(path: str, chain: list[dict]) -> tuple[dict, np.ndarray, np.ndarray]:
    """Commands (SI) per actuated joint, tool lengths (m), measured points (m) of the tool rows."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    keep = [r for r in rows if r.get("instrument", "tracker") in ("tracker", "")]
    q = {}
    for j in chain:
        if j["type"] == "fixed":
            continue
        v = np.array([float(r[j["name"]]) for r in keep])
        q[j["name"]] = v * 1e-3 if j["type"] == "prismatic" else np.radians(v)
    tool = np.array([float(r["tool"]) for r in keep]) * 1e-3
    xyz = np.array([[float(r[c]) for c in "xyz"] for r in keep]) * 1e-3
    return q, tool, xyz


def fit(urdf: str, csv_path: str, order: int = 6, ridge: float = 1e-6) -> tuple[int, int, float, float]:
    """(rows, unknowns, mean residual before, after [mm]) of the one-solve fit."""
    chain = read_chain(urdf)
    q, tool, xyz = read_campaign(csv_path, chain)
    tip, direction, frames = kinematics(chain, q, tool)
    R, t = kabsch(xyz, tip)                                   # tracker -> base
    res = xyz @ R.T + t - tip                                 # base frame, m
    cols = []
    c = tip - tip.mean(axis=0)                                # tracker pose: translation, small rotation
    cols += [np.broadcast_to(e, (len(tip), 3)) for e in np.eye(3)]
    cols += [np.cross(e, c) for e in np.eye(3)]
    cols.append(direction)                                    # gauge-line offset
    for j, Rk, r in frames:
        T = chebyshev(q[j["name"]], *j["limits"], order)      # (n, order + 1)
        for k in range(3):                                    # translation along the moved frame's axis k
            cols += [Rk[:, :, k] * T[:, [i]] for i in range(order + 1)]
        for k in range(3):                                    # rotation about it: R (e_k x r)
            d = np.einsum("nij,nj->ni", Rk, np.cross(np.eye(3)[k], r))
            cols += [d * T[:, [i]] for i in range(order + 1)]
    J = np.stack(cols, axis=-1).reshape(-1, len(cols))        # (3n, unknowns)
    scale = np.linalg.norm(J, axis=0) + 1e-30
    A = J / scale
    x = np.linalg.solve(A.T @ A + ridge * np.eye(A.shape[1]), A.T @ res.ravel())
    left = res - (A @ x).reshape(-1, 3)
    return len(tip), J.shape[1], np.linalg.norm(res, axis=1).mean() * 1e3, np.linalg.norm(left, axis=1).mean() * 1e3


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("urdf")
    p.add_argument("csv")
    p.add_argument("--order", type=int, default=6)
    a = p.parse_args()
    n, k, before, after = fit(a.urdf, a.csv, a.order)
    print(f"reference: {n} rows, 6-DoF Chebyshev order {a.order}, {k} unknowns, one linear solve: residual mean "
          f"{after:.4f} mm (before {before:.4f} mm)")


if __name__ == "__main__":
    main()
