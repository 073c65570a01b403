"""vecpin judged on machines and errors it has never seen (issue 40).

Every campaign comes from ``benchmarks/generator`` (written blind: it shares no code and no
assumption with vecpin's simulator or models): a random layout (head, table, head-table, twin-drive
gantry, 6R arm) written as URDF, smooth Gaussian-process errors per axis, at most one effect (thermal
with lag and nonlinearity, a knocked tracker, isolated or clustered gross errors, backlash, a per-turn
harmonic, a non-separable coupling of two linear axes, a twin-drive yaw), spherical tracker noise.
vecpin is called as a user calls it: ``vecpin diagnose URDF CSV --out DIR`` and its diagnosis.json.

Scores: clean campaigns that stay silent; campaigns naming a wrong effect (spurious); per family the
recall (the true effect named, or named in the ambiguity group of a named effect) above a stated size,
and the precision of vecpin's names (``twin_skew``, vecpin's twin-drive yaw of beam and carriage together, is a
gantry skew); gross-error rows found; Wilson 95 % intervals throughout. Then
model choice on multi-target (three tool) clean campaigns: the chosen model's true held-out error
(``vecpin evaluate`` of the fitted model on noise-free readings of the generator's truth at fresh
commands) against the best of a few fixed candidates (``vecpin fit --model --basis --order``).
On campaigns with gross errors, validation after them (:mod:`unseen_gross`): the model the diagnosis
hands the user against a fit without the true gross rows.

Every vecpin run is given the tracker's and the axes' noise as their specs state them (the truth's
figures), unless --default-noise.

Run: python benchmarks/bench_unseen.py [-n 20] [--seed S | --heldout] [--family F] [--choice 4] [--detection 0]
     [--jobs 1] [--default-noise] [--no-write] [--page PATH]
--detection N: on N more campaigns, the stated detection size checked (the effect injected at 1x and 2x it).
The page is rewritten every 10 campaigns and after every later step (marked interim until the end).
Fresh seeds every run unless --seed; --heldout: the held-out seeds of ``benchmarks/heldout.py`` (committed code
only, no draw's details shown, the summary added to docs/results/heldout.md; run it once per stop, never tune).
"""
from __future__ import annotations

import argparse
import json
import os
import secrets
import subprocess
import sys
import tempfile
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from generator import draw_campaign, heldout_csv  # noqa: E402
from generator.truth import FAMILIES, VECPIN_NAME  # noqa: E402
from heldout import Run, aggregate, heldout_seeds  # noqa: E402
from unseen_gross import gross_validation, validation_lines  # noqa: E402

RESULT = ROOT / "docs" / "results" / "unseen.md"
RECALL_SIZE_MM = 0.02          # recall is stated for effects at least this large (RMS at the tip)
CANDIDATES = [("6dof", "chebyshev", "2"), ("6dof", "chebyshev", "4"), ("6dof", "chebyshev", "6"),
              ("ap", "chebyshev", "4"), ("6dof", "pspline", "auto")]
Z95 = 1.959963984540054
OWN = ("The same table for vecpin's own simulator families (bundled machines and the independent truth family): "
       "[diagnosis.md](diagnosis.md) (`bench_diagnosis.py`); the stated detection size checked on them: "
       "[detection.md](detection.md) (`bench_detection.py`).")


def wilson(k: int, n: int) -> tuple[float, float]:
    """Wilson score interval (95 %) of a proportion k/n; (0, 1) when n = 0."""
    if n == 0:
        return 0.0, 1.0
    p = k / n
    den = 1.0 + Z95 ** 2 / n
    mid = (p + Z95 ** 2 / (2 * n)) / den
    half = Z95 * np.sqrt(p * (1 - p) / n + Z95 ** 2 / (4 * n * n)) / den
    return max(0.0, mid - half), min(1.0, mid + half)


def frac(k: int, n: int) -> str:
    lo, hi = wilson(k, n)
    return f"{k}/{n} ({(k / n if n else 0):.0%}; {lo:.0%}-{hi:.0%})"


def vecpin_cmd(*args: str) -> subprocess.CompletedProcess:
    """Run the ``vecpin`` command (the console script of the active environment)."""
    exe = Path(sys.executable).with_name("vecpin")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "vecpin"]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run(cmd + list(args), capture_output=True, text=True, env=env)


