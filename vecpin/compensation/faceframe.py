"""How well the nests' heights and an indicator's sweeps place the table's face, and what the tables keep of it.

The fit finds the table nests' reflector centres, not the table's face; the heights the
operator reads above the face (:mod:`vecpin.measurement.nestheights`) place it: the face is
the plane the nests lie their heights above. A height gauge reads each height to about
0.02 mm, and nests 0.1-0.2 m from the table's axis turn that into a tilt of the estimated
face of 50-100 µrad: as large as what the face is tilted against the frame vecpin keeps
without heights. So the face is an estimate with an uncertainty, and it is combined with the
frame without heights as a metrologist combines two estimates of one quantity:

- **The face from the heights** (:func:`face_tilt`): the plane ``z_i - h_i = c - a x_i - b y_i``
  through the nests' positions (x, y square to the spindle, z along it, in the frame without
  heights) by weighted least squares, each nest weighted by 1 / (its height reading's variance
  + the variance of its fitted position square to the face, from the fit's covariance; the two
  taken independent, and the nests independent of each other: their correlation through the
  fit's gauge is left out). The slopes' covariance is the weighted fit's ``(A' W A)^-1``: it
  falls with the nests' spread about their centre, so nests far from the table's axis tell the
  face better. Tilt = slope for the small angles here: about e1 by b, about e2 by -a.
- **The face from an indicator swept across it** (:func:`sweep_rows`; the readings of
  :mod:`vecpin.measurement.tableface`): a dial test indicator in the spindle, every rotary
  axis at zero, touches the face while one linear axis moves it a distance D; the change r
  (+ pushed in) is the face's slope against that axis' line of motion. The sweep is made with
  the machine's own, uncompensated axes, so it reads the face against the uncompensated lines;
  the fitted model knows those lines in the frame without heights (the tip's motion per metre
  of the axis' command, the rotaries at home, the other axes mid-box:
  :func:`~vecpin.compensation.frame.sweep_lines`), so each sweep is one linear reading of the
  face's slopes in that frame: ``a v.e1 + b v.e2 = -r / D - v.up``, with the variance
  (sd / D)^2 of the reading plus that of the model's line along the spindle against the frame
  (a DTI reads 1-2 µm over a few hundred mm: a few µrad; the model's line at home is known to
  10-20 µrad on the bundled table machines, where the heights give 70-150). What limits the
  face is the model's line at home against the volume's mean: on the simulator's trunnion,
  head-table and all-table machines the face from a noise-free sweep differs from the truth's
  by exactly the model's error in that line (its slope along up, model less truth, each in its
  own reference frame), the same at every height and within a few µrad along the other axis:
  the line is wrong where the sweep is made, not the sweep made in the wrong place. The line's
  variance (:func:`~vecpin.compensation.frame.sweep_lines`) holds the fit's covariance of the
  line and of the frame it is read in (the frame is the same model's mean, so their errors are
  correlated), and the misfit the fit's residuals cannot exclude
  (:func:`~vecpin.compensation.frame.misfit_variance`), which the covariance leaves out. The
  1 sigma printed is the RMS length of the tilt's error, sqrt(trace) of its covariance: the tilt
  is judged as one angle, and its largest direction alone understates it by up to sqrt 2
  (benchmarks/bench_part_frame.py measures the ratio). The sweeps and the nests' plane are weighed together by their
  inverse covariances (the nests' plane as one reading of both slopes with covariance C), and
  that one face of the readings is what the prior is combined with below; a sweep alone (no
  heights) fixes the tilt where two axes that cross are swept, the nests still give the origin.
  Where the nests' plane and the sweeps disagree beyond chance (chi-square, 99 %) the printout
  says so.
- **The frame without heights** (the machine's reference lines or its volume's mean
  orientation, :func:`~vecpin.compensation.frame.model_reference_frame`) as the prior of the
  face's tilt: zero, with a standard deviation :data:`TABLE_FACE_PRIOR` per component. ISO
  10791 (machining centres: the geometric tests of part 1, horizontal spindle, and part 2,
  vertical spindle) checks at acceptance that the table's surface is parallel to the X and Y
  motions (:data:`PARALLELISM_TOLERANCE`, 0.025 mm over 500 mm) and that the axes are square
  (:data:`SQUARENESS_TOLERANCE`, 0.020 mm over 500 mm); the values as recalled for the usual
  table sizes, not taken from the standard's text here. A machine that passed is known to lie
  within them and nothing more: a bound, taken as a rectangular distribution (GUM 4.3.7, as the
  height gauge's stated accuracy is in :mod:`vecpin.measurement.nestheights`), sigma = bound /
  sqrt(3). The frame without heights is the volume's mean orientation on a turning table, which
  a squareness error turns by about half of it (docs/results/part_frame.md), so
  ``sqrt((P / sqrt 3)^2 + (S / 2 / sqrt 3)^2)`` = 31 µrad per component. It is a constant a
  user changes (``prior`` of :func:`~vecpin.compensation.frame.on_the_table_face`). The first
  version took 50 µrad as one standard deviation ("the tolerance with room"); the bound's
  rectangular reading replaced it after a look at 4 generator draws (the commit log says so),
  not fitted to them.
- **Combined** (the posterior of a normal prior and a normal measurement): slopes
  ``P (P + C)^-1 s`` with covariance ``P (P + C)^-1 C``; heights read well (C small) give the
  face, heights read badly give the frame without heights. When the two disagree beyond chance
  (``s' (P + C)^-1 s`` above the 99 % point of chi-square with 2 degrees of freedom) the prior
  is what is contradicted (a table outside the acceptance tolerance): the face from the heights
  is kept alone, and the printout says so.

The tables are then fitted in the combined frame (:func:`~vecpin.compensation.plan.plan_tables`).
Where the heights count at least half (:attr:`FaceTilt.decides`: they tell the face at least as
well as the frame without heights) the campaign has read the face: product terms are offered by
default and, written, hold the volume's tilt against it at zero (one-axis tables are the
least-squares fit there). Where they count less, the tables keep the combined frame as they keep
the frame without heights (their turn of the volume held at zero, no product terms by default):
as the heights' weight falls to zero the tables become those without heights, so heights read
badly cannot cost more than the small tilt they still carry. The printout gives the face's 1 sigma
tilt uncertainty (the RMS length of the tilt's error), with advice when it is above :data:`FACE_TARGET`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.measurement.nestheights import GAUGE_SD_MM
from vecpin.units import M_PER_MM, MM_PER_M

PARALLELISM_TOLERANCE = 0.025 / 500   # rad: ISO 10791, the table's surface parallel to X's and Y's motions
SQUARENESS_TOLERANCE = 0.020 / 500    # rad: ISO 10791, the axes square to each other
TABLE_FACE_PRIOR = float(np.hypot(PARALLELISM_TOLERANCE, SQUARENESS_TOLERANCE / 2) / np.sqrt(3))   # rad, 1 sigma
FACE_TARGET = 50e-6        # rad: the face's 1 sigma tilt uncertainty the printout asks for (issue 39: 50 µrad)
CONSISTENT_CHI2 = 9.2103   # chi-square, 2 degrees of freedom, 99 %: face and prior agree within it
FLOOR_SD = 1e-9            # m: a reading's standard deviation at least this (exact heights: equal weights)
FLOOR_TILT = 1e-9          # rad: a slope reading's standard deviation at least this where readings are weighed together


@dataclass
class FaceTilt:
    """The table's face from the nests' heights and the indicator sweeps, and what the tables
    keep of it, in a frame whose ``axes`` (e1, e2) are square to the spindle: ``slopes`` (2,)
    [rad] of the face from the readings alone (its normal is up + a e1 + b e2) with covariance
    ``cov`` (2,2) [rad^2], of which ``from_nests`` (2,2) is the fitted nests' share; ``kept``,
    ``kept_cov``: the same combined with the frame without heights (module text);
    ``consistent``: False where the two disagree beyond chance (the face kept alone); ``prior``
    [rad]; ``spread`` [m^2]: the smallest eigenvalue of the nests' layout about their centre,
    square to the spindle; ``reading_sd`` [m]: the heights' rms standard deviation; ``n``:
    nests whose heights count (0: none); ``swept``: the axes swept with an indicator;
    ``agree``: False where the nests' face and the sweeps disagree beyond chance (99 %)."""

    axes: tuple
    slopes: np.ndarray
    cov: np.ndarray
    from_nests: np.ndarray
    kept: np.ndarray
    kept_cov: np.ndarray
    consistent: bool
    prior: float
    spread: float
    reading_sd: float
    n: int
    swept: tuple = ()
    agree: bool = True

    @property
    def sources(self) -> str:
        """Which readings set the face, in words."""
        parts = ([f"the heights of {self.n} nests"] if self.n else []) + (
            [f"an indicator swept along {' and '.join(self.swept)}"] if self.swept else [])
        return " and ".join(parts)

    @staticmethod
    def _tilt(cov: np.ndarray) -> np.ndarray:
        J = np.array([[0.0, 1.0], [-1.0, 0.0]])    # slopes (a, b) -> tilt about (e1, e2): (b, -a)
        return J @ cov @ J.T

    @property
    def tilt_cov(self) -> np.ndarray:
        """(2,2) [rad^2]: the covariance of the face's tilt about (e1, e2) from the readings alone."""
        return self._tilt(self.cov)

    @property
    def kept_tilt_cov(self) -> np.ndarray:
        """(2,2) [rad^2]: the covariance of the tilt of the face the tables keep."""
        return self._tilt(self.kept_cov)

    @property
    def sd(self) -> float:
        """The face's 1 sigma tilt uncertainty from the readings alone [rad]: the RMS length of the
        tilt's error, sqrt(trace(cov)) (what a tilt judged as one angle, its two components together,
        is expected to be; the largest direction alone understates it by up to sqrt 2)."""
        return _magnitude_sd(self.cov)

    @property
    def kept_sd(self) -> float:
        """The kept face's 1 sigma tilt uncertainty [rad]: the RMS length of its error (as :attr:`sd`)."""
        return _magnitude_sd(self.kept_cov)

    @property
    def weight(self) -> float:
        """The share of the readings' face in the face kept (0: the frame without heights, 1: the face alone)."""
        if not self.consistent:
            return 1.0
        P = self.prior ** 2 * np.eye(2)
        return float(np.trace(P @ np.linalg.inv(P + self.cov)) / 2)

    @property
    def decides(self) -> bool:
        """True where the heights tell the face at least as well as the frame without heights
        does (:attr:`weight` 1/2 or more, or the two disagree): the campaign has read the face,
        and the tables keep it as a read face (product terms offered by default, which carry a
        tilt fixed to the turning table). Else the tables keep the combined frame as they keep
        the frame without heights (its turn held, no product terms by default): a face known
        worse than the prior is not one to carry."""
        return self.weight >= 0.5

    @property
    def how(self) -> str:
        """The face and the frame kept, in words: which readings set it, its 1 sigma, their weight."""
        tilt = float(np.hypot(*self.slopes)) * 1e6
        clash = "" if self.agree else (" (the nests' heights and the indicator's sweeps disagree beyond chance: "
                                       "check both)")
        if not self.consistent:
            return (f"the face from {self.sources} is tilted {tilt:.0f} µrad (±{self.sd * 1e6:.0f}, 1σ) against the "
                    f"frame without heights, beyond the {self.prior * 1e6:.0f} µrad (1σ) an accepted table's face is "
                    f"expected within: the face is kept as the readings give it (check the "
                    f"{'readings' if self.swept else 'heights'} and the table){clash}")
        return (f"the face from {self.sources} tilted {tilt:.0f} µrad (±{self.sd * 1e6:.0f}, 1σ) against the frame "
                f"without heights, that frame's tilt against an accepted table's face ±{self.prior * 1e6:.0f} µrad "
                f"(1σ): weighted by their uncertainties, the readings count {100 * self.weight:.0f} %" + (
                    "" if self.decides else ", less than the frame without heights: the tables hold their turn of "
                    "the volume as without heights (no product terms by default)") + clash)

    def known(self) -> str:
        """The face's tilt uncertainty as printed [µrad] (:meth:`advice` beside it when above :data:`FACE_TARGET`)."""
        return (f"the table's face known to ±{self.sd * 1e6:.0f} µrad from {self.sources} (1σ tilt), "
                f"±{self.kept_sd * 1e6:.0f} µrad as kept")

    @property
    def needs_advice(self) -> bool:
        """True when the face's tilt uncertainty from the readings is above :data:`FACE_TARGET`."""
        return self.sd > FACE_TARGET

    def advice(self) -> str:
        """What would bring the face's tilt uncertainty to :data:`FACE_TARGET`: an indicator swept
        across the face (where none was), the nests farther from the table's axis, or the heights
        read better (the fitted nests' share as it is)."""
        head = f"the face's tilt ±{self.sd * 1e6:.0f} µrad (1σ) is above the {FACE_TARGET * 1e6:.0f} µrad target"
        sweep = ("sweep the face with a dial test indicator in the spindle along X and Y, the rotary axes at zero "
                 "(table_face.csv, `table_face`: the face then known to 10-30 µrad on the simulated table machines)")
        if self.swept:
            return (f"{head}: sweep the indicator along two axes that cross, over a longer distance, and read it to "
                    "1-2 µm")
        room = FACE_TARGET ** 2 - _magnitude_sd(self.from_nests) ** 2   # what the readings may add (a trace)
        if room <= 0:
            return (f"{head}, and the fitted nests' heights alone are that uncertain: {sweep}; or more nest readings, "
                    "or nests farther from the table's axis")
        radius = self.reading_sd * np.sqrt(4.0 / self.n / room)      # n nests evenly on a circle: trace 4 sd^2 / n r^2
        gauge = np.sqrt(room * self.spread / 2)                       # the readings' sd that meets it at these nests
        return (f"{head}: {sweep}; or place the {self.n} nests farther from the table's "
                f"axis, evenly at {radius * MM_PER_M:.0f} mm from it where the table allows (the heights read to "
                f"{self.reading_sd * MM_PER_M:.3f} mm), or read the heights to {gauge * MM_PER_M:.3f} mm (1σ)")


