"""Versioned JSON files of fitted models.

A model file is self-contained: it embeds the machine's URDF (with its SHA-256),
the model's specification (:class:`~vecpin.models.spec.ModelSpec`: kind, a basis per
axis, tool-length corrections, prior scale, effects), every parameter with
its standard deviation in mm or degrees, the tracker pose (with the fitted table nests
and tool targets), the measurement zone, the noise settings, the fit report and the model's own uncompensated
figure on fixed check commands (``check``: recomputed and compared when the file is read,
with the parameters against their priors: :mod:`vecpin.models.recorded`).
``format`` is ``"vecpin-model"``, ``version`` 1. Files hold no time stamp or timing, so
the same fit writes the same bytes.

Every number a user reads is in mm or degrees (a key ending ``_mm`` is mm; ``_mm_deg``
holds mm for translations and degrees for rotations; axis values are in the axis' unit):
parameters, tracker and station translations, station pose corrections
(``correction_mm_deg``), ball-bar pivots, table nests and tool targets with their standard deviations,
axis travels and basis knots, the zone, the measured range and the residuals.

This module knows the file, not the model classes: :func:`load_model` takes the
factory that builds a model from its spec (:meth:`vecpin.models.ErrorModel.from_spec`).
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Callable

import numpy as np

from vecpin.errors import InputError, ModelFileError, VecpinError
from vecpin.fileio import write_text
from vecpin.identification.report import FitReport
from vecpin.kinematics.machine import Machine
from vecpin.measurement.instruments.tracker import E0_NAMES, POSE_PRIOR
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.setup import Setup
from vecpin.measurement.tableface import check_table_face
from vecpin.models.recorded import check_figure, check_recorded, still_axes, still_hold
from vecpin.models.spec import ModelSpec
from vecpin.units import MM_PER_M, M_PER_MM, QUANTITY_UNITS, SI_PER_UNIT

FORMAT = "vecpin-model"
VERSION = 1
READS = (1,)
MAX_FILE_BYTES = 200_000_000


def urdf_sha256(machine: Machine) -> str:
    """SHA-256 of the machine's URDF text: two machines are the same machine when it matches."""
    return hashlib.sha256(machine.urdf_xml.encode()).hexdigest()


def check_same_machine(a: Machine, b: Machine, what_a: str, what_b: str) -> None:
    """Refuse to combine files of two different machines (URDF checksum and load options)."""
    if urdf_sha256(a) != urdf_sha256(b) or a.load_options != b.load_options:
        raise InputError(f"{what_a} is for machine '{a.name}' ({a.source}) and {what_b} for machine '{b.name}' "
                         f"({b.source}), whose URDFs or tool options differ: use files of one machine")


def model_to_dict(model) -> dict:
    """The file's content for a fitted model (see the module docstring)."""
    m = model.machine
    std = np.sqrt(np.clip(np.diag(model.cov_), 0, None))
    removed = set(model.report_.removed)
    params = []
    quantities = ["length"] * 3 + ["angle"] * 3 + [p.quantity for p in model.parameters]
    priors = np.r_[np.full(6, POSE_PRIOR), model.priors]
    for name, value, s, q, pr in zip(list(E0_NAMES) + model.parameter_names, np.r_[model.e0_, model.b_], std,
                                     quantities, priors):
        unit, si = QUANTITY_UNITS[q]
        params.append({"name": name, "value": float(value / si), "std": float(s / si), "prior": float(pr / si),
                       "unit": unit, "removed": name in removed})
    report = model.report_.to_dict()
    report.pop("seconds", None)  # timing is not part of the result: reruns write the same bytes
    setup = model.setup_
    return {
        "format": FORMAT, "version": VERSION,
        "units": {"length": "mm", "angle": "deg", "ap_parameters": "unit of the output axis (mm or deg)"},
        "machine": {"name": m.name, "source": m.source, "urdf_sha256": urdf_sha256(m),
                    "axes": [{"name": a.name, "kind": a.kind, "unit": a.unit, "lower": a.lower_user, "upper": a.upper_user}
                             for a in m.axes],
                    "urdf": m.urdf_xml, "load_options": m.load_options,
                    "urdf_dir": str(m.urdf_path.parent.resolve()) if m.urdf_path is not None else None},
        "model": model.spec.to_dict(m),
        "tracker": {"rotation": setup.R.tolist(), "translation_mm": (setup.t * MM_PER_M).tolist(),
                    "meaning": "p_tracker = R (E_0 p_machine) + t",
                    "stations": {str(s): {"rotation": R.tolist(), "translation_mm": (t * MM_PER_M).tolist(),
                                          "correction_mm_deg": pose_correction_to_user(e)}
                                 for s, (R, t, e) in setup.stations.items()},
                    "pivots_mm": {str(p): (c * MM_PER_M).tolist() for p, c in setup.pivots.items()},
                    **_points_to_dict(setup)},
        "noise": model.noise_.to_dict(m),
        "parameters": params,
        "fit": report,
        "correlations": _correlations(model, std),
        "selection": getattr(model, "selection_", None),
        "zone": _zone_to_dict(getattr(model, "zone_", None)),
        "check": check_figure(model),
        "still_axes": _still_to_dict(model),
    }