def tool_options(kind: str) -> list[str]:
    return ["--tool-link", "tool0", "--tool-axis=+z"] if kind == "arm" else []


def noise_options(truth: dict, stated: bool) -> list[str]:
    """The instrument's and the machine's noise as their specs state them (the truth's), or nothing
    (vecpin's defaults)."""
    if not stated:
        return []
    out = ["--tracker-noise", *(f"{v:.6g}" for v in truth["tracker_noise"])]
    if truth["repeatability_mm"] > 0:
        out += ["--repeatability-mm", f"{truth['repeatability_mm']:.6g}"]
    if truth["repeatability_deg"] > 0:
        out += ["--repeatability-deg", f"{truth['repeatability_deg']:.6g}"]
    return out


# vecpin's names of one family: its twin-drive yaw (varying with the beam and the carriage together) is a gantry skew
SAME_FAMILY = {"twin_skew": "gantry_skew"}


def family_of(name: str) -> str:
    """The family name (:data:`VECPIN_NAME`'s) of one of vecpin's effect names."""
    return SAME_FAMILY.get(name, name)


def named_effects(diag: dict) -> tuple[set[str], set[str]]:
    """(names vecpin accepted, names in the ambiguity groups of accepted effects), vecpin's effect names."""
    named, groups = set(), set()
    for e in diag.get("effects", []):
        if e.get("accepted"):
            named.add(family_of(e["name"]))
            for alt in e.get("alternatives") or []:
                groups.add(family_of(alt.get("name") if isinstance(alt, dict) else str(alt).split("[")[0]))
    if diag.get("outlier_lines"):
        named.add("outliers")
    return named, groups


def score_one(truth: dict, diag: dict) -> dict:
    """One campaign's verdict: hit, wrong names, gross rows found and missed."""
    named, groups = named_effects(diag)
    want = truth["vecpin_name"]
    hit = want is not None and (want in named or want in groups)
    wrong = sorted(n for n in named if n != want and not (want in groups and n in _group_names(diag, want)))
    flagged = set(diag.get("outlier_lines") or [])
    true_gross = set(truth["gross_lines"])
    sizes = [len(e.get("alternatives") or []) + 1 for e in diag.get("effects", []) if e.get("accepted")]
    return {"hit": hit, "named": sorted(named), "wrong": wrong, "status": true_status(diag, want),
            "group": max(sizes, default=0), "via_group": hit and want not in named, "also": sorted(groups - named),
            "gross_found": len(flagged & true_gross),
            "gross_true": len(true_gross), "gross_false": len(flagged - true_gross)}


def true_status(diag: dict, want: str | None) -> str:
    """What the diagnosis made of the true effect's candidates (the best of them)."""
    if want is None:
        return "-"
    mine = [e for e in diag.get("effects", []) if family_of(e["name"]) == want]
    if want == "outliers" and diag.get("outlier_lines"):
        return "accepted"
    for status, key in (("accepted", "accepted"), ("significant, not accepted", "significant"),
                        ("detected, too small to name", "detected_but_small")):
        if any(e.get(key) for e in mine):
            return status
    if not mine:
        return "not tried"
    return f"not significant (best shrink {max(e.get('shrink_pct') or 0.0 for e in mine):.1f} %)"


def _group_names(diag: dict, want: str) -> set[str]:
    """Accepted effects whose ambiguity group holds ``want`` (naming them is naming the group)."""
    out = set()
    for e in diag.get("effects", []):
        alts = {family_of(a.get("name") if isinstance(a, dict) else str(a).split("[")[0])
                for a in e.get("alternatives") or []}
        if e.get("accepted") and want in alts:
            out.add(family_of(e["name"]))
    return out