def _magnitude_sd(cov: np.ndarray) -> float:
    """sqrt(trace(cov)) [rad]: the RMS length of a 2-vector error with covariance ``cov``."""
    return float(np.sqrt(max(np.trace(cov), 0.0)))


def nest_z_cov(setup, ids: list[str]) -> np.ndarray:
    """(N,N) [m^2]: the covariance of the fitted nests ``ids``' z coordinates (workpiece frame),
    from ``setup.nest_z_cov`` where the fit left it, else their standard deviations alone
    (``setup.std``: a shift of them all, which no tilt sees, then counts as tilts: larger)."""
    full = getattr(setup, "nest_z_cov", None) or {}
    where = {k: i for i, k in enumerate(full.get("ids", []))}
    if all(k in where for k in ids):
        idx = [where[k] for k in ids]
        return np.asarray(full["cov"], float)[np.ix_(idx, idx)]
    return np.diag([setup.std.get(f"nest{k}.z", 0.0) ** 2 for k in ids])


def setup_face(setup, up: np.ndarray, place=None, prior: float = TABLE_FACE_PRIOR, lines: dict | None = None
               ) -> tuple[list[str], FaceTilt | None]:
    """(ids, face) of a fitted setup's readings of the table's face: ``ids`` the nests with a
    height and a fitted position (sorted), ``face`` :func:`face_tilt` of their positions
    ``setup.nests`` (workpiece frame [m], mapped by ``place`` (N,3) -> (N,3) into the frame the
    face is wanted in, default as fitted), ``setup.nest_heights`` and ``setup.nest_height_sd``
    [m], the fitted z covariance (:func:`nest_z_cov`) and the indicator sweeps
    ``setup.face_sweep`` along the lines of motion ``lines`` {axis: ((3,) [m/m], in the same
    frame, the variance of its slope along the spindle [rad^2], added to the reading's)} (a sweep
    without its line is left out); None where the readings do not fix the face."""
    ids = sorted(k for k in setup.nest_heights if k in setup.nests)
    sweep = {a: (lines[a][0], d, r, float(np.sqrt(sd ** 2 + lines[a][1] * d ** 2)))   # the line's own variance added
             for a, (d, r, sd) in sorted(getattr(setup, "face_sweep", {}).items()) if a in (lines or {})}
    if len(ids) < 3 and not sweep:
        return ids, None
    P = np.array([setup.nests[k] for k in ids], float).reshape(-1, 3)
    P = P if place is None or not len(P) else place(P)
    return ids, face_tilt(P, up, [setup.nest_heights[k] for k in ids], [setup.nest_height_sd.get(k) for k in ids],
                          nest_z_cov(setup, ids) if ids else None, prior, sweep)


