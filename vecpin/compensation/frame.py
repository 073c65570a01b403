"""The frame compensation keeps, for a model or a simulated truth (issue 39).

A rigid motion of the whole working volume is not observable from tracker data, so which
one the compensated machine keeps is a definition (:mod:`vecpin.measurement.partframe`):
the machine's ISO 230-1 reference lines where its table stands still, the mean orientation
of its volume where the table turns and on arms, and, where the campaign read the table's
face (nests at given heights), that face square to the spindle. :func:`model_as_actual`
gives a fitted model in that frame: everything that computes or judges tables from a model
uses it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vecpin.compensation.faceframe import TABLE_FACE_PRIOR, FaceTilt, setup_face
from vecpin.compensation.functions import FRAME, ActualMachine, geometric_model, nominal_tip, pseudo_commands
from vecpin.compensation.tableproblem import TableProblem
from vecpin.compensation.tables import TableSet
from vecpin.errors import VecpinError
from vecpin.kinematics.machine import Machine
from vecpin.kinematics.so3 import exp3, log3
from vecpin.measurement import partframe
from vecpin.measurement.campaign import PAPER_I_TOOLS_MM
from vecpin.measurement.registration import rigid_registration
from vecpin.measurement.tableface import sweep_ends
from vecpin.models import ErrorModel
from vecpin.models.recorded import recorded_box
from vecpin.units import MM_PER_M


LINE_COMMANDS = 600           # commands the reference lines are measured on (slopes: steady at a few hundred)
ORIENTATION_COMMANDS = 4000   # commands the mean orientation is measured on: on xyzac_trt the best-fit rotation of
                              # 600 quasi-random commands moves by 46-88 µrad from one set to the next, of 6000 by < 5


def reference_commands(machine: Machine, lower: np.ndarray | None = None, upper: np.ndarray | None = None,
                       n: int | None = None, seed: int = 0) -> np.ndarray:
    """Quasi-random commands [m, rad] over the box ``lower``..``upper`` (default the travel)
    where the machine's reference frame is measured (:mod:`vecpin.measurement.partframe`):
    ``n`` (default :data:`LINE_COMMANDS`) with every rotary axis at home (0, or the nearest
    end of the box) where it is defined by reference lines; :data:`ORIENTATION_COMMANDS`
    over the whole box where it is the volume's mean orientation."""
    lines = partframe.uses_lines(machine)
    q = pseudo_commands(machine, n or (LINE_COMMANDS if lines else ORIENTATION_COMMANDS), seed, lower, upper)
    if not lines:
        return q
    rot = [a.index for a in machine.axes if a.kind == "rotary"]
    lo = machine.lower if lower is None else lower
    hi = machine.upper if upper is None else upper
    q[:, rot] = np.clip(0.0, lo[rot], hi[rot])
    return q


@dataclass
class ReferenceFrame:
    """The machine's own reference frame, as tables keep it: ``R`` (3,3) takes the
    machine's tips (relative to the workpiece) about ``centre`` (3,) [m] into it; ``how``
    says how it is defined, in words (:func:`vecpin.measurement.partframe.reference_rotation`);
    ``hold_turn``: True where it is the volume's mean orientation, which the tables must
    not turn (:class:`~vecpin.compensation.tableproblem.TableProblem`'s ``hold_turn``);
    ``kind``: which definition, as :func:`frame_kept` measures the tables' turn against it:
    "lines" (ISO 230-1's reference lines), "orientation" (the volume's mean orientation),
    "face" (the table's face found by nests' heights or an indicator's sweeps) or "" (a frame
    given outright); ``face``: how well the face is known, where it is "face"
    (:class:`~vecpin.compensation.faceframe.FaceTilt`)."""

    R: np.ndarray
    centre: np.ndarray
    how: str
    hold_turn: bool = False
    kind: str = ""
    face: FaceTilt | None = None

    @property
    def angle(self) -> float:
        """The rotation's angle [rad]: how far the machine's frame is turned from where its tips are given."""
        return partframe.rotation_angle(self.R)

    def apply(self, points: np.ndarray) -> np.ndarray:
        """``points`` (N,3) [m], given where the machine's tips are, in this frame."""
        return (np.asarray(points, float) - self.centre) @ self.R.T + self.centre


