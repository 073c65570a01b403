"""Hand-derived closed-form nominal kinematics of every bundled machine (numpy only).

Independent of vecpin's kinematics engine and of any URDF reader: each function is
written from the machine's geometry as stated in its URDF header (seed numbers, or
ASSUMED values marked there). Adapted from the derivations in the machine notes that
came with the URDFs (scratch/machines/README.md).

``tip(q, t)``: q (N, n) axis values [m, rad] in vecpin's axis order (head branch, then
table branch), t (N,) tool length [m]; returns the tool tip in the workpiece frame when
the machine has one, else in the base frame. ``workpiece(q)``: (N, 4, 4) pose of the
workpiece frame in the base frame. Notation: sX = sin X, cX = cos X.
"""
from __future__ import annotations

import numpy as np


def _cols(q, n):
    q = np.atleast_2d(np.asarray(q, float))
    assert q.shape[1] == n
    return q.T


def rot(axis: str, a: np.ndarray) -> np.ndarray:
    """(N,3,3) right-handed rotations about x, y or z."""
    a = np.asarray(a, float)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(a.shape + (3, 3))
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    k = 3 - i - j
    R[..., k, k] = 1.0
    R[..., i, i], R[..., i, j], R[..., j, i], R[..., j, j] = c, -s, s, c
    return R


def homogeneous(R, p) -> np.ndarray:
    R = np.asarray(R, float)
    p = np.broadcast_to(np.asarray(p, float), R.shape[:-2] + (3,))
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3], T[..., :3, 3], T[..., 3, 3] = R, p, 1.0
    return T


# ---------------------------------------------------------------- the first four machines
# flow_xyzcb, Paper I eq. 20-21: tip = (X, Y, Z) + Rz(C) Ry(B) (0, 0, -(T_offset + t)), T_offset = 98 mm
# cincinnati_20v / snk_120v: (X, Y, Z) + Rx(A) Ry(B) (0, 0, -(L + t)), L = 250 / 300 mm
# ingersoll_xyzca: (X, Y, Z) + Rz(C) Rx(A) (0, 0, -(450 mm + t))
def _head_two_rotaries(first: str, second: str, L: float):
    def f(q, t):
        X, Y, Z, r1, r2 = _cols(q, 5)
        v = np.zeros((len(X), 3))
        v[:, 2] = -(L + np.broadcast_to(t, X.shape))
        out = np.einsum("pij,pjk,pk->pi", rot(first, r1), rot(second, r2), v)
        return out + np.stack([X, Y, Z], 1)
    return f


# ---------------------------------------------------------------- Master Mill (seed Table 2.7)
# tip = (X, Y, Z) + Rz(C) Rx(A) (0, 0, -d), d = L + t, L = 0.500 m (ASSUMED)
#     = (X - d sA sC, Y + d sA cC, Z - d cA)
def master_mill(q, t):
    X, Y, Z, C, A = _cols(q, 5)
    d = 0.500 + t
    return np.stack([X - d * np.sin(A) * np.sin(C), Y + d * np.sin(A) * np.cos(C), Z - d * np.cos(A)], 1)


# ---------------------------------------------------------------- Spar Mill 23 (all geometry ASSUMED)
# head 1 at (0, Y0, Z0): (X, Y0 + Y + d sA, Z0 + Z - d cA); head 2 is its mirror image in y = 0
SPAR_Y0, SPAR_Z0, SPAR_L = 0.600, 2.000, 0.350


def spar_mill_23(q, t):
    X, Y, Z, A = _cols(q, 4)
    d = SPAR_L + t
    return np.stack([X, SPAR_Y0 + Y + d * np.sin(A), SPAR_Z0 + Z - d * np.cos(A)], 1)


def spar_mill_23_spindle_2(q, t):
    p = spar_mill_23(q, t)
    p[:, 1] *= -1.0
    return p


# ---------------------------------------------------------------- production XYZBAW (seed Table 2.11)
# tip = (X, Y, Z0 + Z) + Ry(B) [ (0, 0, -hBA) + Rx(A) (0, 0, e) ],  e = W - hAW - L - t
# Rx(A)(0,0,e) = (0, -e sA, e cA); w = e cA - hBA; Ry(B)(0, -e sA, w) = (w sB, -e sA, w cB)
def production_xyzbaw(q, t):
    X, Y, Z, B, A, W = _cols(q, 6)
    e = W - 0.250 - 0.400 - t
    w = e * np.cos(A) - 0.300
    return np.stack([X + w * np.sin(B), Y - e * np.sin(A), 1.200 + Z + w * np.cos(B)], 1)


