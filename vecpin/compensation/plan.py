"""From a fitted model to the tables a controller holds (one call).

Full tables when the controller takes them all (AP: eq. 17 when the gauge-line change
is applied, no axis is held and no geometric effect is non-zero; else, and for 6-DoF:
projection, eq. 18-19); otherwise the best admissible subset (Paper II), re-solved on the model.
The controller enters only as :class:`~vecpin.compensation.limits.ControllerLimits`
(plain data the export layer resolves from a controller name and profile), so this
layer knows no file format.

The report is honest about what it is: every row is the *model-predicted* volumetric
error on the same points (quasi-random or campaign commands x tool lengths), and
each compensated row carries the spread of that prediction over the model's
parameter uncertainty (draws from its covariance ``cov_``): a full table set that
cancels the model to 0.0002 mm is still only as good as the model on the machine.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from vecpin.compensation.functions import (FRAME, all_table_names, from_ap_model, geometric_model, hold_ranges,
                                           nominal_tip, pitch_names, pseudo_commands, rich_table_bases, table_bases)
from vecpin.compensation.tableproblem import TableProblem
from vecpin.compensation.products import prediction_noise, product_candidates, products_wanted, with_products
from vecpin.compensation.follow import Unfollowed, unfollowed
from vecpin.compensation.frame import (LINE_COMMANDS, FrameKept, ReferenceFrame, fit_tools, frame_kept, measured_box,
                                       model_as_actual, model_reference_frame, read_face, reference_commands)
from vecpin.compensation.report import CompensationReport, compensated_errors, part_and_shape
from vecpin.compensation.limits import NO_LIMITS, ControllerLimits
from vecpin.compensation.selection import Selection, exact_search, genetic_search, impact_heuristic
from vecpin.compensation.tables import TableSet
from vecpin.errors import InputError, VecpinError
from vecpin.kinematics.machine import Machine
from vecpin.models import APModel, ErrorModel
from vecpin.planning.zones import clip_to_zone
from vecpin.units import MM_PER_M, from_mm
from vecpin.measurement.campaign import PAPER_I_TOOLS_MM
from vecpin.measurement import partframe
from vecpin.threads import one_blas_thread

MAX_TABLE_TOOLS = 4  # tool lengths the table problem is posed on (two fix position and orientation)
METHODS = ("exact", "ga", "heuristic")
HOLD_MARGIN = 0.02  # unmeasured share of an axis' travel at an end beyond which tables are held constant
#: the parameter-uncertainty spread and the subset search under a controller's table limit (statistics
#: over the commands, ranking sets) use at most the first this many of the pseudo-commands (a quasi-random
#: sequence's first ones cover the space as the whole does); the chosen tables are fitted on all of them
SUBSET_COMMANDS = 1000
REFERENCE_TOLERANCE = 1e-8  # rad: a model turned less than this from its reference frame is in it


@dataclass
class TablePlan:
    """Tables for one controller: the set to write, the selection (None when every
    table fits), the report, the linearised problem and the limits it obeyed."""

    tables: TableSet
    limits: ControllerLimits
    selection: Selection | None
    report: CompensationReport
    problem: TableProblem
    points: int
    frame: FrameKept | None = None
    reference: ReferenceFrame | None = None  # the model's reference frame the tables keep
    unfollowed: Unfollowed | None = None     # what the full tables leave of the model's error, and why
    written: str = ""                        # the label of the report row of ``tables`` (the set to write)


def covariance_kind(model: ErrorModel) -> str:
    """'full' when the model carries its parameter covariance, 'diagonal' when only
    standard deviations survive (a model read from a file)."""
    cov = model.cov_
    return "diagonal" if np.count_nonzero(cov - np.diag(np.diag(cov))) == 0 else "full"


EQUATIONS_PER_COEFFICIENT = 40  # pseudo-measurement equations per table coefficient (see table_commands)
MIN_TABLE_COMMANDS = 1000


def table_commands(machine: Machine, n_tools: int, modulo_axes=()) -> int:
    """How many pseudo-commands the full table set of ``machine`` is fitted on, each read
    with ``n_tools`` tool lengths. Tables are separable and a machine's errors are not:
    the part no table follows acts on the least-squares fit of the p table coefficients
    as noise does, and the fitted tables miss the best ones by about that part times
    sqrt(p / m) at m = 3 x commands x tools equations. With m >= 40 p that loss stays
    below 16 % of the part (about 1 % of the compensated error; on a five-axis machine
    1000 commands cost about 4 %); at least 1000 commands."""
    p = len(machine.axes) * sum(b.size for b in rich_table_bases(machine, tuple(modulo_axes)))
    return max(MIN_TABLE_COMMANDS, int(np.ceil(EQUATIONS_PER_COEFFICIENT * p / (3 * max(n_tools, 1)))))


def parameter_spread(model: ErrorModel, tables: TableSet | None, q: np.ndarray, tool: np.ndarray,
                     draws: int = 200, seed: int = 0, point=0, frame: ReferenceFrame | None = None
                     ) -> tuple[float, float, float]:
    """Mean volumetric error [mm] in the part's frame of ``tables`` on machines that differ
    from the model by its parameter uncertainty: (mean over draws, 16th and 84th percentile).

    Each draw is ``b_ + db`` with ``db ~ N(0, cov_b)``; the compensated error is
    linearised around the model, ``e(b_ + db) = e(b_) + J_b db`` (tool tip relative to the
    workpiece at the compensated commands, nominal with the changed T_offset). Each drawn
    machine is taken into its own reference frame (its reference lines move with the
    draw: :func:`~vecpin.measurement.partframe.reference_rotation_changes`, which also
    removes the orientation the tracker pose absorbs) and judged as a part set up on it sees
    it (translation and rotation about the spindle removed, linearised). The draws are
    seeded: reruns print the same figures. Only the model's geometric part counts
    (:func:`~vecpin.compensation.functions.geometric_model`): tables carry no more.
    ``frame``: the model's reference frame when it is known already."""
    model = geometric_model(model)
    m = model.machine
    frame = frame or model_reference_frame(model)
    q = np.atleast_2d(np.asarray(q, float))
    tool = np.broadcast_to(np.asarray(tool, float), (len(q),))
    if tables is None:
        qc, nominal = q, nominal_tip(m, q, tool, point)
    else:
        qc, nominal = tables.apply(q), nominal_tip(m, q, tool + tables.gauge_offset_change, point)
    out = model.tool_tip(qc, tool, model.b_, jacobian=True, frame=FRAME, point=point)
    tip = frame.apply(out.tip)
    J_b = np.einsum("ij,njp->nip", frame.R, out.J_b)
    cov = np.asarray(model.cov_, float)[6:, 6:]
    w, U = np.linalg.eigh(0.5 * (cov + cov.T))
    F = U * np.sqrt(np.clip(w, 0.0, None))                    # cov = F F^T
    z = np.random.default_rng(seed).standard_normal((draws, F.shape[1])) @ F.T  # (S, P)
    e = (tip - nominal).ravel()[None] + z @ J_b.reshape(3 * len(q), -1).T   # (S, 3N)
    # each draw in its own reference frame: its lines measured where the model's were
    qr = reference_commands(m, *measured_box(model), n=LINE_COMMANDS)   # the draws' changes: a linear functional
    tr = fit_tools(model)
    qq, tt = np.repeat(qr, len(tr), axis=0), np.tile(tr, len(qr))
    ref = model.tool_tip(qq, tt, model.b_, jacobian=True, frame=FRAME)
    Jr = np.einsum("ij,njp->nip", frame.R, ref.J_b)
    ref_tip = frame.apply(ref.tip)
    dw = partframe.reference_rotation_changes(m, qq, tt, ref_tip, np.einsum("nip,sp->sni", Jr, z))
    e = (e.reshape(draws, -1, 3) + np.cross(dw[:, None, :], tip - frame.centre)).reshape(draws, -1)
    Q = partframe.part_motion_basis(nominal, partframe.spindle_axis(m))
    flat = e - (e @ Q) @ Q.T
    means = np.linalg.norm(flat.reshape(draws, -1, 3), axis=2).mean(axis=1) * MM_PER_M
    return float(means.mean()), float(np.percentile(means, 16)), float(np.percentile(means, 84))