def face_axes(up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(e1, e2): the two unit directions square to ``up`` the face's slopes are given along."""
    e1 = np.cross(up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(up, e1)


def sweep_rows(sweep: dict, up: np.ndarray, e1: np.ndarray, e2: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(H (k,2), y (k,) [rad], var (k,) [rad^2]): the indicator sweeps ``sweep`` {axis: (v (3,)
    the tip's motion per metre of the axis' command relative to the table, in the frame the face
    is wanted in [m/m]; distance D [m]; change r [m], + pushed in; its sd [m])} as readings of the
    face's slopes (a, b) (:func:`face_tilt`). The tip moves D v; the face height under it changes
    by -D (a v.e1 + b v.e2), the tip's own height by D v.up, so the gap closes by r = -D (v.up + a
    v.e1 + b v.e2): a v.e1 + b v.e2 = -r / D - v.up, with variance (sd / D)^2."""
    H, y, var = [], [], []
    for v, D, r, sd in sweep.values():
        v = np.asarray(v, float)
        H.append([v @ e1, v @ e2])
        y.append(-r / D - v @ up)
        var.append((sd / D) ** 2)
    return np.array(H, float).reshape(-1, 2), np.array(y, float), np.array(var, float)


def _nests_plane(P: np.ndarray, up: np.ndarray, e1: np.ndarray, e2: np.ndarray, heights, sds, nest_cov):
    """(slopes, cov, from_nests, spread, reading_sd) of the nests' plane (:func:`face_tilt`), None
    for fewer than three nests or nests on a line."""
    reading = np.array([GAUGE_SD_MM * M_PER_MM if s is None else float(s) for s in sds], float)
    C_nest = np.zeros((len(P), len(P))) if nest_cov is None else np.asarray(nest_cov, float)
    w = 1.0 / np.maximum(reading ** 2 + np.diag(C_nest), FLOOR_SD ** 2)
    A = np.column_stack([P @ e1, P @ e2, -np.ones(len(P))])
    if len(P) < 3 or np.linalg.matrix_rank(A, tol=1e-6 * max(np.abs(A).max(), 1e-12)) < 3:
        return None
    G = np.linalg.solve(A.T @ (w[:, None] * A), A.T * w)[:2]    # slopes = G (h - z): the weighted plane fit
    slopes = G @ (np.asarray(heights, float) - P @ up)
    from_nests = G @ C_nest @ G.T                                # a shift of every nest: G's rows see none
    cov = G @ np.diag(reading ** 2) @ G.T + from_nests
    xy = A[:, :2] - A[:, :2].mean(axis=0)
    return (slopes, 0.5 * (cov + cov.T), 0.5 * (from_nests + from_nests.T), float(np.linalg.eigvalsh(xy.T @ xy).min()),
            float(np.sqrt(np.mean(reading ** 2))))


def face_tilt(P: np.ndarray, up: np.ndarray, heights, sds, nest_cov=None, prior: float = TABLE_FACE_PRIOR,
              sweep: dict | None = None) -> FaceTilt | None:
    """The face the nests at ``P`` (N,3) [m] lie ``heights`` (N,) [m] above, read with
    standard deviations ``sds`` (N,) [m; None: :data:`~vecpin.measurement.nestheights.GAUGE_SD_MM`],
    the nests' positions along ``up`` (the spindle's opposite) found with covariance
    ``nest_cov`` (N,N) [m^2; None: exact], and the indicator sweeps ``sweep`` (:func:`sweep_rows`;
    None or empty: none), combined with the prior ``prior`` [rad] (module text); None when
    the readings do not fix both slopes (fewer than three nests or nests on a line, and no
    sweep of two axes that cross)."""
    P = np.asarray(P, float).reshape(-1, 3)
    e1, e2 = face_axes(up)
    plane = _nests_plane(P, up, e1, e2, heights, sds, nest_cov) if len(P) else None
    sweep = sweep or {}
    if not sweep:
        if plane is None:
            return None
        slopes, cov, from_nests, spread, reading_sd = plane
        agree = True
    else:   # the readings weighed by their inverse covariances (information form), then with the prior as below
        H, y, var = sweep_rows(sweep, up, e1, e2)
        rows = [(H, y, np.diag(var))]
        if plane is not None:
            rows.append((np.eye(2), plane[0], plane[1]))
        info, rhs, inv = np.zeros((2, 2)), np.zeros(2), []
        for Hk, yk, Rk in rows:
            Wk = np.linalg.inv(Rk + FLOOR_TILT ** 2 * np.eye(len(yk)))
            info += Hk.T @ Wk @ Hk
            rhs += Hk.T @ Wk @ yk
            inv.append(Wk)
        if np.linalg.eigvalsh(info).min() <= 1e-12 * max(np.abs(info).max(), 1e-300):
            return None
        cov = np.linalg.inv(info)
        slopes = cov @ rhs
        misfit = sum(float((yk - Hk @ slopes) @ Wk @ (yk - Hk @ slopes)) for (Hk, yk, _), Wk in zip(rows, inv))
        dof = sum(len(yk) for _, yk, _ in rows) - 2
        from scipy.stats import chi2   # only where sweeps are read: not on every fit's import path
        agree = dof <= 0 or misfit <= chi2.ppf(0.99, dof)
        from_nests, spread, reading_sd = (np.zeros((2, 2)), 0.0, 0.0) if plane is None else plane[2:]
        cov = 0.5 * (cov + cov.T)
    Pr = prior ** 2 * np.eye(2)
    S = Pr + cov
    consistent = bool(slopes @ np.linalg.solve(S, slopes) <= CONSISTENT_CHI2)
    if consistent:
        gain = Pr @ np.linalg.inv(S)
        kept, kept_cov = gain @ slopes, gain @ cov
        kept_cov = 0.5 * (kept_cov + kept_cov.T)
    else:
        kept, kept_cov = slopes.copy(), cov.copy()
    return FaceTilt((e1, e2), slopes, cov, from_nests, kept, kept_cov, consistent, prior, spread, reading_sd,
                    len(P) if plane is not None else 0, tuple(sweep), agree)