def reference_frame(actual: ActualMachine, machine: Machine, tools, lower: np.ndarray | None = None,
                    upper: np.ndarray | None = None) -> ReferenceFrame:
    """The reference frame of the ``actual`` machine (a model or a simulated truth) from its
    tips at :func:`reference_commands` in the box ``lower``..``upper`` x ``tools`` [m], at
    every tool point (several spindles driven together share one frame)."""
    q = reference_commands(machine, lower, upper)
    tools = np.asarray(tools, float)
    P = len(machine.tool_links)
    qq = np.tile(np.repeat(q, len(tools), axis=0), (P, 1))
    tt = np.tile(tools, len(q) * P)
    pt = 0 if P == 1 else np.repeat(np.arange(P), len(q) * len(tools))
    tip = actual(qq, tt, False, pt)[0]
    R, how = partframe.reference_rotation(machine, qq, tt, nominal_tip(machine, qq, tt, pt), tip,
                                          partframe.spindle_axis(machine))
    lines = partframe.uses_lines(machine)
    return ReferenceFrame(R, tip.mean(axis=0), how, not lines, "lines" if lines else "orientation")


def in_reference_frame(actual: ActualMachine, frame: ReferenceFrame) -> ActualMachine:
    """The ``actual`` machine with its tips expressed in its reference frame ``frame``:
    tables fitted to it keep that frame (they do not turn the working volume against the
    machine's own reference lines, which a part on the table would see)."""
    def moved(q, tool, jacobian=False, point=0):
        tip, J = actual(q, tool, jacobian, point)
        return frame.apply(tip), (None if J is None else np.einsum("ij,njk->nik", frame.R, J))
    return moved


def model_as_actual(model: ErrorModel, tools=None, frame: "ReferenceFrame | None" = None) -> ActualMachine:
    """The fitted model as the 'actual' machine: the tool tip relative to the workpiece,
    no tracker, in the model's own reference frame (:func:`model_reference_frame`; the
    orientation the fit happened to settle in is not observable from tracker data, the
    machine's reference lines are). Only its geometry (:func:`geometric_model`), as tables
    cannot carry the rest. ``frame``: the model's reference frame when it is known already."""
    raw = _as_fitted(model)
    return in_reference_frame(raw, frame or model_reference_frame(model, raw, tools))


def _as_fitted(model: ErrorModel) -> ActualMachine:
    """The model's geometric part as the actual machine in the frame its fit settled in."""
    geometric = geometric_model(model)

    def raw(q, tool, jacobian=False, point=0):
        out = geometric.tool_tip(q, tool, geometric.b_, jacobian, frame=FRAME, point=point)
        return out.tip, out.J_q
    return raw


def fit_tools(model: ErrorModel) -> np.ndarray:
    """The shortest and the longest tool length [m] of the model's fit (Paper I's two when it
    records none): the tools the model's reference frame is measured with."""
    mm = list(getattr(getattr(model, "report_", None), "tool_lengths_mm", None) or PAPER_I_TOOLS_MM)
    return np.array([min(mm), max(mm)]) / MM_PER_M


def model_reference_frame(model: ErrorModel, raw: ActualMachine | None = None, tools=None) -> ReferenceFrame:
    """The reference frame of a fitted model (:func:`reference_frame`) over the commands its
    campaign measured (:func:`measured_box`) with ``tools`` [m] (default :func:`fit_tools`)."""
    raw = raw or _as_fitted(model)
    tools = fit_tools(model) if tools is None else tools
    box = measured_box(model)
    frame = reference_frame(raw, model.machine, tools, *box)
    setup = getattr(model, "setup_", None)
    if setup is not None and (len(setup.nest_heights) >= 3 or getattr(setup, "face_sweep", None)):
        lines = sweep_lines(raw, model.machine, frame, setup.face_sweep, box, float(np.min(tools)), model)
        frame = on_the_table_face(frame, model.machine, setup, lines=lines)
    return frame