def run_campaign(seed: int, work: Path, stated: bool = True, family: str = "random") -> dict:
    """Draw, write, diagnose and score one campaign; its record (truth, verdict, seconds)."""
    if family == "gross":   # either kind of gross errors, by the seed (the validation after gross errors)
        family = ("gross_isolated", "gross_cluster")[seed % 2]
    camp = draw_campaign(seed, family=None if family == "clean" else family)
    paths = camp.write(work / str(seed))
    truth = camp.truth_record()
    t0 = time.perf_counter()
    out = work / str(seed) / "diag"
    res = vecpin_cmd("diagnose", str(paths["urdf"]), str(paths["csv"]), "--out", str(out), "--quiet",
                     *tool_options(truth["kind"]), *noise_options(truth, stated))
    seconds = time.perf_counter() - t0
    rec = {"seed": seed, "truth": truth, "seconds": seconds}
    if res.returncode != 0:
        rec["error"] = (res.stderr.strip().splitlines() or ["exit %d" % res.returncode])[-1]
        return rec
    diag = json.loads((out / "diagnosis.json").read_text())
    rec.update(score_one(truth, diag))
    bases = ((diag.get("base") or {}).get("choice") or {}).get("chosen", {}).get("bases", {})
    rec["base_on_axes"] = ", ".join(f"{a}: {bases[a]}" for a in truth["effect_axes"] if a in bases)
    rec["headline"] = diag.get("headline", [""])[1] if len(diag.get("headline", [])) > 1 else ""
    rec["stated_um"] = stated_size(diag, truth)
    if truth["gross_lines"]:   # validation after gross errors (unseen_gross): the diagnosis' model, a clean fit
        rec["validation"] = gross_validation(vecpin_cmd, camp, paths, out,
                                             [*tool_options(truth["kind"]), *noise_options(truth, stated)])
    return rec


def stated_size(diag: dict, truth: dict) -> float | None:
    """The detection size [µm] the diagnosis states for the true effect: its family's candidate on the true effect's
    axes (a per-turn harmonic of C: ``rotary_periodic[C]``, not the family's easiest axis), else the smallest of the
    family's candidates."""
    fams = [f for f in diag.get("detection", [])
            if family_of(f["effect"]) == truth["vecpin_name"] and f.get("detectable_rms_um") is not None]
    axes = set(truth.get("effect_axes") or ())
    own = [um for f in fams for label, um in (f.get("per_candidate_um") or {}).items()
           if axes and um is not None and set(label.partition("[")[2].rstrip("]").split(",")) == axes]
    sizes = own or [f["detectable_rms_um"] for f in fams]
    return min(sizes) if sizes else None


def model_choice(seed: int, work: Path, stated: bool = True) -> dict:
    """Fit the default choice and the fixed candidates on a clean 3-tool campaign; each model's true
    held-out mean error (mm) on 150 fresh commands x 3 tools read without noise from the truth."""
    rng = np.random.default_rng(seed)
    kind = str(rng.choice(["head", "gantry", "arm"]))
    camp = draw_campaign(seed, kind=kind, family=None, n_tools=3)
    folder = work / f"choice_{seed}"
    paths = camp.write(folder)
    held = folder / "heldout_truth.csv"
    held.write_text(heldout_csv(camp, 150, seed + 1))
    out = {"seed": seed, "kind": kind, "models": {}}
    runs = [("chosen", [])] + [(f"{m}/{b}/{o}", ["--model", m, "--basis", b, "--order", o]) for m, b, o in CANDIDATES]
    for label, opts in runs:
        model = folder / f"model_{label.replace('/', '_')}.json"
        fit = vecpin_cmd("fit", str(paths["urdf"]), str(paths["csv"]), "--out", str(model), "--quiet",
                         *opts, *tool_options(kind), *noise_options(camp.truth_record(), stated))
        if fit.returncode != 0:
            out["models"][label] = None
            continue
        ev_json = folder / f"eval_{label.replace('/', '_')}.json"
        ev = vecpin_cmd("evaluate", str(model), str(held), "--json", str(ev_json))
        out["models"][label] = json.loads(ev_json.read_text())["model_residual"]["all"]["mean"] \
            if ev.returncode == 0 else None
    return out


DETECT_FAMILIES = ("harmonic", "coupled", "backlash", "thermal", "shift", "skew")
FACTORS = (1.0, 2.0)


