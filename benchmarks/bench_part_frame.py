"""Compensation judged where the part is (issue 39): per machine class, the true machine
uncompensated and through vecpin's tables, as a part set up on the table sees it.

For each bundled machine class (head, gantry, twin drive, trunnion, head-table, all-table,
arm) a true machine is drawn from vecpin's simulator, and for one head and one gantry a
truth from the independent family (errors outside vecpin's models); a campaign is
simulated, vecpin's default fit chooses and fits the model, and `vecpin tables` writes the
generic files (the full table set). A judge written without vecpin's compensation code
(tests/part_frame_judge.py) reads the files, commands the true machine through them and
judges the tip relative to the true table on 600 fresh random commands x 2 tools:

* part: the part's frame (a translation and a rotation about the spindle removed);
* shape: the best rigid motion removed (the seed's figure, the error's shape);
* turn: the angle between the frames ISO 230-1's reference lines span (X and Y moved
  alone) before and after compensation (the frame vecpin keeps on a machine whose table
  stands still), and between the best-fit orientations of the whole volume before and after
  (the frame it keeps where the table turns, and on arms).

The truth's table is not aligned to its own reference lines (the simulator draws the
errors of every axis, including the slopes of X's and Y's lines against the table): no
campaign that reads only the tool can know that tilt, so the part figure of the
compensated machine keeps it; "part / shape" says how much of what is left it is. On the
machines whose table carries nests, each is run twice: as above, and with the fit given
the nests' heights above the table's face (what a user knows of them: `vecpin fit
--nest-height`), so that the tables keep the face square to the spindle.

Run: python benchmarks/bench_part_frame.py [--out docs/results/part_frame.md] [--seed N]
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

import vecpin  # noqa: E402
from vecpin.compensation.functions import pseudo_commands  # noqa: E402
from vecpin.compensation.frame import measured_box
from vecpin.measurement.noise import NoiseModel  # noqa: E402
from vecpin.measurement.partframe import uses_lines  # noqa: E402
from vecpin.simulation.independent import IndependentMachine, layout  # noqa: E402
from vecpin.simulation.floor import table_floor  # noqa: E402
from vecpin.simulation.simulate import simulate  # noqa: E402

CASES = (("head", "cincinnati_20v", None), ("gantry", "flow_xyzcb", None), ("twin drive", "master_mill", None),
         ("trunnion", "trunnion_xyzac", None), ("head-table", "head_table_bc", None),
         ("all-table", "xyzac_trt", None), ("arm", "ur5", None),
         ("head, independent truth", "head_xyzab", "mixed"), ("gantry, independent truth", "portal_xyzcb", "spline"))


def one(cls: str, name: str, family: str | None, seed: int, folder: Path, face: bool = False) -> dict:
    """One machine: simulated, fitted (with the nests' heights above the table's face when ``face``), its
    full tables written and judged."""
    t0 = time.time()
    if family is None:
        m = vecpin.Machine.load(name)
        sim = simulate(m, seed=seed)
    else:
        m = layout(name)
        truth = IndependentMachine.random(m, family, seed=seed, mean_error_mm=0.5)
        sim = simulate(m, seed=seed + 1, truth=truth)
    heights = {k: float(p[2]) * 1e3 for k, p in sim.nests.items()} if face else None
    model = vecpin.fit(m, sim.campaign, NoiseModel.default(m, "spherical"), nest_heights=heights).model
    vecpin.make_tables(model, folder, "generic", uncertainty=False)
    q = pseudo_commands(m, 600, seed=seed + 100, lower=measured_box(model)[0], upper=measured_box(model)[1])
    tool = np.tile([0.21488, 0.31286], 300)
    box = measured_box(model)
    row = {"class": cls, "machine": name + (f" ({family})" if family else ""),
           "frame": "the table's face (nest heights)" if face else ("reference lines" if uses_lines(m) else
                                                                    "mean orientation"),
           "uncompensated": judge(sim.truth, m, None, q, tool, box),
           "compensated": judge(sim.truth, m, folder / "tables.json", q, tool, box),
           "floor": table_floor(sim.truth, q, tool, keep="table").mean_mm}
    row["seconds"] = time.time() - t0
    return row


def table(rows: list[dict], seed: int) -> str:
    lines = [f"True tool-tip error [mm] relative to the true table, mean over 600 fresh commands x 2 tools in the "
             f"measured region; vecpin's default fit and full tables (generic files), simulator seed {seed}; judged by "
             "tests/part_frame_judge.py (its own reader and registrations; written by benchmarks/bench_part_frame.py). "
             "part: as a part set up by probing its origin and aligning an edge sees it; shape: the best rigid motion "
             "removed; turn: the angle [µrad] between the frames of X's and Y's reference lines before and after "
             "(lines), "
             "and between the best-fit orientations of the whole volume before and after (volume); best part: the best "
             "full table set that exists for the part (fitted to the truth in its table's own frame, judged the same "
             "way by vecpin's own code: simulation only).",
             "frame kept: what vecpin's tables keep (reference lines where the table stands still, the mean "
             "orientation where it turns and on arms, the table's face where the fit was given the nests' heights "
             "above it: the campaign reads the table).",
             "", "| class | machine | frame kept | uncompensated part | uncompensated shape | compensated part | "
             "compensated shape | part / shape | part / uncompensated | best part | part / best part | "
             "turn µrad, lines | turn µrad, volume |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        u, c = r["uncompensated"], r["compensated"]
        lines.append(f"| {r['class']} | {r['machine']} | {r['frame']} | {u['part']:.4f} | {u['shape']:.4f} | "
                     f"{c['part']:.4f} | {c['shape']:.4f} | {c['part'] / c['shape']:.2f} | "
                     f"{c['part'] / u['part']:.3f} | {r['floor']:.4f} | {c['part'] / r['floor']:.2f} | "
                     f"{c['turn_urad']:.1f} | {c['volume_turn_urad']:.1f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "results" / "part_frame.md"))
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--cases", nargs="+", default=[c[1] for c in CASES])
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for cls, name, family in CASES:
            if name not in args.cases:
                continue
            m = vecpin.Machine.load(name) if family is None else layout(name)
            for face in (False, True) if m.has_workpiece else (False,):
                r = one(cls, name, family, args.seed, Path(tmp) / f"{name}-{face}", face)
                u, c = r["uncompensated"], r["compensated"]
                print(f"{cls:<26s} {r['machine']:<22s} {r['frame']:<32s} part {u['part']:.4f} -> {c['part']:.4f} mm, "
                      f"shape {u['shape']:.4f} -> {c['shape']:.4f} mm, best part {r['floor']:.4f} mm, "
                      f"turn {c['turn_urad']:.1f} / {c['volume_turn_urad']:.1f} µrad ({r['seconds']:.0f} s)",
                      flush=True)
                rows.append(r)
    text = table(rows, args.seed)
    print(text)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
