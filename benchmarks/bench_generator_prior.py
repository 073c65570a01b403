"""The smoothness prior against the default model choice on the blind generator's machines (issue 40).

Fresh draws from ``benchmarks/generator`` (written blind to vecpin), the classes that take tables in turn,
each fitted twice from the same noisy campaign without the nests' heights (the *no heights* arm of
benchmarks/bench_generator_tables.py): ``vecpin fit`` with the default model choice (a series and an order
per axis on held-out data) and ``vecpin fit --basis smooth`` (vecpin.fitting.smoothprior: rich bases, a
Gaussian smoothness prior whose scales the evidence chooses; no fact of the generator enters it), the
stated noise either way; ``vecpin tables`` (generic). Judged as bench_generator_tables.py judges (its
code: the generator's kinematics as the truth, tests/part_frame_judge.py's reader): the true tip relative
to the true table on 600 fresh commands x the tools, mean [mm], against *best* (the best values for the
same tables, from the truth) and *achievable* (the best values for them from the oracle's posterior mean
of the same campaign, benchmarks/gentables_oracle.py). This runs only those two arms (the whole bench
runs them beside its others).

With ``--heights`` both are also fitted given every table nest's exact height above the table's face.

Run: python benchmarks/bench_generator_prior.py [-n 8] [--seed S] [--kinds table head_table ...] [--heights]
     [--json F] [--from-json F ...] [--out docs/results/generator_prior.md]
"""
from __future__ import annotations

import argparse
import json
import os
import secrets
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):   # one thread: the machine is shared
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from bench_generator_tables import (KINDS, PRIOR_OPTIONS, BestSets, Truth, side_run)  # noqa: E402
from generator import draw_campaign  # noqa: E402
from gentables_oracle import estimated_campaign  # noqa: E402
from gentables_page import N_JUDGE, TABLE_KINDS, TARGET  # noqa: E402

RESULT = HERE.parent / "docs" / "results" / "generator_prior.md"
ARMS = (("no-heights", "default choice", ()), ("prior", "smooth prior", PRIOR_OPTIONS))
# with --heights: both fits given every nest's exact height above the table's face (--nest-height)
HEIGHT_ARMS = (("exact-heights", "default choice, exact heights", ()),
               ("prior-exact-heights", "smooth prior, exact heights", PRIOR_OPTIONS))


def one_draw(seed: int, kind: str, work: Path, heights: bool = False) -> dict:
    """Both arms (``heights``: and both given the exact heights) on one fresh machine, judged against
    best and achievable (part and shape)."""
    camp = draw_campaign(seed, kind=kind, family=None)
    truth = Truth(camp)
    q, tool = truth.commands(N_JUDGE, seed + 7919)
    bests = BestSets(truth, seed + 104729)
    oracle = BestSets(Truth(estimated_campaign(camp)), seed + 104729)
    rec = {"seed": seed, "kind": kind, "axes": truth.axes, "commands": int(len(next(iter(camp.q.values()))))}
    for name, _, extra in ARMS + (HEIGHT_ARMS if heights else ()):
        t0 = time.perf_counter()
        rec[name] = side_run(camp, work / str(seed) / name, truth, bests, q, tool,
                             0.0 if "heights" in name and name != "no-heights" else None, extra, oracle)
        rec[name]["seconds"] = time.perf_counter() - t0
    return rec


def ratio(rec: dict, arm: str, frame: str = "part", per: str = "best") -> float | None:
    sub = rec.get(arm) or {}
    return None if "vecpin" not in sub else sub["vecpin"][frame] / sub[per][frame]


def _stats(v) -> str:
    v = np.asarray([x for x in v if x is not None])
    return f"median {np.median(v):.2f}, max {v.max():.2f}, within {TARGET}: {int((v <= TARGET).sum())} of {len(v)}" \
        if len(v) else "-"