# ---------------------------------------------------------------- trunnion XYZAC (ASSUMED)
# head: tip_base = (X, Y, H + Z - t), H = 0.700; table: T_bw = Tz(hA) Rx(A) Tz(-hA) Rz(C), hA = 0.100
# r = tip_base - (0, 0, hA); u = Rx(-A) r + (0, 0, hA); tip_wp = Rz(-C) u
def trunnion_xyzac(q, t):
    X, Y, Z, A, C = _cols(q, 5)
    rx, ry, rz = X, Y, 0.700 + Z - t - 0.100
    sA, cA, sC, cC = np.sin(A), np.cos(A), np.sin(C), np.cos(C)
    ux, uy, uz = rx, ry * cA + rz * sA, -ry * sA + rz * cA + 0.100
    return np.stack([ux * cC + uy * sC, -ux * sC + uy * cC, uz], 1)


def trunnion_xyzac_workpiece(q):
    _, _, _, A, C = _cols(q, 5)
    hA = np.array([0, 0, 0.100])
    RA = rot("x", A)
    # Tz(hA) Rx(A) Tz(-hA) Rz(C): rotation RA Rz(C), origin hA - RA hA
    return homogeneous(RA @ rot("z", C), hA - RA @ hA)


# ---------------------------------------------------------------- all-table XYZAC (ASSUMED, LinuxCNC xyzac-trt-like)
# spindle fixed: tip_base = (0, 0, H - t), H = 0.700; table: T_bw = T(-X, -Y, -Z) Tz(hA) Rx(A) Tz(-hA) Rz(C),
# hA = 0.100 (joint axes -x, -y, -z); tip_wp = R_bw^T (tip_base - o_bw)
def xyzac_trt_workpiece(q):
    X, Y, Z, A, C = _cols(q, 5)
    hA = np.array([0, 0, 0.100])
    RA = rot("x", A)
    return homogeneous(RA @ rot("z", C), -np.stack([X, Y, Z], 1) + hA - RA @ hA)


def xyzac_trt(q, t):
    T = xyzac_trt_workpiece(q)
    tip = np.zeros((len(T), 3))
    tip[:, 2] = 0.700 - np.asarray(t, float)
    return np.einsum("pji,pj->pi", T[:, :3, :3], tip - T[:, :3, 3])


# ---------------------------------------------------------------- trunnion XYZBC (ASSUMED)
# T_bw = Tz(hB) Ry(B) T(cx, 0, -hB) Rz(C), hB = 0.080, cx = 0.002; H = 0.720
# r = tip_base - (0,0,hB); u = Ry(-B) r - (cx, 0, -hB); tip_wp = Rz(-C) u
def trunnion_xyzbc(q, t):
    X, Y, Z, B, C = _cols(q, 5)
    rx, ry, rz = X, Y, 0.720 + Z - t - 0.080
    sB, cB, sC, cC = np.sin(B), np.cos(B), np.sin(C), np.cos(C)
    ux, uy, uz = rx * cB - rz * sB - 0.002, ry, rx * sB + rz * cB + 0.080
    return np.stack([ux * cC + uy * sC, -ux * sC + uy * cC, uz], 1)


def trunnion_xyzbc_workpiece(q):
    _, _, _, B, C = _cols(q, 5)
    RB = rot("y", B)
    return homogeneous(RB @ rot("z", C), np.array([0, 0, 0.080]) + RB @ np.array([0.002, 0, -0.080]))


# ---------------------------------------------------------------- head-table BC (ASSUMED)
# head: tip_base = (X - d sB, Y, H + Z - d cB), d = L + t, H = 0.450, L = 0.300
# table: T_bw = T(0.625, 0.500, 0) Rz(C); tip_wp = Rz(-C) (tip_base - (0.625, 0.500, 0))
def head_table_bc(q, t):
    X, Y, Z, B, C = _cols(q, 5)
    d = 0.300 + t
    ux, uy, uz = X - d * np.sin(B) - 0.625, Y - 0.500, 0.450 + Z - d * np.cos(B)
    sC, cC = np.sin(C), np.cos(C)
    return np.stack([ux * cC + uy * sC, -ux * sC + uy * cC, uz], 1)