def detection_check(seed: int, family: str, work: Path, stated: bool = True) -> dict:
    """The stated detection size checked: the campaign of ``seed`` without its effect (size 0: the same machine,
    commands and noise) diagnosed, the size it states for the family read, and the same campaign with the
    generator's effect at 1x and 2x that size diagnosed again: was it named (alone or in its group)?"""
    name = VECPIN_NAME[family]
    rec = {"seed": seed, "family": family, "named": {}}
    clean = draw_campaign(seed, family=family, size_mm=0.0)
    rec["kind"], rec["axes"] = clean.truth_record()["kind"], clean.truth_record()["effect_axes"]
    diag = _diagnose(clean, work / f"det_{seed}_0", stated)
    fam = {f["effect"]: f for f in (diag or {}).get("detection", [])}.get(name)
    if not fam or fam.get("detectable_rms_um") is None:
        rec["stated_um"] = None
        return rec
    rec["stated_um"] = fam["detectable_rms_um"]
    for k in FACTORS:
        camp = draw_campaign(seed, family=family, size_mm=k * rec["stated_um"] * 1e-3)
        d = _diagnose(camp, work / f"det_{seed}_{k:g}", stated)
        named, groups = named_effects(d or {})
        rec["named"][k] = (name in named or name in groups, camp.truth_record()["size_mm"] * 1e3)
    return rec


def _checked(seed: int, family: str, work: Path, stated: bool) -> dict | None:
    """:func:`detection_check`, None when the layout drawn cannot carry the family."""
    try:
        return detection_check(seed, family, work, stated)
    except ValueError:
        return None


def _diagnose(camp, folder: Path, stated: bool) -> dict | None:
    """``vecpin diagnose`` of a drawn campaign: its diagnosis.json, None when it failed."""
    paths = camp.write(folder)
    truth = camp.truth_record()
    res = vecpin_cmd("diagnose", str(paths["urdf"]), str(paths["csv"]), "--out", str(folder / "diag"), "--quiet",
                     *tool_options(truth["kind"]), *noise_options(truth, stated))
    return json.loads((folder / "diag" / "diagnosis.json").read_text()) if res.returncode == 0 else None


def _detection_lines(checks: list[dict]) -> list[str]:
    if not checks:
        return []
    lines = ["", CHECKED.strip(), "",
             "Each campaign diagnosed without its effect (the same machine, commands and noise); the generator's "
             "effect then injected at 1x and 2x the size that diagnosis states for the family "
             "(`detection` in diagnosis.json) and diagnosed again: named (alone or in its ambiguity group) or not.", "",
             "| seed | layout | family | axes | stated µm | " + " | ".join(f"named at {k:g}x" for k in FACTORS) + " |",
             "|---|---|---|---|---|" + "---|" * len(FACTORS)]
    for c in checks:
        cells = " | ".join(("yes" if c["named"][k][0] else "no") + f" ({c['named'][k][1]:.1f} µm)"
                           if k in c["named"] else "-" for k in FACTORS)
        stated = "-" if c["stated_um"] is None else f"{c['stated_um']:.1f}"
        lines.append(f"| {c['seed']} | {c['kind']} | {c['family']} | {','.join(c['axes'])} | {stated} | {cells} |")
    done = [c for c in checks if c["named"]]
    lines += [""] + [f"* named at {k:g}x the stated size: {frac(sum(c['named'][k][0] for c in done), len(done))}"
                     for k in FACTORS]
    return lines