def sweep_lines(actual: ActualMachine, machine: Machine, frame: ReferenceFrame, sweep: dict,
                box: tuple[np.ndarray, np.ndarray], tool: float, model: ErrorModel | None = None
                ) -> dict[str, tuple[np.ndarray, float]]:
    """{axis: ((3,) [m/m], variance [rad^2])}: the ``actual`` machine's (a model's, uncompensated)
    motion of the tip relative to the table per metre of each axis of ``sweep`` {axis: (distance
    [m], ...)}, in ``frame``, from the start to the end of the distance swept (an indicator reads
    its change between the two), centred on the middle of ``box`` (lower, upper) [m, rad] and
    clipped to it, every rotary axis at home (as the indicator's sweep is made), the other linear
    axes mid-box, tool length ``tool`` [m]; and the variance of its slope along the spindle against
    ``frame`` (0 without a model or without sweeps): from the fitted ``model``'s covariance (its
    geometric part's, through d tip / d b at both ends and the frame's own turn with b,
    :func:`_frame_turn_per_b`), plus the misfit its residuals cannot exclude at the two ends
    (:func:`misfit_variance`, taken independent: 2 m / D^2): the uncertainty of the line the
    sweep is read against, which limits the face (a DTI's 2 µm over 300 mm is 7 µrad)."""
    lo, hi = box
    rot = np.array([a.kind == "rotary" for a in machine.axes])
    mid = np.where(rot, partframe.home_commands(machine), 0.5 * (lo + hi))
    geometric = None if model is None else geometric_model(model)
    known = bool(sweep) and geometric is not None and getattr(geometric, "cov_", None) is not None
    up = -partframe.spindle_axis(machine)
    turn = _frame_turn_per_b(geometric, machine, frame, box, fit_tools(model)) if known else None
    misfit = misfit_variance(model) if known else 0.0
    out = {}
    for name, (distance, *_) in sweep.items():
        k = machine.axis_names.index(name)
        q = sweep_ends(mid, lo, hi, k, distance)
        if q[1, k] - q[0, k] < 1e-3:
            raise VecpinError(f"the sweep along {name}: the measured box spans {1e3 * (q[1, k] - q[0, k]):.3g} mm of "
                              f"{name}, too little to read the model's line there")
        tip = actual(q, np.full(2, tool), False, 0)[0]
        v = frame.R @ ((tip[1] - tip[0]) / (q[1, k] - q[0, k]))
        var = 0.0
        if known:
            J = geometric.tool_tip(q, np.full(2, tool), geometric.b_, jacobian=True, frame=FRAME).J_b
            g = (frame.R.T @ up) @ (J[1] - J[0]) / (q[1, k] - q[0, k])       # d (slope along up) / d b, frame held
            g = g + np.cross(v, up) @ turn            # and the frame's own turn with b: d w . (v x up)
            var = float(g @ geometric.cov_[6:, 6:] @ g) + 2.0 * misfit / (q[1, k] - q[0, k]) ** 2
        out[name] = (v, var)
    return out


MISFIT_Z = 2.0   # the misfit the fit's chi-square cannot exclude: its excess over the expected plus this many sigma


def misfit_variance(model: ErrorModel | None) -> float:
    """[m^2]: the variance per component of the model's misfit (what it leaves of the truth, besides
    the noise) that its fit's residuals cannot exclude: the residuals' power times the share of
    chi-square beyond its expected value, up to :data:`MISFIT_Z` sigma of its spread, per component
    (a third of the 3-D residual's mean square); 0 without a fit's report. The covariance of the
    parameters holds what the noise does to the model; this is what the model's structure may miss,
    and at the two ends of a line the misfit is taken independent (a line's slope over distance D:
    variance 2 m / D^2; a smooth misfit correlated over D gives less)."""
    rep = getattr(model, "report_", None)
    if rep is None or not rep.chi2 or not rep.residuals_mm.get("all"):
        return 0.0
    excess = max(rep.chi2 - rep.chi2_expected + MISFIT_Z * rep.chi2_sigma, 0.0) / rep.chi2
    return float(excess * (rep.residuals_mm["all"]["rms"] / MM_PER_M) ** 2 / 3.0)


TURN_COMMANDS = 1000   # commands the frame's turn per parameter is linearised on (the frame itself: its own count)


