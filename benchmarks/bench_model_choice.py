"""vecpin's model choice judged on the generator's multi-target campaigns (issue 40).

Every draw is a fresh clean campaign of ``benchmarks/generator`` (written blind: it shares no code
and no assumption with vecpin's models): a random layout of the kind asked (6R arms by default),
smooth Gaussian-process errors, spherical tracker noise, and three targets read at every pose (tool
points at three distances along the tool axis). vecpin is called as a user calls it:
``vecpin fit URDF CSV`` with no model option (the default: the data choose kind, basis and orders
by cross-validation with every target of a pose in one fold), and beside it each fixed candidate of
:data:`CANDIDATES` (``vecpin fit --model --basis --order``). Each model's true held-out error is
``vecpin evaluate`` of it on noise-free readings of the generator's truth at 150 fresh commands x
the three targets (the campaign's tracker frame): what the truth says, not what a fold guesses.

Figures: per draw the chosen model's mean error against the best candidate's (an oracle: the one
with the lowest true error, chosen after seeing the truth); the target is the chosen model within
10 % of the best. Every vecpin run is given the tracker's and the axes' noise as their specs state
them (the truth's figures).

Run: python benchmarks/bench_model_choice.py [-n 10] [--seed S | --heldout] [--kind arm] [--jobs 2] [--no-write]
Fresh seeds every run unless --seed; --heldout: the held-out seeds of ``benchmarks/heldout.py`` (committed code
only, no draw's details shown, the summary added to docs/results/heldout.md; run it once per stop, never tune).
"""
from __future__ import annotations

import argparse
import json
import secrets
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from bench_unseen import frac, noise_options, tool_options, vecpin_cmd  # noqa: E402
from generator import draw_campaign, heldout_csv  # noqa: E402
from heldout import Run, aggregate, heldout_seeds  # noqa: E402
from results_page import publish  # noqa: E402

RESULT = ROOT / "docs" / "results" / "model_choice.md"
#: the fixed candidates (model, basis, order): constant 6-DoF errors (a geometric calibration), 6-DoF
#: series of low and higher order, the AP model, and 6-DoF penalised splines
CANDIDATES = [("6dof", "chebyshev", "0"), ("6dof", "chebyshev", "2"), ("6dof", "chebyshev", "4"),
              ("ap", "chebyshev", "2"), ("ap", "chebyshev", "4"), ("6dof", "pspline", "auto")]
TARGETS = 3        # targets read at every pose
HELD_COMMANDS = 150
WITHIN = 1.10      # the target: chosen at most this times the best candidate


def one_draw(seed: int, kind: str, work: Path) -> dict:
    """Fit the default and every candidate on draw ``seed``; each model's true held-out mean [mm]
    (None where vecpin refused) and the chosen model's kind and terms."""
    camp = draw_campaign(seed, kind=kind, family=None, n_tools=TARGETS)
    folder = work / f"draw_{seed}"
    paths = camp.write(folder)
    held = folder / "heldout_truth.csv"
    held.write_text(heldout_csv(camp, HELD_COMMANDS, seed + 1))
    out = {"seed": seed, "kind": kind, "rows": len(camp.rows.tool_m), "models": {}, "chosen": ""}
    t0 = time.perf_counter()
    for label, opts in [("chosen", [])] + [("/".join(c), ["--model", c[0], "--basis", c[1], "--order", c[2]])
                                           for c in CANDIDATES]:
        model = folder / f"model_{label.replace('/', '_')}.json"
        fit = vecpin_cmd("fit", str(paths["urdf"]), str(paths["csv"]), "--out", str(model), "--quiet", *opts,
                         *tool_options(kind), *noise_options(camp.truth_record(), True))
        if fit.returncode != 0:
            out["models"][label] = None
            continue
        if label == "chosen":
            c = json.loads(model.read_text()).get("selection", {}).get("chosen", {})
            out["chosen"] = f"{c.get('kind', '?')}, {c.get('model_terms', '?')} terms"
        ev_json = folder / f"eval_{label.replace('/', '_')}.json"
        ev = vecpin_cmd("evaluate", str(model), str(held), "--json", str(ev_json))
        out["models"][label] = (json.loads(ev_json.read_text())["model_residual"]["all"]["mean"]
                                if ev.returncode == 0 else None)
    out["seconds"] = time.perf_counter() - t0
    return out


