"""Rigid registration of the tracker frame to the machine frame.

Least-squares rotation and translation (Kabsch: the SVD of the weighted cross-covariance,
the reflection excluded; many sets at once, :func:`kabsch`) mapping machine-frame points
onto tracker-frame points: ``p_tracker ≈ R p_machine + t``. (scipy's
``Rotation.align_vectors`` does the same for one set; the tests hold the two equal. Its
module costs a fit's process 0.3 s to import.)
Used to place the tracker from nominal kinematics with no user guess; the small
remaining correction ``E_0`` (Paper I eq. 10) is identified with the model.
"""
from __future__ import annotations

import numpy as np

from vecpin.errors import VecpinError
from vecpin.units import MM_PER_M


def rigid_registration(p_machine: np.ndarray, p_tracker: np.ndarray,
                       weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) minimising sum w_i |R p_machine_i + t - p_tracker_i|^2."""
    P = np.asarray(p_machine, float)
    Q = np.asarray(p_tracker, float)
    w = np.ones(len(P)) if weights is None else np.asarray(weights, float)
    w = w / w.sum()
    cp = w @ P
    sv = np.linalg.svd((P - cp) * np.sqrt(w)[:, None], compute_uv=False)
    if len(sv) < 2 or sv[1] < 1e-9 * max(sv[0], 1e-300):
        raise VecpinError("the measured points are (nearly) collinear: the tracker frame cannot be registered")
    R, t = kabsch(P, Q[None], w)
    return R[0], t[0]


def kabsch(P: np.ndarray, Q: np.ndarray, weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(R (G,3,3), t (G,3)) minimising sum_k w_k |R P_gk + t - Q_gk|^2 for each g: P (k,3)
    or (G,k,3), Q (G,k,3) [m], ``weights`` (k,) (default equal): :func:`rigid_registration`, many
    at once."""
    P = np.broadcast_to(P, Q.shape)
    w = np.ones(Q.shape[1]) if weights is None else np.asarray(weights, float)
    w = w / w.sum()
    cp, cq = np.einsum("k,gki->gi", w, P), np.einsum("k,gki->gi", w, Q)
    H = np.einsum("k,gki,gkj->gij", w, P - cp[:, None], Q - cq[:, None])
    U, _, Vt = np.linalg.svd(H)
    V, Ut = np.swapaxes(Vt, 1, 2), np.swapaxes(U, 1, 2)
    D = np.ones((len(Q), 3))
    D[:, 2] = np.sign(np.linalg.det(V @ Ut))   # a rotation, never a reflection
    R = V @ (D[:, :, None] * Ut)
    return R, cq - np.einsum("gij,gj->gi", R, cp)


def rigid_motion_basis(points: np.ndarray) -> np.ndarray:
    """(3N, 6) orthonormal basis of the displacements of ``points`` (N,3) [m] under a
    small rigid motion: translations, and rotations w about the points' centroid
    (w x r = -[r]x w). Projecting a stacked error vector orthogonally to it is the
    linearised best-fit registration."""
    r = points - points.mean(axis=0)
    B = np.zeros((len(points), 3, 6))
    B[:, :, :3] = np.eye(3)
    B[:, :, 3:] = -np.cross(r[:, :, None], np.eye(3)[None], axis=1)
    return np.linalg.qr(B.reshape(-1, 6))[0]


def registered_errors(p_machine: np.ndarray, p_tracker: np.ndarray) -> np.ndarray:
    """(N,3) residuals [same unit] of tracker points after the best rigid fit of the
    machine points: the 'uncompensated' volumetric error of the seed's tables."""
    R, t = rigid_registration(p_machine, p_tracker)
    return p_tracker - (p_machine @ R.T + t)


# scale factors of the usual unit mistakes: measured / nominal
_UNIT_SCALES = {25.4: "the commands in inches while x, y, z are mm",
                1 / 25.4: "x, y, z in inches while the commands are mm",
                10.0: "x, y, z in 1/10 mm or the commands in cm", 0.1: "x, y, z in cm",
                1000.0: "x, y, z in µm", 0.001: "x, y, z in metres"}
RESIDUAL_LIMIT = 0.02  # m: no machine worth measuring is this far from its nominal kinematics after registration


def spans_plane(points: np.ndarray) -> bool:
    """True when the points (N,3) span more than a line (a rigid registration is defined)."""
    P = np.asarray(points, float)
    if len(P) < 3:
        return False
    sv = np.linalg.svd(P - P.mean(0), compute_uv=False)
    return bool(sv[0] >= 1e-6 and sv[1] > 1e-9 * sv[0])


