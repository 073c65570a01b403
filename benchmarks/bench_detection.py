"""What a diagnosis could have seen (issue 40), measured: the size it states per effect
family against how often an effect of that size, simulated, is named.

On flow_xyzcb, for each clean campaign (seeds 0, 1; ``--commands`` commands) the
diagnosis states the size at which it would name each candidate 90 % of the time
(:mod:`vecpin.diagnosis.detection`). The same commands are then simulated with the effect
on that candidate at 0.5, 1 and 2 times the stated size (three seeds each) and diagnosed
again with the clean campaign's base model: the page counts how often it is named.

Run: python benchmarks/bench_detection.py [--commands N] [--out PAGE]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import vecpin
from vecpin.diagnosis.detection import POWER
from vecpin.diagnosis.diagnose import diagnose
from vecpin.simulation.effects import TrueEffect
from vecpin.simulation.simulate import Design, simulate

ROOT = Path(__file__).resolve().parents[1]
CASES = [("rotary_periodic", ("C",), "rotary_periodic[C]"), ("coupled_axes", ("X", "Y"), "coupled_axes[X,Y]")]
FACTORS = (0.5, 1.0, 2.0)
SEEDS = (3, 4, 5)


def one_case(machine, name: str, axes: tuple, label: str, clean_seed: int, n: int) -> dict:
    """The stated size of ``label`` on a clean campaign and how often the effect at each factor of it is named."""
    design = Design(n_commands=n, n_validation=3)
    clean = simulate(machine, seed=clean_seed, design=design)
    d = diagnose(machine, clean.campaign, effects=[name], model="6dof", basis="chebyshev", order=4)
    fam = {f["effect"]: f for f in d.detection}[name]
    size_um = fam["per_candidate_um"][label]
    plan = (clean.campaign.q, clean.campaign.tool)
    named = {}
    for k in FACTORS:
        hits = 0
        for seed in SEEDS:
            spec = TrueEffect(name, axes, k * size_um * 1e-3, seed=seed + 7)
            sim = simulate(machine, seed=seed, design=design, effects=[spec], plan=plan)
            got = diagnose(machine, sim.campaign, effects=[name], base=d.base_model)
            hits += label in [e.label for e in got.accepted]
        named[k] = hits
    return {"label": label, "seed": clean_seed, "rows": len(clean.campaign), "size_um": size_um, "named": named}


def page(rows: list[dict], seconds: float) -> str:
    lines = ["# What a diagnosis could have seen: stated detection sizes against simulation", "",
             "Written by `python benchmarks/bench_detection.py`. Per clean campaign of flow_xyzcb the diagnosis "
             "states the size (RMS of the effect's displacement of the measured points) at which it would name each "
             f"candidate {POWER:.0%} of the time (over the noise and the effect's shape drawn from its prior); the "
             "effect is then simulated on the same commands at 0.5, 1 and 2 times "
             f"that size ({len(SEEDS)} seeds each) and diagnosed with the clean campaign's base model.", "",
             "| effect | clean seed | rows | stated size (µm) | " + " | ".join(
                 f"named at {k:g}x" for k in FACTORS) + " |",
             "|---|---|---|---|" + "---|" * len(FACTORS)]
    for r in rows:
        lines.append(f"| {r['label']} | {r['seed']} | {r['rows']} | {r['size_um']:.1f} | "
                     + " | ".join(f"{r['named'][k]}/{len(SEEDS)}" for k in FACTORS) + " |")
    lines += ["", f"{sum(len(FACTORS) * len(SEEDS) + 1 for _ in rows)} diagnoses in {seconds:.0f} s.", ""]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--commands", type=int, default=100)
    ap.add_argument("--out", default=str(ROOT / "docs" / "results" / "detection.md"))
    args = ap.parse_args()
    m = vecpin.Machine.load("flow_xyzcb")
    t0 = time.perf_counter()
    rows = []
    for name, axes, label in CASES:
        for clean_seed in (0, 1):
            r = one_case(m, name, axes, label, clean_seed, args.commands)
            print(f"{label} seed {clean_seed}: stated {r['size_um']:.1f} µm; named "
                  + ", ".join(f"{k:g}x {r['named'][k]}/{len(SEEDS)}" for k in FACTORS), flush=True)
            rows.append(r)
    text = page(rows, time.perf_counter() - t0)
    Path(args.out).write_text(text)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
