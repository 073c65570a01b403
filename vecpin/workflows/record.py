"""The figures of a day's stages against the user's tolerance, read back from the files the
stages wrote, and the compensation record (ISO/TR 16907:2015 clauses 11 and 12).

Nothing here computes a result: every figure is one a command wrote (plan.json,
assess.json, model.json, evaluate.json, tables/tables.json, verify/verify.json); this module only puts them
beside the tolerance (mm) and the instrument's noise (mm), and lists what was written.
"""
from __future__ import annotations

import json
from datetime import datetime, timezone
from pathlib import Path

from vecpin.fileio import MANIFEST, write_text
from vecpin.workflows.session import OUTPUTS, RECORD_JSON, RECORD_MD, STAGES, Session, _json, sha256, versions


def _verdict(value: float | None, tolerance: float | None) -> bool | None:
    if value is None or tolerance is None:
        return None
    return bool(value <= tolerance)


def _fig(what: str, value: float | None, judged: str | None = None, tolerance: float | None = None,
         noise: float | None = None, **more) -> dict:
    """One stage's figure: ``what`` it is, ``value`` (mm), whether it passes the tolerance
    (``judged`` names the figure compared, None: not judged) and the instrument noise (mm)."""
    return {"what": what, "value_mm": value, "judged": judged,
            "passes": _verdict(value, tolerance) if judged else None, "noise_mm": noise, **more}


def stage_figures(out_dir: str | Path, tolerance_mm: float | None) -> dict[str, dict]:
    """stage -> its figure (see :func:`_fig`) for every stage whose file is in ``out_dir``.
    A stage passes when its figure (mm) is at most ``tolerance_mm``: the plan's predicted
    maximum of the model's validation residual (its parameter uncertainty and the measurement
    noise: what the fitted model would leave on the validation run's readings, not a
    compensated error), the assessment's predicted compensated error (the high end), the
    fit's held-out maximum, the tables' model-predicted maximum in the part's frame
    (tables.json's ``predicted``), the verified compensated maximum."""
    out = Path(out_dir)
    noise = None
    a = _json(out / OUTPUTS["assess"])
    if a:
        noise = a.get("instrument")
    figs: dict[str, dict] = {}
    p = _json(out / OUTPUTS["plan"] / "plan.json")
    if p:
        s = p.get("score") or {}
        cart = ((p.get("settings") or {}).get("noise") or {}).get("cartesian_sigma_mm")
        figs["plan"] = _fig("predicted validation residual of the model, measurement noise included (max)",
                            s.get("validation_max_mm"), "max", tolerance_mm, noise if noise is not None else cart,
                            mean_mm=s.get("validation_mean_mm"), commands=s.get("commands"), rows=s.get("rows"))
    campaign = out / OUTPUTS["import"]
    if campaign.is_file():
        rows = max(0, len(campaign.read_text(encoding="utf-8").splitlines()) - 1)
        figs["import"] = _fig("campaign rows written", None, rows=rows)
    if a:
        pred = a.get("predicted_compensated") or [None, None]
        figs["assess"] = _fig("predicted compensated error (2-3 x repeatability, high end)", pred[-1], "max",
                              tolerance_mm, noise, verdict=a.get("verdict"), mean_error_mm=a.get("mean_error"),
                              repeatability_mm=a.get("repeatability"))
    m = _json(out / OUTPUTS["fit"])
    if m:
        chosen = (m.get("selection") or {}).get("chosen") or {}
        kind = chosen.get("kind") or (m.get("model") or {}).get("kind")
        if chosen.get("heldout_max_mm") is not None:
            figs["fit"] = _fig("held-out error of the chosen model (max)", chosen["heldout_max_mm"], "max",
                               tolerance_mm, noise, heldout_mean_mm=chosen.get("heldout_mean_mm"), model=kind,
                               bases=chosen.get("bases"))
        else:   # a model the user fixed: no choice, so no held-out figures; the fit's own residual
            r = ((m.get("fit") or {}).get("residuals_mm") or {}).get("all") or {}
            figs["fit"] = _fig("residual of the fixed model on its campaign (max; no held-out figures)",
                               r.get("max"), "max", tolerance_mm, noise, mean_mm=r.get("mean"), model=kind)
    e = _json(out / OUTPUTS["evaluate"])
    if e:
        r = (e.get("model_residual") or {}).get("all") or {}
        figs["evaluate"] = _fig("residual of the model on the campaign (max)", r.get("max"), "max", tolerance_mm,
                                noise, mean_mm=r.get("mean"))
    d = _json(out / OUTPUTS["diagnose"] / "diagnosis.json")
    if d:
        best = d.get("best") or {}
        figs["diagnose"] = _fig("held-out error of the best model the diagnosis found (max)",
                                best.get("heldout_max_mm"), "max", tolerance_mm, noise,
                                mean_mm=best.get("heldout_mean_mm"), effects=best.get("effects"),
                                headline=d.get("headline"))
    t = (_json(out / OUTPUTS["tables"] / "tables.json") or {}).get("predicted")
    if t:   # the tables the machine gets, model-predicted on the printout's points
        w, u = t.get("written") or {}, t.get("uncompensated") or {}
        figs["tables"] = _fig("model-predicted error the tables leave, in the part's frame (max)", w.get("max_mm"),
                              "max", tolerance_mm, noise, mean_mm=w.get("mean_mm"),
                              shape_mean_mm=w.get("shape_mean_mm"), before_mean_mm=u.get("mean_mm"),
                              before_max_mm=u.get("max_mm"), row=w.get("label"), frame=t.get("frame"),
                              points=t.get("basis"))
    v = _json(out / OUTPUTS["verify"] / "verify.json")
    if v:
        after = ((v.get("compensated") or {}).get("measured") or {}).get("all") or {}
        before = ((v.get("uncompensated") or {}).get("measured") or {}).get("all") or {}
        figs["verify"] = _fig("measured compensated error on the validation run (max)", after.get("max"), "max",
                              tolerance_mm, noise, mean_mm=after.get("mean"), before_mean_mm=before.get("mean"),
                              before_max_mm=before.get("max"), reduction_of_mean_pct=v.get("reduction_of_mean_pct"))
    return figs