def check_registration(p_machine: np.ndarray, p_tracker: np.ndarray, source: str = "campaign",
                       rows: np.ndarray | None = None) -> None:
    """Refuse a campaign whose measured points cannot be the nominal tool tips seen by a
    tracker: a scale of a unit mistake, a mirror image (a left-handed tracker frame:
    two columns swapped or one negated), or residuals of centimetres after the rigid
    registration. ``rows``: file line numbers of the points, for the messages."""
    from vecpin.errors import CampaignFileError
    P = np.asarray(p_machine, float)
    Q = np.asarray(p_tracker, float)
    if len(P) < 4:
        return
    cp, cq = P.mean(0), Q.mean(0)
    A, B = P - cp, Q - cq
    if not spans_plane(P):
        raise CampaignFileError(source, "the commanded tool tips lie on a line (or at one point), so the tracker "
                                "frame cannot be registered; measure commands spread over the travel")
    sa = np.sqrt((A**2).sum() / len(A))
    sb = np.sqrt((B**2).sum() / len(B))
    if sa <= 0 or sb <= 0:
        return
    U, S, Vt = np.linalg.svd(A.T @ B)
    d = np.sign(np.linalg.det(U @ Vt))
    scale = float((S[0] + S[1] + d * S[2]) / (A**2).sum())  # Umeyama: best scale with a proper rotation
    mirror = (U @ Vt).T if d < 0 else None  # the best orthogonal map is a reflection
    for s, cause in _UNIT_SCALES.items():
        if abs(np.log(scale / s)) < 0.05:
            raise CampaignFileError(source, f"the measured points are {scale:.4g} times the size of the commanded "
                                    f"ones: {cause}? Files are mm; fix the units and fit again", column="x")
    R, t = rigid_registration(P, Q)
    res = np.linalg.norm(Q - (P @ R.T + t), axis=1)
    if mirror is not None:
        res_mirror = np.linalg.norm(B - A @ mirror.T, axis=1)
        if np.sqrt((res_mirror**2).mean()) < 0.2 * np.sqrt((res**2).mean()):
            raise CampaignFileError(source, "the measured points are a mirror image of the commanded ones: a "
                                    "left-handed tracker frame (two of x, y, z swapped, or one negated); fix the "
                                    "columns and fit again", column="x")
    rms = float(np.sqrt(np.median(res**2)))
    if rms > RESIDUAL_LIMIT:
        raise CampaignFileError(source, f"after the best rigid registration the points are still {rms * MM_PER_M:.1f} mm "
                                "(median) from the nominal tool tips: this is not this machine's campaign, or the "
                                "axis or tool columns are in the wrong units (inches or cm for mm?) or order")
    bad = np.flatnonzero(res > max(10 * np.median(res) + 1e-4, RESIDUAL_LIMIT))
    if bad.size and bad.size <= max(1, len(res) // 20):
        row = int(rows[bad[0]]) if rows is not None else None
        raise CampaignFileError(source, f"{bad.size} row(s) lie {res[bad[0]] * MM_PER_M:.1f} mm from the nominal tool tip "
                                "while the others fit within a few: a mistyped command or tool length (metres for mm?) "
                                "or a wrong point; fix or delete the row", row=row)


def station0(campaign, what: str = "the model's tracker pose"):
    """The rows a fitted tracker pose describes (station 0's tracker rows), refused when
    there are none (a campaign measured only from other stations, or only by ball bar)."""
    from vecpin.errors import CampaignFileError
    c = campaign.primary()
    if len(c.tracker_rows) == 0:
        raise CampaignFileError(campaign.source, f"no tracker rows of station 0, the station {what} describes; "
                                "number the stations from 0 (the 'station' column) or give a campaign with them",
                                column="station")
    return c


def check_campaign_frames(machine, campaign) -> None:
    """:func:`check_registration` of every tracker station of a campaign against the
    machine's nominal tool tips (before a campaign is judged or fitted): the rows of tool
    tips (targets of unknown offset and table nests are checked by the fit, from the
    likelihood's starting points)."""
    trk = np.flatnonzero((campaign.instrument == "tracker") & (campaign.target == ""))
    nominal = machine.tool_tip(campaign.q[trk], campaign.tool[trk], frame="base", point=campaign.point[trk])
    for s in np.unique(campaign.station[trk]):
        sel = campaign.station[trk] == s
        if len(campaign.nest_rows) and not spans_plane(nominal[sel]):
            continue  # the tool stands still (every axis moves the table): the nest rows place the tracker
        check_registration(nominal[sel], campaign.xyz[trk][sel], campaign.source, campaign.lines[trk][sel])


def check_same_pose(nominal: np.ndarray, predicted: np.ndarray, measured: np.ndarray, source: str,
                    model_source: str, rows: np.ndarray | None = None) -> None:
    """Refuse to judge a model on a campaign that is not a campaign of this machine
    (:func:`check_registration` of the nominal tool tips ``nominal``, machine frame) or
    whose points (tracker frame, [m]) lie far from where the model's fitted tracker pose
    puts the nominal tool tips (``predicted``): the tracker was moved. Judging it anyway
    gives a meaningless 'reduction' (the residual is the pose difference, metres)."""
    from vecpin.errors import CampaignFileError
    if spans_plane(nominal):  # on a line (one joint's sweep) nothing is registered: the distances alone are judged
        check_registration(nominal, measured, source, rows)
    d = np.linalg.norm(np.asarray(measured, float) - np.asarray(predicted, float), axis=1)
    d = d[np.isfinite(d)]
    if d.size and float(np.median(d)) > RESIDUAL_LIMIT:
        raise CampaignFileError(source, f"its points lie {np.median(d) * MM_PER_M:.1f} mm (median) from where the tracker "
                                f"pose of {model_source} puts them: the tracker was moved (give `reregister` to "
                                "register it to this campaign), or this is another machine's campaign")