@one_blas_thread
def plan_tables(model: ErrorModel, limits: ControllerLimits | None = None, *, max_tables: int | None = None,
                no_circular: bool | None = None, forbid_output=(), points: int | None = None, method: str = "exact",
                n_commands: int | None = None, tools_mm=None, table_order: int | None = None, seed: int = 0,
                modulo_axes=(), commands: np.ndarray | None = None, uncertainty: bool = True,
                zone: dict | None = None, progress=None, products: bool | None = None) -> TablePlan:
    """Compensation tables of a fitted model under a controller's ``limits``
    (None: no controller limit, vecpin's generic files).

    ``points`` per table (default: the controller's, at most 1024). The pseudo-measurements are
    ``commands`` [m, rad] (e.g. a campaign's) or ``n_commands`` quasi-random ones (default
    :func:`table_commands`: enough for the number of table coefficients), each with every tool
    length (``tools_mm``, default the fit's). ``modulo_axes``: rotary input axes whose tables cover one turn
    and repeat. ``uncertainty``: add the parameter-uncertainty spread to each row.
    ``zone``: {axis: (low, high)} mm/deg, fit the tables in this region only (a machine
    calibrated in zones, seed Section 2.6), within what the model's campaign measured.
    ``products``: :mod:`~vecpin.compensation.products` on, off, None: its default. Limits checked before solving."""
    lim, say = _limits(limits), progress or (lambda text: None)
    model._check_fitted()
    model, left_out = _geometric(model)
    req = _request(model, lim, max_tables, no_circular, forbid_output, points, method, modulo_axes, tools_mm,
                   commands, n_commands)
    frame = model_reference_frame(model)
    actual = model_as_actual(model, frame=frame)
    m = model.machine
    offer, held_back, product_line = products_wanted(products, lim, read_face(frame), m, req.cons is not None)
    problem, where, hold, lo, hi, q, tools = _table_problem(model, actual, frame, req, modulo_axes, commands,
                                                            n_commands, seed, zone, offer, not held_back)
    unmeasured = _unmeasured(m, hold)
    gauge_note = _gauge_significance(model, problem, pitch_names(m) if req.pitch_only else all_table_names(m))
    report = CompensationReport(basis=f"model-predicted volumetric error at {where} x tools "
                                      f"{', '.join(f'{t:g}' for t in req.tools_mm)} mm (every row on these points), "
                                      "in the part's frame; shape: the best rigid motion removed as well:")
    with_spread = uncertainty and covariance_kind(model) == "full"
    spread_rows = np.flatnonzero((np.arange(len(problem.q)) // len(problem.tools)) % len(q) < SUBSET_COMMANDS)
    rows: dict[int, tuple] = {}   # id of a table set -> (the set, kept alive; its report row; its errors)

    def add(label, ts, n):  # the spread, a statistic over the commands, on at most SUBSET_COMMANDS of them
        pt = problem._pt if np.isscalar(problem._pt) else problem._pt[spread_rows]
        spread = parameter_spread(model, ts, problem.q[spread_rows], problem.L[spread_rows],
                                  point=pt, frame=frame) if with_spread else None
        part, shape = part_and_shape(actual, m, ts, problem.q, problem.L, point=problem._pt)
        report.add(label, part, n, spread, shape=shape)
        rows[id(ts)] = (ts, report.rows[-1], part)
        return part

    before = add("uncompensated (model)", None, 0)
    say("solving the full table set")
    full = _full_tables(model, problem, frame, bool(unmeasured), modulo_axes, hold, req.n_points)
    after = add("full tables (model-predicted)" if not req.pitch_only else f"full tables (not loadable on {lim.name})",
                full, len(full.tables))
    full = _with_products(problem, lim, full, after, add, req.n_points, report, held_back, product_line, model, frame)
    left = _unfollowed(model, problem, before, after, full, rows[id(full)][2])
    pitch = problem.solve(pitch_names(m)).discretise(req.n_points)
    add("pitch only (model-predicted)", pitch, len(pitch.tables))
    selection, tables = None, (pitch if req.pitch_only or req.only_pitch_note else full)
    if req.cons is not None:
        say(f"choosing {req.cons.max_tables} of the {m.n_axes * (m.n_axes - 1)} cross tables ({method})")
        search = TableProblem(actual, m, q[:SUBSET_COMMANDS], tools, modulo_axes=tuple(modulo_axes), hold=hold,
                              hold_turn=frame.hold_turn, bases=table_bases(m, table_order or 8, "fourier",
                                                                           tuple(modulo_axes), lo, hi))
        search.free_gauge = problem.free_gauge
        as_held = None if lim.hold is None else (lambda ts: lim.hold(ts, m))   # judged as the controller holds them
        selection = SEARCHES[method](search, req.cons, seed, req.n_points, as_held)
        tables = problem.solve(pitch_names(m) + selection.tables).discretise(req.n_points)
        add(f"{method}: {' '.join(selection.tables)} (model-predicted)", tables, len(tables.tables))
    lim.check_tables(tables)
    fold_note = None
    if modulo_axes:   # what folding onto one turn costs: the same tables over the whole travel, on the same points
        say(f"solving the same tables over the whole travel of {', '.join(modulo_axes)} (not modulo)")
        written = rows[id(tables)][1]   # the row of the set written, before the unfolded row is added
        flat = _unfolded(actual, m, q, tools, lo, hi, problem.free_gauge, problem.hold_turn).solve(tables.names())
        add(unfolded_label(modulo_axes), flat.discretise(req.n_points), len(tables.tables))
        fold_note = _fold_note(m, modulo_axes, written.mean, report.rows[-1].mean)
    kept = frame_kept(actual, m, tables, problem, frame)
    advice = [f"table's face: {frame.face.advice()}"] if frame.face is not None and frame.face.needs_advice else []
    report.notes += ([fold_note] if fold_note else []) + [kept.text] + advice + _notes(
        model, with_spread, uncertainty, gauge_note, left_out, req, unmeasured) + [left.line()]
    report.notes += [_held_note(selection, lim.name)] if selection is not None and selection.held else []
    return TablePlan(tables, lim, selection, report, problem, req.n_points, kept, frame, left,
                     rows[id(tables)][1].label)


def _unfollowed(model: ErrorModel, problem: TableProblem, before, one_axis, full: TableSet, written) -> Unfollowed:
    """What no table can follow: what the full set ``full`` (its errors ``written`` (N,3) [m]) leaves of the model's
    errors ``before``, after its product terms where it carries any (``one_axis``: the one-axis set's errors)."""
    terms = " ".join(p.name for p in full.products)
    return unfollowed(model.machine, problem.q, problem.L, before, written, model.report_.residuals_mm["all"]["mean"],
                      terms, one_axis if terms else None)


def _with_products(problem: TableProblem, lim: ControllerLimits, full: TableSet, after, add, n_points: int,
                   report: CompensationReport, held_back: str, line: str, model: ErrorModel, frame: ReferenceFrame):
    """The full set with the product terms ``model``'s campaign supports (:func:`.products.with_products`)."""
    if problem.products:
        noise = prediction_noise(model, problem, frame.R) if covariance_kind(model) == "full" else None
        full = with_products(problem, lim, full, after, add, n_points, report.notes, held_back, noise,
                             problem.hold_turn and not frame.hold_turn)
    report.notes += [line] if line else []
    return full


def _unmeasured(m: Machine, hold: dict) -> dict:
    """The axes whose held range {axis: (low, high)} [m, rad] stops short of their travel."""
    return {a: v for a, v in hold.items() if v[0] > m.axis(a).lower + HOLD_MARGIN * m.axis(a).travel
            or v[1] < m.axis(a).upper - HOLD_MARGIN * m.axis(a).travel}


def _limits(limits) -> ControllerLimits:
    """The controller's limits, or none (vecpin's generic files); a controller's name refused with the way."""
    if limits is not None and not isinstance(limits, ControllerLimits):
        raise InputError(f"plan_tables takes ControllerLimits, not {limits!r}: resolve a controller name with "
                         "vecpin.export.registry.get_format(name).limits")
    return limits or NO_LIMITS


def _full_tables(model: ErrorModel, problem: TableProblem, frame: ReferenceFrame, unmeasured: bool, modulo_axes,
                 hold, n_points: int) -> TableSet:
    """The full table set: eq. 17 (the AP model's perturbations are the tables) only when the
    perturbations are the whole model (a geometric effect, a gantry skew, is not in them),
    nothing is held, the gauge line is free and the model's own frame is its reference
    frame (eq. 17 cancels the perturbations in the frame the fit settled in, which a
    rotation of the volume, absorbed by the tracker pose, leaves undefined); else the projection."""
    effects_on = any(np.any(model.b_[sl] != 0) for _, sl in model.effect_slices())
    if (isinstance(model, APModel) and not unmeasured and problem.free_gauge and not effects_on
            and frame.angle < REFERENCE_TOLERANCE):
        return from_ap_model(model, modulo_axes, hold).discretise(n_points)
    return problem.solve(all_table_names(model.machine)).discretise(n_points)


def unfolded_label(modulo_axes) -> str:
    """The report row of the written set's tables fitted over the whole travel of the modulo axes."""
    return f"same tables, {', '.join(modulo_axes)} over the whole travel (not modulo; model-predicted)"


def _unfolded(actual, m: Machine, q: np.ndarray, tools: np.ndarray, lo: np.ndarray, hi: np.ndarray,
              free_gauge: bool, hold_turn: bool) -> TableProblem:
    """The table problem of :func:`_table_problem` without modulo axes: every rotary
    input's table over its travel (the measured part of it, held beyond)."""
    problem = TableProblem(actual, m, q, tools, hold=hold_ranges(m, lo, hi, ()), hold_turn=hold_turn,
                           bases=rich_table_bases(m, (), lower=lo, upper=hi))
    problem.free_gauge = problem.free_gauge and free_gauge
    return problem


def _fold_note(m: Machine, modulo_axes, folded_mm: float, flat_mm: float) -> str:
    """What the modulo tables (mean error ``folded_mm``) cost against the same tables over
    the whole travel (``flat_mm``)."""
    travel = ", ".join(f"{a} {m.axis(a).lower_user:g} .. {m.axis(a).upper_user:g} deg" for a in modulo_axes)
    loss = f"{100 * (folded_mm / flat_mm - 1):+.0f} %" if flat_mm > 0 else "-"
    return (f"modulo tables ({', '.join(modulo_axes)}: one turn, repeating) fold the errors of the whole travel "
            f"({travel}) onto one turn: the set written leaves {folded_mm:.4f} mm, the same tables over the whole "
            f"travel {flat_mm:.4f} mm ({loss}; model-predicted)")


def _held_note(selection: Selection, controller: str) -> str:
    """What judging the search's best sets as the controller holds them did."""
    chosen = next(h for (names, _, _), h in zip(selection.finalists, selection.held) if names == selection.tables)
    first = selection.finalists[int(np.argmin([mean for _, _, mean in selection.finalists]))]
    text = (f"selection: the {len(selection.held)} best sets by the linearised score judged as {controller} holds them "
            f"(its files written and read back, on the search's commands): the set chosen leaves {chosen:.4f} mm as "
            f"held, {selection.mean_mm:.4f} mm as planned")
    if first[0] != selection.tables:
        held_first = selection.held[selection.finalists.index(first)]
        text += (f"; the best as planned, {' '.join(first[0])} ({first[2]:.4f} mm), would leave {held_first:.4f} mm "
                 "as held")
    return text


SEARCHES = {"exact": lambda p, c, seed, n, hold: exact_search(p, c, n_points=n, hold=hold),
            "ga": lambda p, c, seed, n, hold: genetic_search(p, c, seed=seed, n_points=n),
            "heuristic": lambda p, c, seed, n, hold: impact_heuristic(p, c, n_points=n)}


def _geometric(model: ErrorModel) -> tuple[ErrorModel, list[str]]:
    """The model's geometric part (tables carry geometry) and advice for the row-dependent
    effects it leaves out."""
    if not model.row_dependent:
        return model, []
    std = model.std_
    left_out = [f"{e.label} is not in the tables (it depends on the rows, not the position): "
                + "; ".join(e.advice(model.b_[sl], std[sl])) for e, sl in model.effect_slices() if not e.geometric]
    return model.geometric_part()[0], left_out


@dataclass
class _Request:
    """A table request checked against the controller and the model, before any solve."""

    n_points: int
    pitch_only: bool
    cons: object | None
    only_pitch_note: str | None
    tools_mm: list[float]
    tools_note: str | None


def _request(model, lim, max_tables, no_circular, forbid_output, points, method, modulo_axes, tools_mm,
             commands, n_commands) -> _Request:
    """Everything a user can get wrong, checked before any heavy work."""
    m = model.machine
    n_points = lim.points(points)
    if method not in METHODS:
        raise InputError(f"`method` {method}: choose one of {', '.join(METHODS)}")
    for a in forbid_output:
        m.axis(a)
    _check_modulo(model, modulo_axes)
    pitch_only = not lim.cross_tables
    need_subset = not pitch_only and (max_tables is not None or bool(no_circular) or bool(forbid_output)
                                      or lim.needs_selection(m.axis_names))
    cons, only_pitch_note = None, None
    if pitch_only and max_tables:
        lim.constraints(max_tables, axis_names=m.axis_names)  # raises: this controller takes no cross tables
    if need_subset:
        cons = lim.constraints(max_tables, no_circular, tuple(forbid_output), axis_names=m.axis_names)
        if cons.max_tables == 0 or not cons.candidates(m.axis_names):
            only_pitch_note = ("`max_tables` 0" if cons.max_tables == 0 else "every cross table is forbidden "
                               "(`forbid_output` and the controller's rules)") + ": pitch tables only"
            cons = None
    tools_mm, tools_note = _table_tools(model, tools_mm)
    if commands is None and n_commands is not None and n_commands < 1:
        raise InputError(f"n_commands {n_commands}: give at least one command")
    return _Request(n_points, pitch_only, cons, only_pitch_note, tools_mm, tools_note)


def _check_modulo(model: ErrorModel, modulo_axes) -> None:
    m = model.machine
    for a in modulo_axes:
        ax = m.axis(a)
        if ax.kind != "rotary":
            raise InputError(f"`modulo_axes` {a}: only rotary axes have modulo tables, not the linear axis {a}")
        if ax.upper_user - ax.lower_user < 360.0 - 1e-9:
            raise InputError(f"`modulo_axes` {a}: {a} travels {ax.upper_user - ax.lower_user:g} deg "
                             f"({ax.lower_user:g} .. {ax.upper_user:g}), less than a turn, so a table over one turn "
                             f"that repeats does not apply; leave out `modulo_axes` {a} (its table spans the travel)")
        if isinstance(model, APModel) and model.bases[ax.index].kind != "fourier":
            raise VecpinError(f"a modulo table on {a} must repeat every turn, but the model's basis on {a} is not "
                              "periodic: fit with `basis` auto (Fourier on rotary axes travelling more than a turn)")


def _table_tools(model: ErrorModel, tools_mm) -> tuple[list[float], str | None]:
    """The tool lengths [mm] the tables are fitted with (given, or the fit's), and a note
    when a tool column measured row by row gave too many."""
    if tools_mm is not None:
        t = np.asarray(tools_mm, float)
        if t.size == 0 or not np.all(np.isfinite(t)) or t.min() < 0 or t.max() > 10_000:
            raise InputError(f"`tools_mm` {' '.join(f'{v:g}' for v in t)}: tool lengths are mm from the gauge line, "
                             "0 .. 10000 (e.g. 214.88 312.86)")
    tools_mm = list(tools_mm or getattr(model.report_, "tool_lengths_mm", None) or PAPER_I_TOOLS_MM)
    note = None
    if len(tools_mm) > MAX_TABLE_TOOLS:  # a tool column measured row by row: as many lengths as rows
        lo, hi = float(min(tools_mm)), float(max(tools_mm))
        note = (f"{len(tools_mm)} different tool lengths in the fit: the tables are fitted on {MAX_TABLE_TOOLS} "
                f"spanning {lo:g} .. {hi:g} mm (give `tools_mm` to choose)")
        tools_mm = [float(v) for v in np.linspace(lo, hi, MAX_TABLE_TOOLS)]
    if len(tools_mm) < 2:
        tools_mm = tools_mm + [t + 100.0 for t in tools_mm]  # two lengths fix position and orientation
    return tools_mm, note


def _table_problem(model: ErrorModel, actual, frame: ReferenceFrame, req: _Request, modulo_axes, commands,
                   n_commands: int, seed: int, zone, products: bool = False, written: bool = False):
    """(problem, where, hold ranges, lower, upper, commands, tools): the table problem on the
    measured box (or zone). Table functions that can follow any model (splines finer than
    its functions) over that box: every spline has pseudo-commands under it, and beyond
    the box the functions are held constant, exactly - a table must not extrapolate what
    was never measured. The subset search works on a cheaper Chebyshev problem over the
    same box; the chosen set is re-solved on this one. ``products``: with product-term columns;
    ``written``: they will be written. In the table's-face frame with product terms written the
    tables hold the compensated volume's turn against the face at 0 (``hold_turn``): they can carry a
    tilt fixed to the turning table, and least squares would otherwise leave up to 60 µrad of it for a
    smaller error elsewhere (xyzac_trt), which a part clamped on the face sees. One-axis tables cannot
    carry most of such a tilt: held, it would cost the part more than it leaves (trunnion_xyzac 0.031 ->
    0.041 mm), so they leave what least squares leaves, as every one-axis set does."""
    m = model.machine
    lo, hi = measured_box(model)
    if zone:
        zl, zh = clip_to_zone(m, zone)
        lo, hi = np.maximum(lo, zl), np.minimum(hi, zh)
        if np.any(hi < lo):
            a = m.axes[int(np.argmax(hi < lo))]
            raise InputError(f"`zone`: the zone's interval of {a.name} lies outside what the model's campaign measured "
                             f"({a.to_user(measured_box(model)[0][a.index]):g} .. "
                             f"{a.to_user(measured_box(model)[1][a.index]):g} {a.unit})")
    if commands is None:
        n_commands = n_commands or table_commands(m, len(req.tools_mm), tuple(modulo_axes))
        q = pseudo_commands(m, n_commands, seed, lo, hi)
        where = f"{len(q)} quasi-random commands in the measured region"
    else:
        q = np.unique(np.asarray(commands, float), axis=0)
        where = f"{len(q)} campaign commands"
    tools = from_mm(np.array(req.tools_mm, float))
    hold = hold_ranges(m, lo, hi, tuple(modulo_axes))
    terms = product_candidates(m) if products and req.cons is None and not (req.pitch_only or
                                                                            req.only_pitch_note) else []
    problem = TableProblem(actual, m, q, tools, hold=hold, modulo_axes=tuple(modulo_axes), products=terms,
                           hold_turn=frame.hold_turn or (read_face(frame) and bool(terms) and written),
                           bases=rich_table_bases(m, tuple(modulo_axes), lower=lo, upper=hi))
    return problem, where, hold, lo, hi, q, tools


def _notes(model, with_spread: bool, uncertainty: bool, gauge_note: str, left_out: list[str], req: _Request,
           unmeasured: dict) -> list[str]:
    """The report's notes: the spread column, the gauge line, what the tables leave out."""
    m = model.machine
    notes = []
    if with_spread:
        notes.append("last column: mean over 200 seeded draws of the parameters from the model's covariance, "
                     "compensated error linearised around the model, each draw in its own reference frame and "
                     "judged in the part's frame; [16th, 84th percentile]")
    elif uncertainty:
        notes.append("no parameter uncertainty: this model carries standard deviations only (a model file "
                     "of an earlier vecpin kept no correlations), and without them the spread would be "
                     "meaningless; refit to get it")
    notes.append(gauge_note)
    notes += left_out
    notes += [n for n in (req.only_pitch_note, req.tools_note) if n]
    if unmeasured:
        notes.append("measured range: tables held constant beyond the commands the campaign measured on "
                     + ", ".join(f"{a} ({m.axis(a).to_user(v[0]):g} .. {m.axis(a).to_user(v[1]):g} "
                                 f"{m.axis(a).unit})" for a, v in unmeasured.items())
                     + ": a table must not extrapolate what was never measured")
    fit_res = model.report_.residuals_mm["all"]
    notes.append(f"the model's own fit residual (measured, on the campaign's points, not these): mean "
                 f"{fit_res['mean']:.4f} mm, max {fit_res['max']:.4f} mm - the compensated machine cannot be "
                 "expected to do better than the model fits it")
    return notes


def _gauge_significance(model: ErrorModel, problem: TableProblem, names) -> str:
    """Decide whether the gauge-line (T_offset) change is applied: only when it is at
    least twice its standard deviation from the model's parameter covariance."""
    if problem.along_tool:
        return (f"gauge-line (T_offset) change: not used, {', '.join(problem.along_tool)} moves along the tool and its "
                "pitch table carries the same correction")
    x = problem.solve_linear(names)
    cov_b = np.asarray(model.cov_, float)[6:, 6:]
    J_b = model.tool_tip(problem.q, problem.L, model.b_, jacobian=True, frame=FRAME, point=problem._pt).J_b
    sd = problem.gauge_std(names, J_b, cov_b)
    dT = float(x[0])
    kind = "" if covariance_kind(model) == "full" else " (standard deviations only: the file kept no correlations)"
    if abs(dT) >= 2 * sd:
        return (f"gauge-line (T_offset) change of the full table set {dT * MM_PER_M:+.4f} ± {sd * MM_PER_M:.4f} "
                f"mm{kind}: significant, applied (the value to enter is the one of the tables written, above)")
    problem.free_gauge = False
    return (f"gauge-line (T_offset) change of the full table set {dT * MM_PER_M:+.4f} ± {sd * MM_PER_M:.4f} "
            f"mm{kind}: not significant (below 2 standard deviations), not applied")


def gauge_effect(plan: TablePlan, model: ErrorModel, tables: TableSet | None = None) -> dict[str, float]:
    """The model-predicted mean error [mm] of ``tables`` (default: the plan's) on the plan's
    points with their gauge-line (T_offset) change ``dT`` entered as it is ('entered'),
    not entered ('none': the controller keeps its tool lengths) and entered with the other
    sign ('flipped'): what the datum and its sign are worth. Only the model's geometric
    part is judged, as in :func:`plan_tables`."""
    tables = plan.tables if tables is None else tables
    model = geometric_model(model)
    actual = model_as_actual(model, frame=plan.reference)   # the frame the plan's tables keep, found once
    dT = tables.gauge_offset_change
    out = {}
    for key, value in (("entered", dT), ("none", 0.0), ("flipped", -dT)):
        ts = dataclasses.replace(tables, gauge_offset_change=value)
        err = compensated_errors(actual, model.machine, ts, plan.problem.q, plan.problem.L, point=plan.problem._pt)
        out[key] = float(np.linalg.norm(err, axis=1).mean() * MM_PER_M)
    return out


def add_as_written_row(plan: TablePlan, model: ErrorModel, tables: TableSet, label: str) -> None:
    """Add the row of the tables as a controller will hold them (read back from the
    written files: resampled, rounded, constants removed), on the plan's points. Only
    the model's geometric part is judged, as in :func:`plan_tables`."""
    model = geometric_model(model)
    actual = model_as_actual(model, frame=plan.reference)   # in the frame the plan's tables keep
    pt = plan.problem._pt
    err, shape = part_and_shape(actual, model.machine, tables, plan.problem.q, plan.problem.L, point=pt)
    with_spread = any(r.spread is not None for r in plan.report.rows)
    spread = (parameter_spread(model, tables, plan.problem.q, plan.problem.L, point=pt, frame=plan.reference)
              if with_spread else None)
    plan.report.add(label, err, len(tables.tables), spread, shape=shape)