def page(records: list[dict], how: str) -> str:
    """The results page: the summary per arm and frame, then every draw."""
    ok = [r for r in records if all("vecpin" in (r.get(a) or {}) for a, _, _ in ARMS)]
    lines = ["# The smoothness prior on the generator's machines (issue 40)", "",
             f"`python benchmarks/bench_generator_prior.py` ({how}; the module text says what is judged and how).",
             "", "## summary", ""]
    for frame in ("part", "shape"):
        for group, keep in (("table machines", lambda r: r["kind"] in TABLE_KINDS), ("every class", lambda r: True)):
            rows = [r for r in ok if keep(r)]
            for arm, text, _ in ARMS + HEIGHT_ARMS:
                if not any(arm in r for r in rows):
                    continue
                lines.append(f"- {frame}, {group}: {text} / best {_stats(ratio(r, arm, frame) for r in rows)}; "
                             f"{text} / achievable {_stats(ratio(r, arm, frame, 'achievable') for r in rows)}")
            lines.append(f"- {frame}, {group}: achievable / best (the smooth prior's tables) "
                         f"{_stats(r['prior']['achievable'][frame] / r['prior']['best'][frame] for r in rows)}")
            pairs = np.array([(ratio(r, "prior", frame), ratio(r, "no-heights", frame)) for r in rows])
            if len(pairs):
                mm = np.median([r["prior"]["vecpin"][frame] / r["no-heights"]["vecpin"][frame] for r in rows])
                below = int((pairs[:, 0] < pairs[:, 1]).sum())
                lines.append(f"- {frame}, {group}: smooth prior / default (vecpin's tables, mm / mm) median {mm:.2f}; "
                             f"the prior's ratio to best below the default's in {below} of {len(pairs)}")
    lines += ["", "`vecpin fit` seconds (median, a process each, on a machine shared with other jobs): " + ", ".join(
        f"{text} {np.median([r[a]['fit_s'] for r in ok]):.0f}" for a, text, _ in ARMS) if ok else "", "",
        "## per draw (vecpin / best, vecpin / achievable; part, then shape)", "",
        "| seed | class | axes | commands | default / best | default / achievable | prior / best | prior / achievable "
        "| default / best (shape) | default / achievable (shape) | prior / best (shape) | prior / achievable (shape) "
        "| default model | prior model |", "|---|---|---|---|" + "---|" * 10]
    for r in records:
        if r not in ok:
            err = "; ".join(str((r.get(a) or {}).get("error", "")) for a, _, _ in ARMS)
            lines.append(f"| {r['seed']} | {r['kind']} | {''.join(r['axes'])} | failed: {err} |")
            continue
        cells = [f"{ratio(r, a, fr, per):.2f}" for fr in ("part", "shape") for a in ("no-heights", "prior")
                 for per in ("best", "achievable")]
        lines.append(f"| {r['seed']} | {r['kind']} | {''.join(r['axes'])} | {r['commands']} | {' | '.join(cells)} | "
                     f"{r['no-heights'].get('label', '')} | {r['prior'].get('label', '')} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", type=int, default=8, help="draws (default 8)")
    ap.add_argument("--seed", type=int, default=None, help="first seed (default: fresh)")
    ap.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS)
    ap.add_argument("--out", default=str(RESULT))
    ap.add_argument("--heights", action="store_true",
                    help="also both fits given the nests' exact heights (arms exact-heights, prior-exact-heights)")
    ap.add_argument("--json", default=None, help="also write every record here")
    ap.add_argument("--from-json", nargs="+", default=None, help="write the page from records saved by --json")
    args = ap.parse_args(argv)
    if args.from_json:
        records = [r for f in args.from_json for r in json.loads(Path(f).read_text())]
        seeds = sorted(r["seed"] for r in records)
        Path(args.out).write_text(page(records, f"{len(records)} draws, seeds {seeds[0]}..{seeds[-1]} in "
                                                f"{len(args.from_json)} runs, classes in turn"))
        print(f"wrote {args.out}")
        return
    first = args.seed if args.seed is not None else secrets.randbelow(10**8)
    records = []
    with tempfile.TemporaryDirectory(prefix="vecpin_genprior_") as tmp:
        for i in range(args.n):
            rec = one_draw(first + i, args.kinds[i % len(args.kinds)], Path(tmp), args.heights)
            records.append(rec)
            print(json.dumps(rec), flush=True)
            if args.json:
                Path(args.json).write_text(json.dumps(records, indent=1))
    Path(args.out).write_text(page(records, f"{args.n} draws from seed {first}, classes {', '.join(args.kinds)} "
                                            "in turn"))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
