"""The smoothness prior against the default model choice on the bundled machines' simulated truths (issue 40).

For each bundled machine of benchmarks/bench_kinds.py (and Paper I's flow_xyzcb) and seed, vecpin's simulator
draws a true machine (its own error families: the case the default choice was tuned on) and a campaign (the
default design, table nests on table machines, the stated spherical tracker noise), as bench_kinds.py does.
Both fits of the same campaign: the default model choice (``basis="auto"``) and the smooth prior
(``basis="smooth"``, vecpin.fitting.smoothprior). Figures per fit [mm]: the noise-free validation on 300 fresh
commands x Paper I's tools (vecpin.simulation.judge.validation_error: relative to the workpiece on table
machines, after the best rigid registration), the true machine commanded through the model's tables against
the table floor (vecpin.simulation.floor, judged in the machine's reference frame as bench_kinds.py judges),
and the fit's seconds.

Run: python benchmarks/bench_prior_bundled.py [--seeds 2] [--first 1] [--machines ...] [--json F]
     [--from-json F ...] [--out docs/results/prior_bundled.md]
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):   # one thread: the machine is shared
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

import vecpin  # noqa: E402
from bench_kinds import MACHINES  # noqa: E402
from vecpin.compensation.plan import plan_tables  # noqa: E402
from vecpin.measurement.noise import NoiseModel  # noqa: E402
from vecpin.simulation.floor import table_floor, true_compensated_error  # noqa: E402
from vecpin.simulation.judge import validation_commands, validation_error  # noqa: E402
from vecpin.simulation.simulate import Design, simulate  # noqa: E402
from vecpin.workflows.fitting import fit_campaign  # noqa: E402

RESULT = Path(__file__).resolve().parents[1] / "docs" / "results" / "prior_bundled.md"
ARMS = ("auto", "smooth")


def one(name: str, seed: int) -> dict:
    """Both fits of one simulated campaign, judged on the simulator's truth."""
    m = vecpin.Machine.load(name)
    sim = simulate(m, seed=seed, design=Design(n_validation=5))
    noise = NoiseModel.default(m, "spherical", tracker=sim.truth.tracker.noise)
    q, tool = validation_commands(m, 300, seed=7)
    floor = table_floor(sim.truth, q, tool, judged="reference").mean_mm
    rec = {"machine": name, "seed": seed, "rows": len(sim.campaign), "floor": floor}
    for basis in ARMS:
        t0 = time.perf_counter()
        model = fit_campaign(m, sim.campaign, noise, basis=basis).model
        seconds = time.perf_counter() - t0
        tables = plan_tables(model, uncertainty=False).tables
        rec[basis] = {"label": model.label(), "seconds": seconds,
                      "validation": validation_error(model, sim.truth, q, tool)[0],
                      "tables": true_compensated_error(sim.truth, tables, q, tool, "reference")[0]}
    return rec


def page(records: list[dict], how: str) -> str:
    """The results page: per machine and seed both fits, then the ratios smooth / default."""
    val = np.array([r["smooth"]["validation"] / r["auto"]["validation"] for r in records])
    tab = np.array([r["smooth"]["tables"] / r["auto"]["tables"] for r in records])
    lines = ["# The smoothness prior on the bundled machines' simulated truths (issue 40)", "",
             f"`python benchmarks/bench_prior_bundled.py` ({how}; the module text says what is judged and how).", "",
             "## summary (smooth prior / default choice)", "",
             f"- noise-free validation: median {np.median(val):.2f}, min {val.min():.2f}, max {val.max():.2f}; "
             f"the prior lower in {int((val < 1).sum())} of {len(val)}",
             f"- tables on the true machine: median {np.median(tab):.2f}, min {tab.min():.2f}, max {tab.max():.2f}; "
             f"the prior lower in {int((tab < 1).sum())} of {len(tab)}",
             "- tables / floor: " + ", ".join(
                 f"{a} median {np.median([r[a]['tables'] / r['floor'] for r in records]):.2f}" for a in ARMS),
             "- fit seconds (median): " + ", ".join(f"{a} {np.median([r[a]['seconds'] for r in records]):.1f}"
                                                    for a in ARMS), "",
             "## per machine and seed (mm)", "",
             "| machine | seed | rows | default validation | prior validation | default tables / floor | "
             "prior tables / floor | default model | prior model |", "|---|---|---|---|---|---|---|---|---|"]
    for r in records:
        a, s = r["auto"], r["smooth"]
        lines.append(f"| {r['machine']} | {r['seed']} | {r['rows']} | {a['validation']:.4f} | {s['validation']:.4f} | "
                     f"{a['tables']:.4f} / {r['floor']:.4f} = {a['tables'] / r['floor']:.2f} | "
                     f"{s['tables']:.4f} / {r['floor']:.4f} = {s['tables'] / r['floor']:.2f} | {a['label']} | "
                     f"{s['label']} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--first", type=int, default=1, help="first seed (default 1)")
    ap.add_argument("--machines", nargs="+", default=["flow_xyzcb", *MACHINES])
    ap.add_argument("--out", default=str(RESULT))
    ap.add_argument("--json", default=None, help="also write every record here")
    ap.add_argument("--from-json", nargs="+", default=None, help="write the page from records saved by --json")
    args = ap.parse_args(argv)
    if args.from_json:
        records = [r for f in args.from_json for r in json.loads(Path(f).read_text())]
        seeds = sorted({r["seed"] for r in records})
        Path(args.out).write_text(page(records, f"seeds {', '.join(map(str, seeds))}, machines "
                                                f"{', '.join(dict.fromkeys(r['machine'] for r in records))}"))
        print(f"wrote {args.out}")
        return
    records = []
    for name in args.machines:
        for seed in range(args.first, args.first + args.seeds):
            rec = one(name, seed)
            records.append(rec)
            if args.json:
                Path(args.json).write_text(json.dumps(records, indent=1))
            print(f"{name:<20s} {seed} default val {rec['auto']['validation']:.4f} tab/floor "
                  f"{rec['auto']['tables'] / rec['floor']:.2f} ({rec['auto']['seconds']:.0f} s) | prior val "
                  f"{rec['smooth']['validation']:.4f} tab/floor {rec['smooth']['tables'] / rec['floor']:.2f} "
                  f"({rec['smooth']['seconds']:.0f} s) {rec['smooth']['label']}", flush=True)
    Path(args.out).write_text(page(records, f"seeds {args.first}..{args.first + args.seeds - 1}, machines "
                                            f"{', '.join(args.machines)}"))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
