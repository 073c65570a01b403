"""Versioned JSON files of fitted models.

A model file is self-contained: it embeds the machine's URDF (with its SHA-256),
the model definition (kind, bases, offsets, priors), every parameter with its
standard deviation in mm or degrees, the tracker pose, the noise settings and the
fit report. ``format`` is ``"vecpin-model"``, ``version`` 1.
"""
from __future__ import annotations

import datetime
import hashlib
import json
import math
from pathlib import Path

import numpy as np

from vecpin.models.basis import AxisBasis
from vecpin.errors import InputError, ModelFileError, VecpinError
from vecpin.identification.fit import E0_NAMES, FitReport, Setup
from vecpin.kinematics.machine import Machine
from vecpin.models import ErrorModel, make_model
from vecpin.measurement.noise import NoiseModel

FORMAT = "vecpin-model"
VERSION = 1


UNITS = {"length": ("mm", 1e3), "angle": ("deg", 180 / math.pi), "ratio": ("ratio", 1.0)}
FROM_UNIT = {"mm": 1e-3, "deg": math.pi / 180, "ratio": 1.0}


def _unit(quantity: str) -> tuple[str, float]:
    return UNITS[quantity]


def model_to_dict(model: ErrorModel) -> dict:
    model._check_fitted()
    m = model.machine
    std = np.sqrt(np.clip(np.diag(model.cov_), 0, None))
    removed = set(model.report_.removed)
    params = []
    quantities = ["length"] * 3 + ["angle"] * 3 + [p.quantity for p in model.parameters]
    priors = list(np.r_[1e-2 * np.ones(6), model.priors])
    for k, (name, value, s, q, pr) in enumerate(zip(list(E0_NAMES) + model.parameter_names,
                                                    np.r_[model.e0_, model.b_], std, quantities, priors)):
        unit, f = _unit(q)
        params.append({"name": name, "value": float(value * f), "std": float(s * f), "prior": float(pr * f),
                       "unit": unit, "removed": name in removed})
    bases = [B.to_dict(a.scale) | {"lower": float(a.to_user(B.lower)), "upper": float(a.to_user(B.upper)),
                                   "rotary": B.rotary}
             for a, B in zip(m.axes, model.bases)]
    return {
        "format": FORMAT, "version": VERSION,
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "units": {"length": "mm", "angle": "deg", "ap_parameters": "unit of the output axis (mm or deg)"},
        "machine": {"name": m.name, "source": m.source, "urdf_sha256": hashlib.sha256(m.urdf_xml.encode()).hexdigest(),
                    "axes": [{"name": a.name, "kind": a.kind, "unit": a.unit, "lower": a.lower_user, "upper": a.upper_user}
                             for a in m.axes],
                    "urdf": m.urdf_xml},
        "model": {"kind": model.kind, "order": model.order, "basis": model.basis_kind, "axis_bases": bases,
                  "tool_lengths_mm": None if model.tool_lengths is None else [t * 1e3 for t in model.tool_lengths],
                  "prior_scale": model.prior_scale, "effects": [e.to_dict() for e in model.effects]},
        "tracker": {"rotation": model.setup_.R.tolist(), "translation_mm": (model.setup_.t * 1e3).tolist(),
                    "meaning": "p_tracker = R (E_0 p_machine) + t",
                    "stations": {str(s): {"rotation": R.tolist(), "translation_mm": (t * 1e3).tolist(),
                                          "correction": [float(v) for v in e]}
                                 for s, (R, t, e) in model.setup_.stations.items()},
                    "pivots_mm": {str(p): (c * 1e3).tolist() for p, c in model.setup_.pivots.items()}},
        "noise": model.noise_.to_dict(m),
        "parameters": params,
        "fit": model.report_.to_dict(),
    }


def save_model(model: ErrorModel, path: str | Path) -> None:
    Path(path).write_text(json.dumps(model_to_dict(model), indent=1))


def load_model(path: str | Path) -> ErrorModel:
    path = Path(path)
    if not path.is_file():
        raise VecpinError(f"{path}: no such model file")
    try:
        d = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise VecpinError(f"{path}: not a JSON model file ({exc})") from None
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise VecpinError(f"{path}: not a vecpin model file (format '{d.get('format') if isinstance(d, dict) else '?'}')")
    if d.get("version") != VERSION:
        raise VecpinError(f"{path}: model file version {d.get('version')} is not supported (this vecpin reads {VERSION})")
    try:
        return _from_dict(d, path)
    except (KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, VecpinError):
            raise
        raise VecpinError(f"{path}: damaged model file ({type(exc).__name__}: {exc})") from None


def _from_dict(d: dict, path: Path) -> ErrorModel:
    md = d["machine"]
    xml = md["urdf"]
    if hashlib.sha256(xml.encode()).hexdigest() != md["urdf_sha256"]:
        raise VecpinError(f"{path}: the embedded URDF does not match its checksum")
    machine = Machine.from_urdf_string(xml, source=md.get("source", md["name"]))
    spec = d["model"]
    bases = None
    if spec["basis"] == "custom":
        bases = []
        for a, b in zip(machine.axes, spec["axis_bases"]):
            try:
                bases.append(AxisBasis.from_dict(b, float(a.to_si(b["lower"])), float(a.to_si(b["upper"])),
                                                 bool(b["rotary"]), a.scale))
            except InputError as exc:
                raise ModelFileError(path, f"the basis of axis {a.name} is invalid ({exc})", "model.axis_bases") from None
    tools = None if spec["tool_lengths_mm"] is None else [t * 1e-3 for t in spec["tool_lengths_mm"]]
    from vecpin.models.effects import effect_from_dict
    effects = [effect_from_dict(e, machine) for e in spec.get("effects", [])]
    model = make_model(spec["kind"], machine, spec["order"], basis="chebyshev" if spec["basis"] == "chebyshev" else "auto",
                       tool_lengths=tools, prior_scale=spec["prior_scale"], bases=bases, effects=effects)
    by_name = {p["name"]: p for p in d["parameters"]}
    names = list(E0_NAMES) + model.parameter_names
    missing = [n for n in names if n not in by_name]
    if missing:
        raise VecpinError(f"{path}: parameters missing from the file: {', '.join(missing[:5])}")
    theta = np.empty(len(names))
    std = np.empty(len(names))
    for k, n in enumerate(names):
        p = by_name[n]
        f = FROM_UNIT[p["unit"]]
        theta[k], std[k] = p["value"] * f, p["std"] * f
    model.e0_, model.b_ = theta[:6], theta[6:]
    model.cov_ = np.diag(std**2)
    tr = d["tracker"]
    model.setup_ = Setup(np.array(tr["rotation"], float), np.array(tr["translation_mm"], float) * 1e-3, theta[:6].copy())
    for s, st in tr.get("stations", {}).items():
        model.setup_.stations[int(s)] = (np.array(st["rotation"], float), np.array(st["translation_mm"], float) * 1e-3,
                                         np.array(st["correction"], float))
    for p, c in tr.get("pivots_mm", {}).items():
        model.setup_.pivots[int(p)] = np.array(c, float) * 1e-3
    model.noise_ = NoiseModel.from_dict(d["noise"], machine)
    fields = {k: v for k, v in d["fit"].items() if k in FitReport.__dataclass_fields__}
    model.report_ = FitReport(**fields)
    return model