def _files(out: Path, stage: str) -> list[dict]:
    """The files a stage wrote (name relative to ``out``, bytes, sha256), manifests left out."""
    target = out / OUTPUTS[stage]
    paths = sorted(p for p in target.rglob("*") if p.is_file()) if target.is_dir() else [target]
    return [{"name": str(p.relative_to(out)), "bytes": p.stat().st_size, "sha256": sha256(p)}
            for p in paths if p.exists() and p.name != MANIFEST and not p.name.startswith(".vecpin-")]


def record(session: Session, out_dir: str | Path, commands: dict[str, list[str]]) -> dict:
    """The compensation record's data: the session, the software, per stage the command it ran
    and the files it wrote, the inputs with their sha256, the figures against the tolerance."""
    out = Path(out_dir)
    inputs = []
    for stage, fields in session.stages.items():
        for key in ("export", "profile", "before", "after"):
            if isinstance(fields.get(key), str):
                p = Path(session.input_path(fields[key]))
                inputs.append({"stage": stage, "field": key, "path": str(p),
                               "sha256": sha256(p) if p.is_file() else None})
    model = _json(out / OUTPUTS["fit"]) or {}
    return {"format": "vecpin-record", "version": 1,
            "written": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "machine": session.machine, "urdf_sha256": (model.get("machine") or {}).get("urdf_sha256"),
            "tolerance_mm": session.tolerance_mm, "session": session.to_dict(),
            "session_sha256": sha256(Path(session.path)) if session.path and Path(session.path).is_file() else None,
            "software": versions(), "inputs": inputs,
            "stages": {s: {"command": commands[s], "files": _files(out, s)} for s in STAGES if s in commands},
            "figures": stage_figures(out, session.tolerance_mm)}