def head_table_bc_workpiece(q):
    C = _cols(q, 5)[4]
    return homogeneous(rot("z", C), np.array([0.625, 0.500, 0.0]))


# ---------------------------------------------------------------- UR5 and UR10 (CB3) from published DH parameters
# Universal Robots, "Parameters for calculations of kinematics and dynamics" (serie 3, standard DH):
#   UR5:  a = (0, -0.425, -0.39225, 0, 0, 0) m, d = (0.089159, 0, 0, 0.10915, 0.09465, 0.0823) m,
#   UR10: a = (0, -0.612, -0.5723, 0, 0, 0) m,  d = (0.1273, 0, 0, 0.163941, 0.1157, 0.0922) m,
#   alpha = (pi/2, 0, 0, pi/2, -pi/2, 0). T = prod_i Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i); the tool
#   points along +z of the flange frame.
UR5_A = (0.0, -0.425, -0.39225, 0.0, 0.0, 0.0)
UR5_D = (0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823)
UR10_A = (0.0, -0.612, -0.5723, 0.0, 0.0, 0.0)
UR10_D = (0.1273, 0.0, 0.0, 0.163941, 0.1157, 0.0922)
UR_ALPHA = (np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0)


def _ur_dh(a, d):
    def tip(q, t):
        """Product of the six DH matrices (the vendor's definition)."""
        q = _cols(q, 6).T
        T = np.broadcast_to(np.eye(4), (len(q), 4, 4)).copy()
        for i in range(6):
            Rz = homogeneous(rot("z", q[:, i]), np.zeros(3))
            const = homogeneous(rot("x", np.array(UR_ALPHA[i])), np.array([a[i], 0.0, d[i]]))
            T = T @ Rz @ const
        return T[:, :3, 3] + T[:, :3, 2] * np.asarray(t, float).reshape(-1, 1)
    return tip


ur5_dh = _ur_dh(UR5_A, UR5_D)
ur10_dh = _ur_dh(UR10_A, UR10_D)


def ur5_planar(q, t):
    """The same by hand: joints 2-4 are parallel, a planar chain in frame 1's x-y plane.
    r along x1 = (c1, s1, 0), h along base z, w along z1 = (s1, -c1, 0); D = d6 + t."""
    t1, t2, t3, t4, t5, _ = _cols(q, 6)
    D = UR5_D[5] + t
    s234, c234 = np.sin(t2 + t3 + t4), np.cos(t2 + t3 + t4)
    r = UR5_A[1] * np.cos(t2) + UR5_A[2] * np.cos(t2 + t3) + UR5_D[4] * s234 - D * np.sin(t5) * c234
    h = UR5_A[1] * np.sin(t2) + UR5_A[2] * np.sin(t2 + t3) - UR5_D[4] * c234 - D * np.sin(t5) * s234
    w = UR5_D[3] + D * np.cos(t5)
    return np.stack([r * np.cos(t1) + w * np.sin(t1), r * np.sin(t1) - w * np.cos(t1), UR5_D[0] + h], 1)


#: name -> (tool point -> closed form tip), workpiece pose closed form or None
MACHINES = {
    "flow_xyzcb": ({0: _head_two_rotaries("z", "y", 0.098)}, None),
    "cincinnati_20v": ({0: _head_two_rotaries("x", "y", 0.250)}, None),
    "snk_120v": ({0: _head_two_rotaries("x", "y", 0.300)}, None),
    "ingersoll_xyzca": ({0: _head_two_rotaries("z", "x", 0.450)}, None),
    "master_mill": ({0: master_mill}, None),
    "spar_mill_23": ({0: spar_mill_23, 1: spar_mill_23_spindle_2}, None),
    "production_xyzbaw": ({0: production_xyzbaw}, None),
    "trunnion_xyzac": ({0: trunnion_xyzac}, trunnion_xyzac_workpiece),
    "trunnion_xyzbc": ({0: trunnion_xyzbc}, trunnion_xyzbc_workpiece),
    "head_table_bc": ({0: head_table_bc}, head_table_bc_workpiece),
    "xyzac_trt": ({0: xyzac_trt}, xyzac_trt_workpiece),
    "ur5": ({0: ur5_dh}, None),
    "ur10": ({0: ur10_dh}, None),
}
