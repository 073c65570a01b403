"""Gross rows found before the noise level is taken from the data (issues 40 and 42).

When the user states no noise, the model choice takes the noise level from the
residuals of its best common candidate. Before it does, that candidate's linearised
full-data fit is made robust (:func:`vecpin.identification.robust.robust_fit`: Huber,
then rows beyond the Šidák limit at the robust level skipped), and the rows it skips
are the gross rows. What happens to them:

* **A few** (at most :data:`GROSS_SHARE` of the rows): they are left out of the choice
  and of the fit, and the printout names them by file line, with what to do. A metrologist
  re-measures a reading the tracker lost or a beam broke; a model is not made to absorb it.
* **Many, and they drive the level** (more than :data:`GROSS_SHARE` of the rows, and the
  plain noise scale, sqrt(chi2 / expected) of every row, more than :data:`NOISE_CAP` times
  the robust one): the run is refused, naming the rows, the target or tool or
  stretch of measurement order they share, and what to check. A target whose offset has
  the wrong sign, or a tracker bumped for a stretch of the campaign, is not noise, and
  leaving a tenth of a campaign out silently would be a guess.
* **Many, mildly beyond** (plain scale within :data:`NOISE_CAP` of the robust one): the
  noise is not of the stated shape, or the model misfits a region; the choice goes on with
  every row, as before (the diagnosis tells misfit from gross errors).

A campaign of more than ``MAX_SELECTION_ROWS`` rows is screened on the rows the choice
judges (its subsample, grouped by command).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.errors import InputError
from vecpin.identification.robust import FAMILY_ALPHA, RobustFit, robust_fit
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.registration import rigid_registration
from vecpin.measurement.setup import Setup

GROSS_SHARE = 0.05  # more gross rows than this share are not stray readings: a wrong setting or a moved tracker
# The plain noise scale may exceed the robust one by at most this factor before the rows beyond the limit
# are said to drive it: noise that is merely heavier-tailed than stated (a few rows beyond the Šidák limit)
# moves the plain scale by a few tens of percent; a 0.37 mm tracker bump on a fifth of the rows by 11x.
NOISE_CAP = 3.0
SHOWN = 12          # file lines named in a message
PULLED = 1.5        # the default registration is pulled when its median distance exceeds the robust one's this much
C_STEPS = 10        # concentration steps of the trimmed registration


class GrossRowsRefused(InputError):
    """Many rows far beyond the noise that drive its level: the fit is refused, naming them."""


@dataclass
class Screen:
    """The rows a robust fit skips: ``rows`` (indices of the campaign), ``lines`` (their
    file lines), ``plain`` and ``robust`` noise scales (sigma factors on the stated
    noise), ``text``: what the printout says of them."""

    rows: np.ndarray
    lines: np.ndarray
    plain: float
    robust: float
    text: str


def shown_lines(lines: np.ndarray) -> str:
    """'12, 40, 41 ...' or '100-140' (a run of consecutive lines), at most :data:`SHOWN` named."""
    lines = np.sort(np.asarray(lines, int))
    if lines.size > 3 and lines[-1] - lines[0] == lines.size - 1:
        return f"{lines[0]}-{lines[-1]}"
    return ", ".join(map(str, lines[:SHOWN])) + (" ..." if lines.size > SHOWN else "")


def what_they_share(campaign: Campaign, rows: np.ndarray) -> str:
    """What the rows have in common that points at a cause: all rows of one target or
    tool (its offset or length: a sign flipped?), or a run in measurement order (the
    tracker moved?); '' when nothing."""
    rows = np.sort(np.asarray(rows, int))
    for name, col, what in (("target", campaign.target.astype(str), "its offset in the targets file (a flipped sign?)"),
                            ("tool", np.round(campaign.tool * 1e3, 3).astype(str), "its length (a flipped sign, a "
                             "wrong tool?)")):
        for v in np.unique(col[rows]):
            if not v or v == "nan":
                continue
            own = np.flatnonzero(col == v)
            there = np.intersect1d(own, rows)
            if there.size >= 0.8 * rows.size and there.size >= 0.5 * own.size and own.size < len(campaign):
                label = f"{name} {v}" + (" mm" if name == "tool" else "")
                return f"{there.size} of them are rows of {label} ({there.size} of its {own.size} rows): check {what}"
    if rows.size >= 3 and rows[-1] - rows[0] + 1 <= 2 * rows.size:
        return ("they were measured one after another: did the tracker move (a bump) or lose its reference during "
                "that stretch? re-measure them, or re-register the tracker for them")
    return ""


def screen_rows(J: np.ndarray, w: np.ndarray, valid: np.ndarray, x0: np.ndarray, judged: Campaign,
                campaign: Campaign) -> Screen | None:
    """The gross rows of ``campaign`` by the robust fit of the linearised problem (``J``,
    ``w``, ``valid``, ``x0``: :func:`~vecpin.identification.robust.robust_fit`) of the rows
    ``judged`` (``campaign`` or its subsample); None when there are none, or when they are
    many but do not drive the level (module text). Refuses (InputError) when they are many
    and drive it."""
    fit = robust_fit(J, w, valid, x0, n_rows=len(campaign))
    if not fit.beyond.size:
        return None
    rows = (fit.beyond if judged is campaign
            else np.flatnonzero(np.isin(campaign.lines, judged.lines[fit.beyond])))
    share = fit.beyond.size / len(judged)
    if share > GROSS_SHARE and fit.ratio <= NOISE_CAP:
        return None
    lines = campaign.lines[rows]
    said = _said(fit, campaign, rows, lines)
    if share > GROSS_SHARE:
        raise GrossRowsRefused(
            f"{campaign.source}: {said}. So many rows far beyond the noise are not stray readings, and vecpin will "
            f"neither scale the noise to them nor leave {share:.0%} of the campaign out on its own: correct the "
            "setting they share, or re-measure or remove those rows; to fit them as they are, state the noise "
            "(`repeatability_mm`, `tracker_noise`, ...)")
    text = (f"{said}. They are left out of the model choice and the fit"
            + ("" if "check" in said else "; re-measure them, or check the tracker log for a broken beam"))
    return Screen(rows, lines, float(np.sqrt(fit.plain)), float(np.sqrt(fit.level)), text)


def _said(fit: RobustFit, campaign: Campaign, rows: np.ndarray, lines: np.ndarray) -> str:
    """The sentence naming the gross rows: how many, their file lines, the two noise
    scales, what they share."""
    share = what_they_share(campaign, rows)
    return (f"{rows.size} rows (file lines {shown_lines(lines)}) are gross errors: beyond the limit at which a "
            f"clean campaign of {len(campaign)} rows has any row with probability {FAMILY_ALPHA:g}, at the robust "
            f"level of the other rows' residuals from a first model ({np.sqrt(fit.level):.2f} x the stated noise); "
            f"with them the noise from the data would be {np.sqrt(fit.plain):.2f} x the stated noise"
            + (f"; {share}" if share else ""))


def trimmed_registration(setup: Setup, r: np.ndarray, xyz: np.ndarray, rows: np.ndarray) -> Setup | None:
    """Station 0's tracker pose registered on the half of its point rows ``rows`` that fit
    it best (least trimmed squares by :data:`C_STEPS` concentration steps), from the
    default pose ``setup`` and the rows' metric residuals ``r`` (N,3) [m] at the nominal
    machine under it; None when the default pose is not pulled (its median distance
    within :data:`PULLED` of the trimmed one's): every row steers the registration, and a
    target whose offset has the wrong sign steers it tens of millimetres off, so that the
    linearised problem no longer fits the other rows either."""
    if rows.size < 8:
        return None
    x = xyz[rows]
    P = (x - r[rows] - setup.t) @ setup.R         # the rows' nominal points in the machine frame
    R, t = setup.R, setup.t
    d0 = np.linalg.norm(P @ R.T + t - x, axis=1)
    d = d0
    for _ in range(C_STEPS):
        half = np.argsort(d)[: rows.size // 2]
        R, t = rigid_registration(P[half], x[half])
        d = np.linalg.norm(P @ R.T + t - x, axis=1)
    if np.median(d0) <= PULLED * np.median(d):
        return None
    return Setup(R, t)
