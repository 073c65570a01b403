"""A model file checked against what it records, before anything is written from it.

A model file is plain JSON: a parameter multiplied by 1000 (an edit, a unit slip in a
script that wrote it) reads like any other number and would give corrections of hundreds
of millimetres. Three checks, in this order, each refusing with the reason:

* every parameter within :data:`PRIOR_FACTOR` times its prior scale (the prior is the
  physically plausible size of the term; a fit pays (value/prior)^2 for it, so a fitted
  value at 20 priors is not what a fit of a machine gives);
* the model's own uncompensated figure, recomputed from the parameters on the file's check
  commands (:func:`check_figure`: :data:`CHECK_COMMANDS` fixed quasi-random commands in the
  measured range with the fit's tools, part's frame), equal to the figure the file records
  (``check``, written by :func:`check_figure` when the model is saved) within
  :data:`FIGURE_TOLERANCE`;
* that figure at most :data:`MEASURED_FACTOR` times the uncompensated error the campaign
  measured (``selection.uncompensated_mm``, when the file records it).
"""
from __future__ import annotations

import math

import numpy as np

from vecpin.errors import ModelFileError, VecpinError
from vecpin.measurement.partframe import part_frame_errors, spindle_axis
from vecpin.units import MM_PER_M, norm_mm

PRIOR_FACTOR = 20.0       # a parameter beyond this many prior scales is refused
CHECK_COMMANDS = 128      # commands of the check figure (x the fit's tools)
FIGURE_TOLERANCE = 0.01   # relative; plus FIGURE_ABS_MM
FIGURE_ABS_MM = 1e-4
MEASURED_FACTOR = 10.0    # the model's uncompensated mean at most this many times the measured one


STILL_SHARE = 1e-6   # an axis whose recorded range spans less than this share of its travel stood still


def recorded_box(model, widen_still: bool) -> tuple[np.ndarray, np.ndarray]:
    """The commands the model's campaign measured, per axis (lower, upper) [m, rad], as its
    fit recorded them (the whole travel for an axis the model does not record). An axis that
    stood still (less than :data:`STILL_SHARE` of its travel) is the one position it stood
    at, or with ``widen_still`` its whole travel (tables cannot be fitted over one point)."""
    m = model.machine
    rng = getattr(getattr(model, "report_", None), "measured_range", None) or {}
    lo, hi = m.lower.copy(), m.upper.copy()
    for a in m.axes:
        if a.name in rng:
            lo[a.index], hi[a.index] = sorted(float(a.to_si(v)) for v in rng[a.name])
            if widen_still and hi[a.index] - lo[a.index] < STILL_SHARE * a.travel:
                lo[a.index], hi[a.index] = a.lower, a.upper
    return lo, hi


def still_axes(model) -> list:
    """The axes of ``model``'s machine that stood still in its campaign (their recorded
    range spanning less than :data:`STILL_SHARE` of their travel, :func:`recorded_box`)."""
    lo, hi = recorded_box(model, widen_still=False)
    return [a for a in model.machine.axes if hi[a.index] - lo[a.index] < STILL_SHARE * a.travel]


def still_hold(model) -> tuple[np.ndarray, np.ndarray] | None:
    """(lower, upper) [m, rad] per axis for the model's ``range_``: every axis that stood
    still in its campaign (:func:`still_axes`) held at the one position it stood at, the
    others free (infinite bounds); None when every axis moved. The campaign cannot tell how
    a still axis' errors change, so the correction there is held constant: no slope a
    series or its priors would extrapolate beyond the one position measured."""
    still = still_axes(model)
    if not still:
        return None
    lo, hi = recorded_box(model, widen_still=False)
    free = np.ones(model.machine.n_axes, bool)
    free[[a.index for a in still]] = False
    return np.where(free, -np.inf, lo), np.where(free, np.inf, hi)


PRIMES = (2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47)


def scrambled_halton(d: int, n: int, seed: int = 0) -> np.ndarray:
    """(n, d) in [0, 1): the first ``n`` points of scipy's ``qmc.Halton(d, scramble=True, seed=seed)``,
    bit for bit (Owen's randomised Halton: per dimension a van der Corput sequence in the next
    prime base, each digit permuted by one of ``ceil(54 / log2(base)) - 1`` shuffles drawn from
    ``numpy.random.default_rng(seed)`` in turn). Written here because importing ``scipy.stats``
    takes about a second, more than a fit of a few hundred rows; tests/test_recorded_halton.py
    holds it to scipy's."""
    if d > len(PRIMES) or not isinstance(seed, (int, np.integer)):
        raise ValueError(f"at most {len(PRIMES)} dimensions and a whole-number seed")
    rng = np.random.default_rng(seed)
    out = np.zeros((n, d))
    for k, base in enumerate(PRIMES[:d]):
        perms = np.repeat(np.arange(base)[None], math.ceil(54 / math.log2(base)) - 1, axis=0)
        for perm in perms:
            rng.shuffle(perm)
        q, scale = np.arange(n), 1.0 / base
        for perm in perms:
            out[:, k] += perm[q % base] * scale
            q, scale = q // base, scale / base
    return out


