"""Model, tables and verify per machine class (issue 41), and the share of the model's error
that no table of one input axis can follow.

For each bundled machine class a true machine is drawn from vecpin's simulator, a campaign
simulated, vecpin's default fit chooses and fits the model and `vecpin tables` writes the
generic files (the full table set). On 600 fresh random commands x 2 tools in the measured
region, relative to the true table and in the part's frame:

* model: the fitted model's tip against the true machine's, the best rigid motion removed
  (what the model knows of the error's shape);
* tables (model-predicted): the full tables' row of `vecpin tables` (what vecpin promises);
* verify (true): the true machine commanded through the written tables, judged by
  tests/part_frame_judge.py (its own reader of tables.json and its own registrations);
* not followable: the share of the model's error the full tables leave (the
  "what no table can follow" line of `vecpin tables`) and the input pairs it couples.

Run: python benchmarks/bench_machine_classes.py [--out docs/results/machine_classes.md] [--seed N]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from part_frame_judge import judge  # noqa: E402
from results_page import publish  # noqa: E402

import vecpin  # noqa: E402
from vecpin.compensation.frame import measured_box  # noqa: E402
from vecpin.compensation.functions import pseudo_commands  # noqa: E402
from vecpin.compensation.frame import model_as_actual  # noqa: E402
from vecpin.measurement.registration import registered_errors  # noqa: E402
from vecpin.compensation.functions import truth_as_actual  # noqa: E402
from vecpin.measurement.noise import NoiseModel  # noqa: E402
from vecpin.simulation.simulate import simulate  # noqa: E402

CASES = (("head", "cincinnati_20v"), ("gantry", "flow_xyzcb"), ("twin drive", "master_mill"),
         ("trunnion", "trunnion_xyzac"), ("head-table", "head_table_bc"), ("all-table", "xyzac_trt"),
         ("arm", "ur5"))
TOOLS_M = (0.21488, 0.31286)


def _model_error_mm(model, truth, q: np.ndarray, tool: np.ndarray) -> float:
    """Mean distance [mm] of the model's tip from the true tip relative to the table (each as
    the actual machine, no tables), the best rigid motion removed: where the model puts the
    volume is its reference frame, which the tables keep and the verify column judges."""
    modelled = model_as_actual(model)(q, tool, False, 0)[0]
    true = truth_as_actual(truth)(q, tool, False, 0)[0]
    return float(np.linalg.norm(registered_errors(modelled, true), axis=1).mean() * 1e3)


def one(cls: str, name: str, seed: int, folder: Path) -> dict:
    """One machine: simulated, fitted, its full tables written and judged."""
    t0 = time.time()
    m = vecpin.Machine.load(name)
    sim = simulate(m, seed=seed)
    model = vecpin.fit(m, sim.campaign, NoiseModel.default(m, "spherical")).model
    run = vecpin.make_tables(model, folder, "generic", uncertainty=False)
    box = measured_box(model)
    q = pseudo_commands(m, 600, seed=seed + 100, lower=box[0], upper=box[1])
    tool = np.tile(TOOLS_M, 300)
    full = next(r for r in run.plan.report.rows if r.label.startswith("full tables"))
    left = run.plan.unfollowed
    return {"class": cls, "machine": name, "model": _model_error_mm(model, sim.truth, q, tool),
            "uncompensated": judge(sim.truth, m, None, q, tool, box)["part"],
            "tables": full.mean, "verify": judge(sim.truth, m, folder / "tables.json", q, tool, box)["part"],
            "share": left.share, "pairs": ", ".join(f"{p} ({s:.0%})" for p, s in left.pairs) or "spread",
            "seconds": time.time() - t0}


def table(rows: list[dict], seed: int) -> str:
    lines = ["Mean tool-tip error [mm] relative to the table, in the part's frame, over 600 fresh commands x 2 tools "
             f"in the measured region; vecpin's default fit and full tables (generic files), simulator seed {seed}. "
             "Written by `python benchmarks/bench_machine_classes.py`. model: the fitted model against the true "
             "machine, the best rigid motion removed; tables: what `vecpin tables` predicts for the full set (on its own commands); verify: the true "
             "machine through the written tables, judged by tests/part_frame_judge.py; not followable: the share "
             "of the model's error the full tables leave (errors of two or more inputs at once), and the input "
             "pairs whose products explain it.", "",
             "| class | machine | uncompensated | model | tables (predicted) | verify (true) | not followable | "
             "couples |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['class']} | {r['machine']} | {r['uncompensated']:.4f} | {r['model']:.4f} | "
                     f"{r['tables']:.4f} | {r['verify']:.4f} | {r['share']:.0%} | {r['pairs']} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "results" /
                                         "machine_classes.md"))
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--cases", nargs="+", default=[c[1] for c in CASES])
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for cls, name in CASES:
            if name in args.cases:
                r = one(cls, name, args.seed, Path(tmp) / name)
                print(f"{cls:<12s} {name:<16s} unc {r['uncompensated']:.4f}  model {r['model']:.4f}  tables "
                      f"{r['tables']:.4f}  verify {r['verify']:.4f}  not followable {r['share']:.0%} ({r['pairs']}) "
                      f"({r['seconds']:.0f} s)", flush=True)
                rows.append(r)
    text = table(rows, args.seed)
    publish(text, args.out)


if __name__ == "__main__":
    main()