def _mm(v) -> str:
    return "-" if v is None else f"{v:.4f} mm"


def _passes(f: dict) -> str:
    return {True: "PASS", False: "FAIL", None: "not judged"}[f.get("passes")]


def record_markdown(r: dict) -> str:
    """The record as Markdown, under ISO/TR 16907:2015's clause headings."""
    figs, tol = r["figures"], r["tolerance_mm"]
    lines = ["# Compensation record", "", f"Machine `{r['machine']}` (URDF sha256 `{r['urdf_sha256']}`), "
             f"written {r['written']}. Tolerance: {_mm(tol) if tol else 'not stated'}.", "",
             "## What was measured", ""]
    lines += [f"- {i['stage']} {i['field']}: `{i['path']}` (sha256 `{i['sha256']}`)" for i in r["inputs"]]
    if "import" in figs:
        lines.append(f"- campaign: {figs['import']['rows']} rows (campaign.csv)")
    lines += ["", "## What was fitted", ""]
    for s in ("assess", "fit", "evaluate"):
        if s in figs:
            f = figs[s]
            verdict = f" ({f['verdict']})" if f.get("verdict") else ""
            lines.append(f"- {s}: {f['what']}: {_mm(f['value_mm'])}{verdict}")
    lines += ["", "## What was written", ""]
    tables = r["stages"].get("tables")
    controller = (r["session"]["stages"].get("tables") or {}).get("controller") or "generic"
    lines += ([f"- for the controller ({controller}): " + ", ".join(f"`{f['name']}`" for f in tables["files"])]
              if tables else ["- no tables in this session"])
    lines += ["", "## ISO/TR 16907 clause 11: validation of the numerical compensation", ""]
    lines.append("| stage | figure | value | tolerance | instrument noise | result |")
    lines.append("| --- | --- | --- | --- | --- | --- |")
    for s, f in figs.items():
        if f.get("judged"):
            lines.append(f"| {s} | {f['what']} | {_mm(f['value_mm'])} | {_mm(tol)} | {_mm(f['noise_mm'])} | "
                         f"{_passes(f)} |")
    if "verify" in figs:
        v = figs["verify"]
        lines += ["", f"Validation run without the tables: mean {_mm(v['before_mean_mm'])}, max "
                  f"{_mm(v['before_max_mm'])}; with them: mean {_mm(v['mean_mm'])}, max {_mm(v['value_mm'])}."]
    else:
        lines += ["", "The compensation was not verified: no validation runs in this session."]
    lines += ["", "## ISO/TR 16907 clause 12: documentation on compensation", "", "Software: "
              + ", ".join(f"{k} {v}" for k, v in r["software"].items()) + ".", "",
              f"Session file sha256 `{r['session_sha256']}`. The commands this record's files come from, in order "
              "(run in the output folder):", "", "```text"]
    lines += ["vecpin " + " ".join(_quote(w) for w in st["command"]) for st in r["stages"].values()]
    lines += ["```", "", "Files written (what the machine gets is under tables/):", ""]
    lines += [f"- `{f['name']}` {f['bytes']} bytes, sha256 `{f['sha256']}`"
              for st in r["stages"].values() for f in st["files"]]
    return "\n".join(lines) + "\n"


def _quote(word: str) -> str:
    return word if word and all(c.isalnum() or c in "-_./=:,+@" for c in word) else json.dumps(word)


def write_record(session: Session, out_dir: str | Path, commands: dict[str, list[str]]) -> list[Path]:
    """Write ``record.json`` and ``record.md`` in ``out_dir``; returns their paths."""
    r = record(session, out_dir, commands)
    out = Path(out_dir)
    write_text(out / RECORD_JSON, json.dumps(r, indent=1) + "\n")
    write_text(out / RECORD_MD, record_markdown(r))
    return [out / RECORD_MD, out / RECORD_JSON]