def summary(records: list[dict], choices: list[dict], how: str, checks: list[dict] = (),
            family: str = "random") -> list[str]:
    """The results page: per-family figures, clean campaigns, gross rows, model choice, every campaign
    (``family``: the family drawn, named in the title when the run draws one only)."""
    ok = [r for r in records if "error" not in r]
    clean = [r for r in ok if r["truth"]["family"] is None]
    title = "# vecpin on unseen machines (issue 40)"
    lines = [title if family == "random" else f"{title[:-11]}: {family} campaigns only (issue 40)", "",
             f"Written by `python benchmarks/bench_unseen.py` ({how}). Machines, errors and campaigns are drawn by",
             "`benchmarks/generator`, written blind to vecpin's simulator and models; vecpin is run as",
             "`vecpin diagnose URDF CSV --out DIR` and judged on its diagnosis.json. Intervals: Wilson 95 %.", "",
             OWN, "",
             f"* campaigns: {len(records)} ({len(records) - len(ok)} refused or failed), "
             f"{np.mean([r['seconds'] for r in records]):.1f} s per diagnosis on average "
             f"({np.median([r['truth']['rows'] for r in records]):.0f} rows median)",
             f"* clean campaigns silent: {frac(sum(not r['named'] for r in clean), len(clean))}",
             f"* campaigns naming a wrong effect (spurious): {frac(sum(bool(r['wrong']) for r in ok), len(ok))}; "
             f"wrong names per campaign {np.mean([len(r['wrong']) for r in ok]) if ok else 0:.2f}",
             _gross_line(ok), _group_line(ok), "",
             f"Recall counts effects of at least {RECALL_SIZE_MM * 1e3:.0f} µm RMS at the tip "
             "(gross errors: all); *≥ its detection size*: effects at least the size the campaign's own diagnosis "
             "states it would detect for that family (`detection`: its candidate on the true effect's axes where the "
             "family has one; an effect named whose family has no stated size left is counted); precision is over "
             "every name vecpin gave of that family; *missed but seen*: the true effect was significant but not "
             "accepted, or detected but too small to name.", "",
             f"| family | vecpin name | campaigns | recall (size ≥ {RECALL_SIZE_MM * 1e3:.0f} µm) | recall (≥ its "
             "detection size) | recall (all sizes) | precision | missed but seen | missed, not tried |",
             "|---|---|---|---|---|---|---|---|---|"]
    for fam in FAMILIES:
        mine = [r for r in ok if r["truth"]["family"] == fam]
        big = [r for r in mine if fam.startswith("gross") or r["truth"]["size_mm"] >= RECALL_SIZE_MM]
        name = VECPIN_NAME[fam]
        said = [r for r in ok if name in r["named"]]
        right = [r for r in said if r["truth"]["vecpin_name"] == name]
        seen = [r for r in mine if fam.startswith("gross") or (r["hit"] and r.get("stated_um") is None)
                or (r.get("stated_um") is not None and r["truth"]["size_mm"] * 1e3 >= r["stated_um"])]
        names = ", ".join([name] + [k for k, v in SAME_FAMILY.items() if v == name])
        lines.append(f"| {fam} | {names} | {len(mine)} | {frac(sum(r['hit'] for r in big), len(big))} | "
                     f"{frac(sum(r['hit'] for r in seen), len(seen))} | "
                     f"{frac(sum(r['hit'] for r in mine), len(mine))} | {frac(len(right), len(said))} | "
                     f"{sum(not r['hit'] and r['status'].startswith(('signif', 'detected')) for r in mine)} | "
                     f"{sum(not r['hit'] and r['status'] == 'not tried' for r in mine)} |")
    lines += ["", "Wrong names given, by the campaign's true family:", ""]
    conf = Counter((r["truth"]["family"] or "clean", w) for r in ok for w in r["wrong"])
    lines += [f"* {t}: {w} x{n}" for (t, w), n in sorted(conf.items())] or ["* none"]
    lines += validation_lines(ok, frac) + _choice_lines(choices) + _detection_lines(checks) + _campaign_lines(records)
    return lines


def _group_line(ok: list[dict]) -> str:
    grouped = [r for r in ok if r.get("group", 0) > 1]
    return (f"* campaigns answered with an ambiguity group (\"A or B: this data cannot tell them apart\"): "
            f"{len(grouped)}, of {np.mean([r['group'] for r in grouped]) if grouped else 0:.1f} members on average; "
            f"true effect named only through its group: {sum(r.get('via_group', False) for r in ok)}")


def _gross_line(ok: list[dict]) -> str:
    found = sum(r["gross_found"] for r in ok)
    true = sum(r["gross_true"] for r in ok)
    false = sum(r["gross_false"] for r in ok)
    return (f"* gross-error rows found: {frac(found, true)}; rows flagged that carry no gross error: {false} "
            f"in {len(ok)} campaigns")