def check_commands(model) -> tuple[np.ndarray, np.ndarray]:
    """(q (N,n) [m, rad], tool (N,) [m]): :data:`CHECK_COMMANDS` scrambled-Halton commands
    (seed 0) in the fit's measured range (the axis limits where the file has none), each
    with every tool of the fit (0 without tools)."""
    m = model.machine
    rep = getattr(model, "report_", None)
    lo, hi = recorded_box(model, widen_still=False)
    u = scrambled_halton(m.n_axes, CHECK_COMMANDS, seed=0)
    q = lo + u * (hi - lo)
    tools = [float(t) / MM_PER_M for t in (getattr(rep, "tool_lengths_mm", None) or [0.0])]
    return np.repeat(q, len(tools), axis=0), np.tile(np.asarray(tools), len(q))


def check_figure(model) -> dict | None:
    """The model's uncompensated error on its check commands (:func:`check_commands`) [mm]:
    the modelled tip against the nominal one relative to the workpiece, a part's set-up (a
    translation and a turn about the spindle) removed, mean and max; what the file records
    as ``check``. None for a model with effects that depend on the rows (time, temperature:
    no row, no figure; its parameters are still held against their priors)."""
    q, tool = check_commands(model)
    m = model.machine
    nominal = m.tool_tip(q, tool, frame="workpiece")
    try:
        err = model.predict(q, tool, frame="workpiece")
    except VecpinError:
        return None
    d = norm_mm(part_frame_errors(nominal, nominal + err, spindle_axis(m)))
    return {"mean_mm": float(d.mean()), "max_mm": float(d.max()), "commands": int(len(q)),
            "meaning": "the model's uncompensated error on fixed quasi-random commands in the measured range with "
                       "the fit's tools, part's frame (recomputed and compared when the file is read)"}


def check_parameters(path, parameters: list[dict]) -> None:
    """Refuse a parameter beyond :data:`PRIOR_FACTOR` times its prior (file's units)."""
    for p in parameters:
        v, prior = p.get("value"), p.get("prior")
        if not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (v, prior)) or prior <= 0:
            continue
        if abs(v) > PRIOR_FACTOR * prior:
            unit = p.get("unit", "")
            raise ModelFileError(path, f"parameter {p.get('name')} is {v:g} {unit}, {abs(v) / prior:.0f} times its "
                                 f"prior scale {prior:g} {unit} (a fitted value stays within a few; beyond "
                                 f"{PRIOR_FACTOR:g} is refused): the file was edited or written in other units "
                                 "(x1000?); nothing is written from it: fit the model again", "parameters")


def check_recorded(model, d: dict, path) -> None:
    """The model built from file ``d`` against what the file records (module docstring)."""
    check_parameters(path, d.get("parameters") or [])
    recorded = d.get("check")
    measured = (d.get("selection") or {}).get("uncompensated_mm") if isinstance(d.get("selection"), dict) else None
    if not isinstance(recorded, dict) and not isinstance(measured, dict):
        return
    fig = check_figure(model)
    if fig is None:
        return
    if isinstance(recorded, dict):
        want = recorded.get("mean_mm")
        if not isinstance(want, (int, float)) or not np.isfinite(want):
            raise ModelFileError(path, "the recorded figure is not a number", "check.mean_mm")
        if abs(fig["mean_mm"] - want) > FIGURE_TOLERANCE * abs(want) + FIGURE_ABS_MM:
            raise ModelFileError(path, f"its parameters give an uncompensated error (model) of "
                                 f"{fig['mean_mm']:.4f} mm on its check commands where the file records "
                                 f"{want:.4f} mm{_suspect(d)}: the parameters (or the measured range) were changed "
                                 "after the fit; nothing is written from it: fit the model again", "check")
    if isinstance(measured, dict) and isinstance(measured.get("mean"), (int, float)) and measured["mean"] > 0:
        if fig["mean_mm"] > MEASURED_FACTOR * measured["mean"]:
            raise ModelFileError(path, f"its parameters give an uncompensated error (model) of "
                                 f"{fig['mean_mm']:.4f} mm, more than {MEASURED_FACTOR:g} times the "
                                 f"{measured['mean']:.4f} mm the campaign measured{_suspect(d)}; a model does not "
                                 "predict errors the machine did not have: nothing is written from it",
                                 "selection.uncompensated_mm")


def _suspect(d: dict) -> str:
    """', largest against its prior: NAME (k priors)' for the message, or ''."""
    best, name = 0.0, None
    for p in d.get("parameters") or []:
        v, prior = p.get("value"), p.get("prior")
        if isinstance(v, (int, float)) and isinstance(prior, (int, float)) and prior > 0 and abs(v) / prior > best:
            best, name = abs(v) / prior, p.get("name")
    return f" (the parameter largest against its prior: {name}, {best:.1f} priors)" if name else ""