def _still_to_dict(model) -> dict:
    """The axes that stood still in the campaign, each with where it stood (mm or deg) and
    what that means for the model's errors there."""
    lo, _ = still_hold(model) or (None, None)
    return {a.name: {"position": float(a.to_user(lo[a.index])), "unit": a.unit,
                     "meaning": "did not move in any row: its errors are held at this position (no slope beyond)"}
            for a in still_axes(model)}


def pose_correction_to_user(e) -> list[float]:
    """A station's small pose correction (dx, dy, dz [m], ex, ey, ez [rad]) as the file
    holds it: mm and degrees."""
    e = np.asarray(e, float)
    return [float(v) for v in np.r_[e[:3] * MM_PER_M, np.degrees(e[3:])]]


def pose_correction_from_file(path, field: str, st: dict) -> np.ndarray:
    """A station's pose correction (SI) from the file's ``correction_mm_deg`` (mm, deg)."""
    v = _finite(path, f"{field}.correction_mm_deg", st["correction_mm_deg"])
    if v.shape != (6,):
        raise ModelFileError(path, "needs 6 numbers: dx, dy, dz [mm], ex, ey, ez [deg]", f"{field}.correction_mm_deg")
    return np.r_[v[:3] * M_PER_MM, np.radians(v[3:])]


def _correlations(model, std: np.ndarray) -> dict:
    """The parameter correlations (E_0 and model terms that were estimated, in the order
    of ``parameters``), lower triangle row by row, 6 decimals: with the standard
    deviations they give back the covariance (tables' uncertainty, significance tests)."""
    idx = np.flatnonzero(std > 0)
    C = model.cov_[np.ix_(idx, idx)] / np.outer(std[idx], std[idx])
    C = np.round(C, 6).tolist()
    rows = [C[i][:i] for i in range(len(idx))]
    return {"index": [int(i) for i in idx], "lower": rows,
            "meaning": "corr[i][j] for j < i of the parameters listed by index (0 = E0.dx)"}


def _points_to_dict(setup) -> dict:
    """Fitted table nests (workpiece frame) and tool targets (tool link frame), mm, with
    their standard deviations; only when the campaign had them."""
    out = {}
    for kind, store in (("nests", setup.nests), ("targets", setup.targets)):
        if not store:
            continue
        out[f"{kind}_mm"] = {str(k): [float(v) * MM_PER_M for v in c] for k, c in store.items()}
        key = kind[:-1]
        out[f"{kind}_std_mm"] = {str(k): [setup.std.get(f"{key}{k}.{c}", 0.0) * MM_PER_M for c in "xyz"] for k in store}
    if setup.nest_heights:
        out["nest_heights_mm"] = {str(k): float(h) * MM_PER_M for k, h in setup.nest_heights.items()}
        out["nest_height_sd_mm"] = {str(k): float(s) * MM_PER_M for k, s in setup.nest_height_sd.items()}
    if getattr(setup, "face_sweep", None):   # the table face's indicator sweeps: mm, µm
        out["table_face"] = {str(a): {"distance_mm": d * MM_PER_M, "change_um": c * 1e6, "sd_um": sd * 1e6}
                             for a, (d, c, sd) in setup.face_sweep.items()}
    if setup.nest_z_cov:
        out["nests_z_cov_mm2"] = {"ids": [str(k) for k in setup.nest_z_cov["ids"]],
                                  "matrix": (np.asarray(setup.nest_z_cov["cov"]) * MM_PER_M ** 2).tolist()}
    return out


