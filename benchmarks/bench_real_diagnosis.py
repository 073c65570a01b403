"""The whole default day on real data (issue 25): ``vecpin diagnose`` on the UR10 of
``bench_figaroh`` (the same data, ``--data`` the same way, the same splits), its best
model (base + accepted effects, ``model_best.json``) judged on the held-out poses beside
FIGAROH's default, two ways:

* ``diagnose``: ``vecpin diagnose ur10 train.csv`` with no options. Every joint of this
  campaign is measured over 8-24 % of its ±360° travel, so the model is used beyond what
  was measured: an effect is accepted only if it does not predict the ends of those
  joints worse from the rest of their span (docs/diagnosis.md);
* ``diagnose in the measured zone``: ``vecpin diagnose ur10 train.csv --zone <each joint's
  measured range>``: the model is used where the joints were measured only (held-out
  poses outside the zone are judged all the same: the joint-1 split's lie beyond it).

Each run is a whole process timed from start to exit.
Held-out distances as ``bench_figaroh``: mm, tracker frame; the difference column pairs
the errors pose by pose (a tie: under two standard errors).

Run: python benchmarks/bench_real_diagnosis.py [--data FILE] [--splits joint1 ...] [--out PAGE]
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_figaroh import FIGAROH_DEFAULT, _cell, _split, paired, split_arguments, split_setting, timed  # noqa: E402


def _vecpin(*args: str) -> float:
    """Run ``vecpin args`` in a fresh process; its wall time [s] (SystemExit on failure)."""
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "vecpin", *args, "--quiet"], capture_output=True, text=True)
    if p.returncode:
        raise SystemExit(f"vecpin {args[0]} failed: {(p.stderr.strip().splitlines() or ['no output'])[-1]}")
    return time.perf_counter() - t0


def measured_zone(machine, campaign) -> str:
    """``--zone`` text of each axis' measured range (user units, widened to 0.001)."""
    lo, hi = machine.to_user(campaign.q.min(axis=0)), machine.to_user(campaign.q.max(axis=0))
    return ",".join(f"{a.name}={np.floor(1000 * a_lo) / 1000:g}:{np.ceil(1000 * a_hi) / 1000:g}"
                    for a, a_lo, a_hi in zip(machine.axes, lo, hi))


def run_split(split: str, work: Path) -> dict:
    import vecpin
    from vecpin.units import norm_mm
    m, train, held = _split(split)
    csv = work / "train.csv"
    vecpin.write_campaign(csv, train, m)
    out = {"train": len(train), "held": len(held)}
    for tag in ("diagnose", "zone"):
        folder = work / tag
        zone = ["--zone", measured_zone(m, train)] if tag == "zone" else []
        seconds = _vecpin("diagnose", "ur10", str(csv), "--out", str(folder), *zone)
        model = vecpin.ErrorModel.load(folder / "model_best.json")
        e = norm_mm(model.residuals(held))
        accepted = [x["label"] for x in json.loads((folder / "diagnosis.json").read_text())["effects"]
                    if x["accepted"] and x["name"] != "outliers"]
        out[tag] = {"mean": float(e.mean()), "max": float(e.max()), "errors": e.tolist(), "seconds": seconds,
                    "accepted": accepted}
        print(f"  {split} {tag}: {_cell(out[tag])} ({', '.join(accepted) or 'no effect'}; {seconds:.1f} s)", flush=True)
    out["figaroh"] = timed(["figaroh", split, *FIGAROH_DEFAULT])
    print(f"  {split} FIGAROH default: {_cell(out['figaroh'])}", flush=True)
    return out


def page(rows: dict, source: str) -> str:
    head = ("# Real data: the diagnosis against FIGAROH (UR10, ipa-robot-accuracy)\n\n"
            f"Written by `python benchmarks/bench_real_diagnosis.py` on {source} (module docstring: the two ways, "
            "the splits). Held-out mean / max distance, mm, of the diagnosis' best model (base + accepted effects) "
            "and of FIGAROH's default; whole-process times, s.\n\n")
    out = ["| split | train / held out | diagnose | accepted | diagnose − FIGAROH | in the measured zone | accepted "
           "| zone − FIGAROH | FIGAROH default | time diagnose / zone / FIGAROH, s |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for split, r in rows.items():
        d, z, f = r["diagnose"], r["zone"], r["figaroh"]
        out.append(f"| {split} | {r['train']} / {r['held']} | {_cell(d)} | {', '.join(d['accepted']) or '-'} | "
                   f"{paired(d, f)} | {_cell(z)} | {', '.join(z['accepted']) or '-'} | {paired(z, f)} | {_cell(f)} | "
                   f"{d['seconds']:.1f} / {z['seconds']:.1f} / {f['seconds']:.1f} |")
    return head + "\n".join(out) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    split_arguments(ap, "real_data_diagnosis")
    args = ap.parse_args()
    source, out = split_setting(args, "real_data_diagnosis")
    rows = {}
    for split in args.splits:
        with tempfile.TemporaryDirectory() as d:
            rows[split] = run_split(split, Path(d))
    out.write_text(page(rows, source))
    print(f"written {out}")


if __name__ == "__main__":
    main()
