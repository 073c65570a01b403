"""Validation after gross errors, for ``bench_unseen.py`` (issue 40: "gross errors found at least 95 %,
with validation within 10 % of a clean fit").

For a campaign the generator drew with gross errors, the model vecpin's diagnosis hands the user
(``model_base.json`` of ``vecpin diagnose --out DIR``: fitted without the rows it flagged; no new fit)
is judged against a *clean fit*: ``vecpin fit`` (the default model choice, the same stated noise and tool
options) on the same campaign with the true gross rows removed (the generator knows them). Both are
judged by ``vecpin evaluate`` on noise-free readings of the generator's truth at 150 fresh commands x
every tool (:func:`generator.heldout_csv`, the campaign's tracker frame): the true held-out (validation)
mean error, mm. The figure: the share of campaigns whose vecpin model is within 10 % of the clean fit's
(ratio <= 1.10), with its Wilson 95 % interval.
"""
from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Callable

import numpy as np

from generator import heldout_csv

WITHIN = 1.10          # the target: vecpin's validation at most this times the clean fit's
HELD_COMMANDS = 150    # fresh commands judged (x every tool)


def without_lines(csv: Path, lines: list[int], out: Path) -> Path:
    """``csv`` without the file lines ``lines`` (1-based, header = 1), written to ``out``."""
    drop = set(lines)
    kept = [ln for i, ln in enumerate(csv.read_text().splitlines(keepends=True), 1) if i not in drop]
    out.write_text("".join(kept))
    return out


def validation_mm(run: Callable, model: Path, held: Path) -> float | None:
    """``vecpin evaluate`` of ``model`` on the truth's readings ``held``: the model's mean residual, mm."""
    ev_json = model.with_name(model.stem + "_eval.json")
    res = run("evaluate", str(model), str(held), "--json", str(ev_json))
    if res.returncode != 0 or not ev_json.exists():
        return None
    return float(json.loads(ev_json.read_text())["model_residual"]["all"]["mean"])


def gross_validation(run: Callable, camp, paths: dict, diag_dir: Path, options: list[str]) -> dict:
    """vecpin's model after the diagnosis (``diag_dir/model_base.json``) against the clean fit, both judged
    on the truth: {"vecpin_mm", "clean_mm", "ratio"} (None where a run failed) and the clean fit's seconds.
    ``run``: the ``vecpin`` command; ``options``: the tool and noise options the diagnosis was given."""
    folder = diag_dir.parent
    truth = camp.truth_record()
    held = folder / "heldout_truth.csv"
    held.write_text(heldout_csv(camp, HELD_COMMANDS, camp.seed + 1))
    clean_csv = without_lines(paths["csv"], truth["gross_lines"], folder / "campaign_clean.csv")
    clean_model = folder / "model_clean.json"
    t0 = time.perf_counter()
    fit = run("fit", str(paths["urdf"]), str(clean_csv), "--out", str(clean_model), "--quiet", *options)
    seconds = time.perf_counter() - t0
    clean = validation_mm(run, clean_model, held) if fit.returncode == 0 else None
    base = diag_dir / "model_base.json"
    mine = validation_mm(run, base, held) if base.exists() else None
    ratio = None if clean is None or mine is None or clean <= 0 else mine / clean
    return {"vecpin_mm": mine, "clean_mm": clean, "ratio": ratio, "clean_fit_s": seconds}


def validation_lines(records: list[dict], frac: Callable[[int, int], str], detail: bool = True) -> list[str]:
    """The page's section: per campaign with gross errors (``detail``) and the share within 10 %."""
    done = [r for r in records if r.get("validation")]
    if not done:
        return []
    ratios = [r["validation"]["ratio"] for r in done if r["validation"]["ratio"] is not None]
    lines = ["", "## Validation after gross errors", "",
             "Campaigns with gross errors: the true held-out mean error (noise-free readings of the truth at "
             f"{HELD_COMMANDS} fresh commands x every tool, `vecpin evaluate`) of the model the diagnosis hands "
             "the user (`model_base.json`: fitted without the rows it flagged) against a clean fit (`vecpin fit` "
             "on the same campaign without the true gross rows, the same options). "
             f"Target: within {WITHIN - 1:.0%} of the clean fit.", ""]
    if ratios:
        r = np.array(ratios)
        lines.append(f"* validation within {WITHIN - 1:.0%} of a clean fit: {frac(int((r <= WITHIN).sum()), len(r))}; "
                     f"vecpin / clean median {np.median(r):.2f}, worst {r.max():.2f}"
                     + (f"; {len(done) - len(r)} campaigns not judged (a run failed)" if len(done) > len(r) else ""))
    else:
        lines.append(f"* no campaign judged ({len(done)} with gross errors: a run failed in each)")
    if not detail:
        return lines
    lines += ["", "| seed | layout | rows | gross rows (found) | rows flagged, no gross error | vecpin µm "
              "| clean fit µm | vecpin / clean |", "|---|---|---|---|---|---|---|---|"]
    for r in done:
        v = r["validation"]
        cells = [("-" if v[k] is None else f"{v[k] * 1e3:.1f}") for k in ("vecpin_mm", "clean_mm")]
        ratio = "-" if v["ratio"] is None else f"{v['ratio']:.2f}"
        lines.append(f"| {r['seed']} | {r['truth']['kind']} | {r['truth']['rows']} | {r['gross_true']} "
                     f"({r['gross_found']}) | {r['gross_false']} | {cells[0]} | {cells[1]} | {ratio} |")
    return lines