def _zone_to_dict(zone) -> dict | None:
    """The measurement zone the model was fitted in: {axis: [low, high]} mm/deg, or None."""
    return None if not zone else {a: [float(lo), float(hi)] for a, (lo, hi) in zone.items()}


def save_model(model, path: str | Path) -> None:
    """Write the model file atomically: indented, but the correlations (the bulk of a
    large model's file: P^2 / 2 numbers) one row per line, written by json's C encoder
    (the indenting encoder is pure Python: 0.4 s for a model of 470 terms)."""
    d = model_to_dict(model)
    corr = d.pop("correlations")
    rows = ",\n  ".join(json.dumps(r) for r in corr["lower"])
    head = {k: v for k, v in corr.items() if k != "lower"}
    text = json.dumps(d, indent=1)[:-2]
    write_text(path, f'{text},\n "correlations": {json.dumps(head)[:-1]}, "lower": [\n  {rows}]}}\n}}')


def load_model(path: str | Path, factory: Callable):
    """Read a model file; ``factory(machine, spec)`` builds the model from its spec."""
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(path, "no such model file")
    if path.stat().st_size > MAX_FILE_BYTES:
        raise ModelFileError(path, f"{path.stat().st_size} bytes is far more than any model file")
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ModelFileError(path, f"not a JSON model file ({exc})") from None
    except RecursionError:
        raise ModelFileError(path, "not a model file (nested beyond any model file's depth)") from None
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise ModelFileError(path, f"not a vecpin model file (format '{d.get('format') if isinstance(d, dict) else '?'}')",
                             "format")
    if d.get("version") not in READS:
        raise ModelFileError(path, f"model file version {d.get('version')} is not supported (this vecpin reads "
                             f"{', '.join(map(str, READS))})", "version")
    try:
        model = _from_dict(d, path, factory)
        check_recorded(model, d, path)   # what the file records, before anything is written from it
        model.source_ = str(path)        # messages about the model name its file
        return model
    except VecpinError as exc:
        if isinstance(exc, ModelFileError):
            raise
        raise ModelFileError(path, str(exc)) from None
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
        field = exc.args[0] if isinstance(exc, KeyError) and exc.args else None
        raise ModelFileError(path, f"damaged model file ({type(exc).__name__}: {exc})",
                             field if isinstance(field, str) else None) from None


def _finite(path, field: str, values) -> np.ndarray:
    a = np.asarray(values, float)
    if not np.all(np.isfinite(a)):
        raise ModelFileError(path, "holds a value that is not a finite number", field)
    return a


def _rotation(path, field: str, values) -> np.ndarray:
    R = _finite(path, field, values)
    if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
        raise ModelFileError(path, "is not a rotation matrix (orthonormal, determinant +1)", field)
    return R


def _object(path, d: dict, key: str) -> dict:
    """``d[key]``, which must be a JSON object (a section of the file)."""
    v = d.get(key)
    if not isinstance(v, dict):
        raise ModelFileError(path, f"the section is {'missing' if key not in d else json.dumps(v)[:40]}, not an object of "
                             "fields (the file is damaged or edited: write it again with vecpin fit)", key)
    return v


def _check_measured_range(path, machine, rng) -> None:
    """fit.measured_range: per axis of the machine two finite numbers (mm or deg)."""
    if rng is None:
        return
    if not isinstance(rng, dict):
        raise ModelFileError(path, "an object: axis -> [low, high] (mm or deg)", "fit.measured_range")
    for a, v in rng.items():
        if a not in machine.axis_names:
            raise ModelFileError(path, f"{a!r} is not an axis of {machine.name} ({', '.join(machine.axis_names)})",
                                 "fit.measured_range")
        if (not isinstance(v, list) or len(v) != 2
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x) for x in v)):
            raise ModelFileError(path, f"{v!r}: [low, high] in the axis' unit", f"fit.measured_range.{a}")