def _frame_turn_per_b(geometric, machine: Machine, frame: ReferenceFrame, box, tools) -> np.ndarray:
    """(3, P) [rad per unit of b]: the small rotation that takes the model's tips back into their
    reference frame (its definition: :func:`~vecpin.measurement.partframe.reference_rotation_changes`)
    per change of each geometric parameter, on :data:`TURN_COMMANDS` of :func:`reference_commands` x
    ``tools`` [m]. A line's slope against the frame moves with the line and with the frame: the
    frame is a mean over the volume (or the reference lines) of the same fitted model, so its
    error is correlated with the line's, and the slope's variance holds both."""
    q = reference_commands(machine, *box, n=TURN_COMMANDS)
    tools = np.asarray(tools, float)
    qq, tt = np.repeat(q, len(tools), axis=0), np.tile(tools, len(q))
    out = geometric.tool_tip(qq, tt, geometric.b_, jacobian=True, frame=FRAME)
    tips = frame.apply(out.tip)
    changes = np.einsum("ij,njp->pni", frame.R, out.J_b)             # (P, N, 3): each parameter's change, in frame
    return partframe.reference_rotation_changes(machine, qq, tt, tips, changes).T


def on_the_table_face(frame: ReferenceFrame, machine: Machine, setup, prior: float = TABLE_FACE_PRIOR,
                      lines: dict | None = None) -> ReferenceFrame:
    """``frame`` tilted toward the table's face square to the spindle, as far as the face is
    known: the face is the plane the fitted nests of ``setup`` (a fit's
    :class:`~vecpin.measurement.setup.Setup`) lie their given heights above (weighted least
    squares; three or more nests not on a line), read with their heights' standard deviations
    (a nest without one: the default gauge's) and the nests' z found with the fit's covariance;
    its tilt is combined with ``frame``'s (the frame without heights) weighted by their
    uncertainties (:func:`~vecpin.compensation.faceframe.setup_face`; ``prior``: the face's
    tilt against ``frame``, 1 sigma [rad]). The indicator's sweeps of ``setup.face_sweep``
    along the machine's lines of motion ``lines`` {axis: ((3,) [m/m] in ``frame``, the variance of
    its slope along the spindle [rad^2]): :func:`sweep_lines`} are weighed in with them
    (:func:`~vecpin.compensation.faceframe.face_tilt`).
    The turn about the spindle stays the frame's.
    Where a campaign reads the table this way the tables keep the table itself."""
    up = -partframe.spindle_axis(machine)
    ids, face = setup_face(setup, up, frame.apply, prior, lines)
    if face is None:
        swept = sorted(getattr(setup, "face_sweep", {}) or {})
        raise VecpinError(f"nest heights of {', '.join(ids) or 'no nest'}"
                          + (f" and an indicator swept along {' and '.join(swept)}" if swept else "")
                          + ": three or more fitted nests not on a line, or sweeps along two axes that cross, are "
                          "needed to find the table's face")
    e1, e2 = face.axes
    n = up + face.kept[0] * e1 + face.kept[1] * e2
    axis = np.cross(n / np.linalg.norm(n), up)            # |axis| = sin of the tilt
    sin = np.linalg.norm(axis)
    tilt = exp3(axis * np.arcsin(min(sin, 1.0)) / max(sin, 1e-300))
    nests = f" (nests {', '.join(ids)})" if face.n else ""
    return ReferenceFrame(tilt @ frame.R, frame.centre, frame.how + f"; tilted toward the table's face{nests}: "
                          + face.how, hold_turn=not face.decides,
                          kind="face", face=face)


def read_face(frame: ReferenceFrame) -> bool:
    """True where ``frame`` is the table's face as a campaign read it: found by readings
    that tell it at least as well as the frame without heights (:attr:`FaceTilt.decides`)."""
    return frame.kind == "face" and frame.face is not None and frame.face.decides


def measured_box(model: ErrorModel) -> tuple[np.ndarray, np.ndarray]:
    """The commands the model's campaign measured, per axis (lower, upper) [m, rad], where the
    tables are fitted: the whole travel for a model that does not record it, and for an axis
    held still (its tables cannot be fitted over one point: :func:`recorded_box`)."""
    return recorded_box(model, widen_still=True)


FRAME_COMMANDS = 1000  # commands of a plan on which the tables' turn of the volume is measured