def _choice_lines(choices: list[dict]) -> list[str]:
    if not choices:
        return []
    lines = ["", "## Model choice on multi-target campaigns", "",
             "Clean campaigns with three tools; true held-out mean error, µm, on 150 fresh commands x 3 tools",
             "(noise-free readings of the truth in the campaign's tracker frame, `vecpin evaluate` of each model). "
             "Regret: chosen minus the best candidate.", "",
             "| seed | layout | chosen | " + " | ".join("/".join(c) for c in CANDIDATES)
             + " | regret | chosen / best |",
             "|---|---|---|" + "---|" * len(CANDIDATES) + "---|---|"]
    ratios = []
    for c in choices:
        vals = [c["models"].get("/".join(k)) for k in CANDIDATES]
        good = [v for v in vals if v is not None]
        chosen = c["models"].get("chosen")
        cells = " | ".join("-" if v is None else f"{v * 1e3:.1f}" for v in vals)
        if chosen is None or not good:
            lines.append(f"| {c['seed']} | {c['kind']} | - | {cells} | - | - |")
            continue
        best = min(good)
        ratios.append(chosen / best)
        lines.append(f"| {c['seed']} | {c['kind']} | {chosen * 1e3:.1f} | {cells} | {(chosen - best) * 1e3:+.1f} | "
                     f"{chosen / best:.2f} |")
    if ratios:
        lines += ["", f"Chosen / best candidate: median {np.median(ratios):.2f}, worst {max(ratios):.2f}; "
                  f"chosen within 10 % of the best in {frac(sum(r <= 1.1 for r in ratios), len(ratios))}."]
    return lines