def _check_still(path, d: dict, model) -> None:
    """The file's ``still_axes`` (when there) name the axes its measured range says stood still."""
    if not isinstance(d.get("still_axes"), (dict, type(None))):
        raise ModelFileError(path, "an object: axis -> {position, unit}", "still_axes")
    said, found = sorted(d.get("still_axes") or {}), sorted(a.name for a in still_axes(model))
    if "still_axes" in d and said != found:
        raise ModelFileError(path, f"the file says {', '.join(said) or 'no axis'} stood still, its measured range "
                             f"says {', '.join(found) or 'none'}: one of them was edited; fit the model again",
                             "still_axes")


def _parameter(path, p: dict, key: str) -> float:
    """A parameter's value or std: a finite number, the parameter named when not."""
    v = p.get(key) if isinstance(p, dict) else None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        raise ModelFileError(path, f"parameter {p.get('name') if isinstance(p, dict) else p!r}: {key} {v!r} is not a "
                             "finite number", "parameters")
    return float(v)


def _from_dict(d: dict, path: Path, factory: Callable):
    for key in ("machine", "model", "tracker", "noise", "fit"):
        _object(path, d, key)
    if not isinstance(d.get("parameters"), list) or not all(isinstance(p, dict) for p in d["parameters"]):
        raise ModelFileError(path, "a list of parameters (name, value, std, unit)", "parameters")
    md = d["machine"]
    xml = md["urdf"]
    if hashlib.sha256(xml.encode()).hexdigest() != md["urdf_sha256"]:
        raise ModelFileError(path, "the embedded URDF does not match its checksum", "machine.urdf")
    machine = Machine.from_urdf_string(xml, source=md["source"], **md["load_options"])
    try:
        model = factory(machine, ModelSpec.from_dict(d["model"], machine))
    except InputError as exc:
        raise ModelFileError(path, str(exc), "model") from None
    by_name = {p["name"]: p for p in d["parameters"]}
    names = list(E0_NAMES) + model.parameter_names
    missing = [n for n in names if n not in by_name]
    if missing:
        raise ModelFileError(path, f"parameters missing from the file: {', '.join(missing[:5])}", "parameters")
    theta = np.empty(len(names))
    std = np.empty(len(names))
    for k, n in enumerate(names):
        p = by_name[n]
        f = SI_PER_UNIT[p["unit"]]
        theta[k], std[k] = _parameter(path, p, "value") * f, _parameter(path, p, "std") * f
    _finite(path, "parameters", np.r_[theta, std])
    model.e0_, model.b_ = theta[:6], theta[6:]
    model.cov_ = np.diag(std**2)
    corr = d["correlations"]
    if corr["index"]:
        idx = np.asarray(corr["index"], int)
        if idx.size and (idx.max() >= len(names) or len(corr["lower"]) != idx.size):
            raise ModelFileError(path, "the correlations do not match the parameters", "correlations")
        C = np.eye(idx.size)
        for i, row in enumerate(corr["lower"]):
            if len(row) != i:
                raise ModelFileError(path, f"correlation row {i} has {len(row)} values, not {i}", "correlations")
            C[i, :i] = row
            C[:i, i] = row
        _finite(path, "correlations", C)
        model.cov_[np.ix_(idx, idx)] = C * np.outer(std[idx], std[idx])
    tr = d["tracker"]
    model.setup_ = Setup(_rotation(path, "tracker.rotation", tr["rotation"]),
                         _finite(path, "tracker.translation_mm", tr["translation_mm"]) * M_PER_MM, theta[:6].copy())
    for s, st in tr.get("stations", {}).items():
        model.setup_.stations[int(s)] = (_rotation(path, f"tracker.stations.{s}.rotation", st["rotation"]),
                                         _finite(path, f"tracker.stations.{s}.translation_mm",
                                                 st["translation_mm"]) * M_PER_MM,
                                         pose_correction_from_file(path, f"tracker.stations.{s}", st))
    for p, c in tr.get("pivots_mm", {}).items():
        model.setup_.pivots[int(p)] = _finite(path, f"tracker.pivots_mm.{p}", c) * M_PER_MM
    for kind, store in (("nests", model.setup_.nests), ("targets", model.setup_.targets)):
        for k, c in tr.get(f"{kind}_mm", {}).items():
            store[k] = _finite(path, f"tracker.{kind}_mm.{k}", c) * M_PER_MM
            for comp, sd in zip("xyz", tr[f"{kind}_std_mm"][k]):
                model.setup_.std[f"{kind[:-1]}{k}.{comp}"] = float(sd) * M_PER_MM
    _nest_heights_from(path, tr, model.setup_)
    _table_face_from(path, tr, model.setup_, machine)
    zone = d.get("zone")
    if zone:
        for a in zone:
            machine.axis(a)
        model.zone_ = {a: (float(lo), float(hi)) for a, (lo, hi) in zone.items()}
    model.noise_ = NoiseModel.from_dict(d["noise"], machine)
    fields = {k: v for k, v in d["fit"].items() if k in FitReport.__dataclass_fields__}
    fields.setdefault("seconds", 0.0)
    model.report_ = FitReport(**fields)
    _check_measured_range(path, machine, model.report_.measured_range)
    model.range_ = still_hold(model)   # the axes that stood still: their errors held where they stood, as fitted
    _check_still(path, d, model)
    if d.get("selection") is not None:
        model.selection_ = d["selection"]
    # where relative meshes of the embedded URDF are looked for (the scene): its folder, then the model file's
    model.mesh_dirs_ = [str(x) for x in (md.get("urdf_dir"), path.resolve().parent) if x]
    return model