@dataclass
class FrameKept:
    """How the tables keep the machine's frame: its definition (``how``), the angle [rad] by
    which the compensated volume is turned against it (measured as the frame is defined:
    :func:`tables_turn`), the largest correction the tables make at the tool tip and the
    largest error of the model [mm], and the note printed (``text``)."""

    how: str
    net_rotation: float
    largest_correction_mm: float
    largest_error_mm: float
    text: str

    @property
    def excessive(self) -> bool:
        """True when the tables move the tip by more than twice the largest error they remove."""
        return self.largest_correction_mm > 2.0 * self.largest_error_mm


def frame_kept(actual, m: Machine, tables: TableSet, problem: TableProblem, frame) -> FrameKept:
    """The frame the tables keep and what they do to it (on at most FRAME_COMMANDS of the plan's
    commands): :class:`FrameKept`."""
    rows = np.flatnonzero((np.arange(len(problem.q)) // len(problem.tools)) < FRAME_COMMANDS)
    q, L = problem.q[rows], problem.L[rows]
    pt = problem._pt if np.isscalar(problem._pt) else problem._pt[rows]
    nominal = nominal_tip(m, q, L + tables.gauge_offset_change, pt)
    before = actual(q, L, False, pt)[0]
    after = tables.turn_tips(m, tables.apply(q), actual(tables.apply(q), L, False, pt)[0], FRAME)
    angle, what = _turn(actual, m, tables, frame, q, L, pt, nominal, after)
    moved = after - before
    corr = float(np.linalg.norm(moved - moved.mean(axis=0), axis=1).max() * MM_PER_M)  # a translation is the origin's
    err = float(np.linalg.norm(partframe.part_frame_errors(nominal_tip(m, q, L, pt), before,
                                                           partframe.spindle_axis(m)), axis=1).max() * MM_PER_M)
    text = (f"frame kept: {frame.how}; the tables {what} {angle * 1e6:.1f} µrad against it; largest correction "
            f"at the tool tip {corr:.4f} mm (net of a translation) against a largest error of {err:.4f} mm")
    if frame.kind == "face":
        text += ("; a tilt against a table that turns is mostly beyond tables of one axis (what no table can follow)"
                 f"; {frame.face.known()}")
    kept = FrameKept(frame.how, angle, corr, err, text)
    if kept.excessive:
        kept.text += (": the tables move the tip by more than twice the largest error they remove; a rotation of "
                      "the volume or an offset of an axis' zero is being corrected that the model cannot tell from "
                      "the tracker's pose: check the model (vecpin evaluate) before writing these tables")
    return kept


def _turn(actual, m: Machine, tables: TableSet, frame: ReferenceFrame, q: np.ndarray, L: np.ndarray, pt,
          nominal: np.ndarray, after: np.ndarray) -> tuple[float, str]:
    """(angle [rad], what it is in words): the turn the tables give the compensated volume
    against the frame they keep, measured as that frame is defined (``nominal`` and
    ``after``: the nominal and the compensated tips (N,3) [m] of commands ``q`` x tools ``L``).
    Reference lines: the turn of the frame the primary and secondary axes' mean lines span,
    before to after, on ``q`` with every rotary axis at home (removing a squareness error
    turns the volume's best-fit orientation by about half the squareness while the lines
    stay: the best-fit rotation is not this turn). The table's face: the tilt (square to the
    spindle) of the compensated volume's best-fit rotation against the face. Otherwise the
    best-fit rotation of the compensated volume."""
    if frame.kind == "lines":
        q = q.copy()
        rot = [a.index for a in m.axes if a.kind == "rotary"]
        q[:, rot] = partframe.home_commands(m)[rot]
        home = nominal_tip(m, q, L, pt)
        R0 = partframe.reference_rotation(m, q, L, home, actual(q, L, False, pt)[0])[0]
        qc = tables.apply(q)
        R1 = partframe.reference_rotation(m, q, L, home, tables.turn_tips(m, qc, actual(qc, L, False, pt)[0], FRAME))[0]
        return partframe.rotation_angle(R1 @ R0.T), "turn the frame of the reference lines by"
    if frame.kind == "face":
        w = log3(rigid_registration(after, nominal)[0])
        s = partframe.spindle_axis(m)
        return float(np.linalg.norm(w - (w @ s) * s)), "tilt the compensated volume by"
    return partframe.net_rotation(nominal, after), "turn the working volume by"