def ratio(d: dict) -> float | None:
    """The chosen model's true held-out mean over the best candidate's (None if either is missing)."""
    good = [v for k, v in d["models"].items() if k != "chosen" and v is not None]
    chosen = d["models"].get("chosen")
    return None if chosen is None or not good else chosen / min(good)


def page(draws: list[dict], how: str) -> str:
    """The results page."""
    lines = ["# Model choice on the generator's multi-target campaigns", "",
             "Written by `python benchmarks/bench_model_choice.py` (module docstring: the draws, the candidates, "
             f"the judge). {how}. True held-out mean error, µm, of each model on {HELD_COMMANDS} fresh commands x "
             f"{TARGETS} targets read without noise from the generator's truth; best: the candidate with the lowest "
             "(an oracle). Target: the default's choice within 10 % of the best.", "",
             "| seed | layout | rows | chosen (default) | " + " | ".join("/".join(c) for c in CANDIDATES)
             + " | chosen / best |", "|---|---|---|---|" + "---|" * len(CANDIDATES) + "---|"]
    ratios = []
    for d in draws:
        cells = " | ".join("-" if d["models"].get("/".join(c)) is None else f"{d['models']['/'.join(c)] * 1e3:.1f}"
                           for c in CANDIDATES)
        ch, r = d["models"].get("chosen"), ratio(d)
        if r is not None:
            ratios.append(r)
        lines.append(f"| {d['seed']} | {d['kind']} | {d['rows']} | "
                     + ("refused" if ch is None else f"{ch * 1e3:.1f} ({d['chosen']})")
                     + f" | {cells} | {'-' if r is None else f'{r:.2f}'} |")
    if ratios:
        r = np.array(ratios)
        lines += ["", f"Chosen / best candidate: median {np.median(r):.2f}, mean {r.mean():.2f}, worst {r.max():.2f}; "
                  f"within 10 % of the best in {frac(int((r <= WITHIN).sum()), len(r))} draws (Wilson 95 %)."]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", type=int, default=10, help="draws (default 10)")
    ap.add_argument("--seed", type=int, help="first seed (default: a fresh random one every run)")
    ap.add_argument("--kind", default="arm", help="the generator's layout kind (default arm)")
    ap.add_argument("--jobs", type=int, default=1, help="draws fitted at once (default 1)")
    ap.add_argument("--heldout", action="store_true",
                    help="the held-out seeds: committed code only, the summary only, added to docs/results/heldout.md")
    ap.add_argument("--no-write", action="store_true", help=f"print only, do not write {RESULT.relative_to(ROOT)}")
    args = ap.parse_args()
    held = Run(f"model_choice {args.kind}", args.n) if args.heldout else None   # refused on uncommitted code
    start = args.seed if args.seed is not None else secrets.randbelow(2 ** 31)
    seeds = heldout_seeds(f"model_choice {args.kind}", args.n) if held else list(range(start, start + args.n))
    how = f"{args.n} {args.kind} draws, " + ("held-out seeds" if held else f"seeds {start}..{start + args.n - 1}")
    t0 = time.perf_counter()
    draws = []
    with tempfile.TemporaryDirectory(prefix="choice_") as tmp, ThreadPoolExecutor(max(args.jobs, 1)) as pool:
        for d in pool.map(lambda s: one_draw(s, args.kind, Path(tmp)), seeds):
            draws.append(d)
            if held is not None:   # no draw's details
                held.progress(len(draws))
                continue
            r = ratio(d)
            print(f"seed {d['seed']}: chosen {d['chosen'] or '-'}; "
                  + ", ".join(f"{k} {'-' if v is None else f'{v * 1e3:.1f}'}" for k, v in d["models"].items())
                  + f" um; chosen/best {'-' if r is None else f'{r:.2f}'} ({d['seconds']:.0f} s)", flush=True)
    text = page(draws, f"{how}; {time.perf_counter() - t0:.0f} s")
    if held is not None:
        lines = text.splitlines()
        print(held.write(lines, final=True) if not args.no_write else "\n".join(aggregate(lines)))
        return
    publish(text, RESULT, not args.no_write)


if __name__ == "__main__":
    main()