def _campaign_lines(records: list[dict]) -> list[str]:
    lines = ["", "## Every campaign", "", "The true effect's status: the best of its candidates in diagnosis.json; "
             "for a missed effect, the base model's basis on its axes.", "",
             "| seed | layout | rows | truth | size µm | its detection size µm | vecpin named (or, its group) "
             "| verdict "
             "| true effect's status | s |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in records:
        t = r["truth"]
        truth = (t["family"] or "clean") + (f" [{','.join(t['effect_axes'])}]" if t["effect_axes"] else "")
        size = "-" if t["size_mm"] is None else f"{t['size_mm'] * 1e3:.0f}"
        if "error" in r:
            verdict, named, status = "error: " + r["error"].replace("|", "/")[:90], "-", "-"
        else:
            named, status = ", ".join(r["named"]) or "nothing", r["status"]
            named += f" (or {', '.join(r['also'])})" if r.get("also") else ""
            if not r["hit"] and r.get("base_on_axes"):
                order = (t.get("params") or {}).get("order_per_turn")
                status += f"; base {r['base_on_axes']}" + (f" (true order per turn {order})" if order else "")
            verdict = ("hit" if r["hit"] else ("silent" if t["family"] is None and not r["named"] else "missed")) \
                + (f"; wrong: {', '.join(r['wrong'])}" if r["wrong"] else "")
        stated = "-" if r.get("stated_um") is None else f"{r['stated_um']:.0f}"
        lines.append(f"| {r['seed']} | {t['kind']} | {t['rows']} | {truth} | {size} | {stated} | {named} | {verdict} | "
                     f"{status} | {r['seconds']:.0f} |")
    return lines


CHECKED = "\n## The stated detection size, checked\n"


def page_with(text: str, page: Path = RESULT) -> str:
    """The results page with ``text``. A fresh run's page keeps the detection check already on the page
    when it made none; a run of detection checks alone (``text`` opening with that section) replaces that
    section only. (Held-out runs write docs/results/heldout.md: :mod:`heldout`.)"""
    old = page.read_text(encoding="utf-8") if page.exists() else ""
    main, _, checked = old.partition(CHECKED)
    title = "# vecpin on unseen machines (issue 40)\n"
    if text.startswith(CHECKED):
        return (main or title).rstrip("\n") + "\n" + text
    keep = CHECKED + checked if checked and CHECKED not in text else ""
    return text.rstrip("\n") + "\n" + keep


def seeds(args) -> tuple[list[int], str]:
    if args.heldout:
        return heldout_seeds("unseen", args.n), f"the first {args.n} held-out seeds (benchmarks/heldout.py)"
    start = args.seed if args.seed is not None else secrets.randbelow(2 ** 31)
    return list(range(start, start + args.n)), f"seeds {start}..{start + args.n - 1}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", type=int, default=20, help="campaigns to diagnose (default 20)")
    ap.add_argument("--seed", type=int, help="first seed (default: a fresh random one every run)")
    ap.add_argument("--heldout", action="store_true",
                    help="the held-out seeds: committed code only, the summary only, added to docs/results/heldout.md")
    ap.add_argument("--family", default="random", choices=["random", "clean", "gross", *FAMILIES],
                    help="draw only campaigns of this effect family; gross: isolated or clustered gross errors "
                         "(default: random, a quarter clean)")
    ap.add_argument("--choice", type=int, default=4, help="multi-target campaigns for model choice (default 4)")
    ap.add_argument("--detection", type=int, default=0,
                    help="campaigns on which to check the stated detection size (default 0; 3 diagnoses each)")
    ap.add_argument("--default-noise", action="store_true",
                    help="run vecpin with its default noise (default: the tracker's and the axes' stated noise)")
    ap.add_argument("--no-write", action="store_true", help=f"print only, do not write {RESULT.relative_to(ROOT)}")
    ap.add_argument("--jobs", type=int, default=1, help="campaigns diagnosed at once (default 1)")
    ap.add_argument("--page", type=Path, default=RESULT, help=f"the page to write (default {RESULT.relative_to(ROOT)})")
    args = ap.parse_args()
    held = Run("unseen", args.n) if args.heldout else None   # refused on uncommitted code
    say = (lambda text: None) if held is not None else (lambda text: print(text, flush=True))   # no draw's details
    todo, how = seeds(args)
    how += "" if args.family == "random" else f"; only {args.family} campaigns"
    how += ("; vecpin's default noise" if args.default_noise
            else "; noise as stated: `--tracker-noise`, `--repeatability-mm`, `--repeatability-deg`")
    t0 = time.perf_counter()
    records, choices, checks = [], [], []

    def write(note: str = "") -> str:
        """The page as it stands (``note``: what is still to come), written unless --no-write."""
        lines = (summary(records, choices, f"{how}; {time.perf_counter() - t0:.0f} s{note}", checks,
                         args.family)
                 if records else _detection_lines(checks))
        if held is not None:   # the summary only, on the held-out page
            return held.write(lines, final=note == " in all") if not args.no_write else "\n".join(aggregate(lines))
        text = "\n".join(lines) + "\n"
        if not args.no_write:
            args.page.write_text(page_with(text, args.page), encoding="utf-8")
        return text

    with tempfile.TemporaryDirectory(prefix="unseen_") as tmp, ThreadPoolExecutor(max(args.jobs, 1)) as pool:
        runs = pool.map(lambda s: run_campaign(s, Path(tmp), not args.default_noise, args.family), todo)
        for r in runs:
            records.append(r)
            if held is not None:
                held.progress(len(records))
            say(f"seed {r['seed']} {r['truth']['kind']:<10} {r['truth']['family'] or 'clean':<14} -> "
                  f"{r.get('error') or ', '.join(r['named']) or 'nothing'}  ({r['seconds']:.1f} s)")
            if len(records) % 10 == 0 and len(records) < len(todo):
                write(f" so far: interim page, {len(records)} of {len(todo)} campaigns")
        first = todo[0] if todo else (args.seed if args.seed is not None else secrets.randbelow(2 ** 31))
        plan = [(first + 104729 + i, DETECT_FAMILIES[i % len(DETECT_FAMILIES)]) for i in range(args.detection)]
        for c in pool.map(lambda sf: _checked(sf[0], sf[1], Path(tmp), not args.default_noise), plan):
            if c is None:   # the layout drawn cannot carry the family
                continue
            checks.append(c)
            say(f"detection {c['seed']} {c['family']}: stated {c['stated_um']} um, named "
                  + ", ".join(f"{k:g}x {v[0]} ({v[1]:.1f} um)" for k, v in c["named"].items()))
            write(f" so far: interim page, {len(checks)} detection checks done, model choice to come")
        for s in todo[: args.choice]:
            choices.append(model_choice(s + 7919, Path(tmp), not args.default_noise))
            figs = [f"{k} {'-' if v is None else f'{v * 1e3:.1f} um'}" for k, v in choices[-1]["models"].items()]
            say(f"choice {s + 7919} {choices[-1]['kind']}: " + ", ".join(figs))
            write(f" so far: interim page, model choice {len(choices)} of {min(args.choice, len(todo))}")
    print(write(" in all"))
    if not args.no_write:
        print(f"wrote {args.page if held is None else held.page}")

if __name__ == "__main__":
    main()