def _table_face_from(path, tr: dict, setup, machine) -> None:
    """The table face's indicator sweeps from the file's ``tracker.table_face`` into ``setup``
    [m], checked as the fit checks them (:func:`~vecpin.measurement.tableface.check_table_face`)."""
    given = tr.get("table_face") or {}
    try:
        if not isinstance(given, dict) or not all(isinstance(v, dict) for v in given.values()):
            raise InputError("{axis: {distance_mm, change_um, sd_um}}")
        for a, v in given.items():   # no standard deviation is no reading taken as exact
            if "sd_um" not in v:
                raise InputError(f"{a}: no sd_um (the reading's standard deviation, µm, as the fit writes it)")
        setup.face_sweep.update(check_table_face({a: (v.get("distance_mm"), v.get("change_um"), v["sd_um"])
                                                  for a, v in given.items()}, machine, "tracker.table_face"))
    except InputError as e:
        raise ModelFileError(path, str(e), "tracker.table_face") from None


def _nest_heights_from(path, tr: dict, setup) -> None:
    """The nests' heights above the table's face [m] and their readings' standard deviations [m]
    from the file's ``tracker`` section into ``setup`` (older files carry no standard deviations:
    the default gauge's applies where the heights are used)."""
    for k, h in tr.get("nest_heights_mm", {}).items():
        if str(k) not in setup.nests:
            raise ModelFileError(path, f"nest '{k}' is not among the fitted nests "
                                 f"({', '.join(sorted(setup.nests)) or 'none'})", "tracker.nest_heights_mm")
        if isinstance(h, bool) or not isinstance(h, (int, float)):
            raise ModelFileError(path, "a nest's height must be a number, mm", f"tracker.nest_heights_mm.{k}")
        setup.nest_heights[str(k)] = float(_finite(path, f"tracker.nest_heights_mm.{k}", h)) * M_PER_MM
    for k, s in tr.get("nest_height_sd_mm", {}).items():   # older files: none (the default gauge's, where used)
        if str(k) not in setup.nest_heights or isinstance(s, bool) or not isinstance(s, (int, float)) or s < 0:
            raise ModelFileError(path, "a standard deviation (mm, 0 or more) of a nest given a height",
                                 f"tracker.nest_height_sd_mm.{k}")
        setup.nest_height_sd[str(k)] = float(_finite(path, f"tracker.nest_height_sd_mm.{k}", s)) * M_PER_MM
    zc = tr.get("nests_z_cov_mm2")
    if zc is not None:   # older files: none (the nests' standard deviations stand in)
        ids = [str(k) for k in zc.get("ids", [])] if isinstance(zc, dict) else []
        M = _finite(path, "tracker.nests_z_cov_mm2.matrix", zc.get("matrix", []) if isinstance(zc, dict) else [])
        if not ids or any(k not in setup.nests for k in ids) or M.shape != (len(ids), len(ids)):
            raise ModelFileError(path, "the fitted nests' ids and their z coordinates' covariance, a square matrix "
                                 "(mm^2) with a row per id", "tracker.nests_z_cov_mm2")
        setup.nest_z_cov.update(ids=ids, cov=M * M_PER_MM ** 2)
