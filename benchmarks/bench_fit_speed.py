"""The default fit's whole process against a plain reference fitter (issue 43), and its choices.

Part 1 (speed): campaigns of machines drawn by ``benchmarks/generator`` (head and gantry layouts,
clean, 260 commands x 2 tools = 520 rows, seeds 100..). On each, ``vecpin fit URDF CSV`` (the
default: model choice by held-out data, then the fit) and ``benchmarks/reference_fit.py`` (numpy
only, no vecpin: one 6-DoF Chebyshev order-6 model, one linear solve) run as fresh processes in
turn, ``--pairs`` times; per campaign the median of each, the ratio of the medians; the median
ratio over campaigns is the figure (issue 43: at most 2.0). Wall time and CPU time (user +
system) are both printed: the machine is shared, so absolute times vary; the ratio of two
processes measured in turn much less.

Part 2 (choices): every bundled machine simulated (``vecpin simulate NAME --seed 0``), fitted
with the default choice and the model judged by ``vecpin evaluate`` on the simulator's noise-free
validation readings (validation_truth.csv, which the fit never saw). ``--record FILE`` writes the
choices; ``--before FILE`` compares with a recording of an earlier vecpin (same chosen model, or
the validation error where it differs).

What is left (``--part 1``, first campaign): the CPU of processes that only import (numpy; numpy with
scipy.linalg and Pinocchio, the libraries the fit computes with; every module ``vecpin fit``
imports), of ``vecpin fit`` with the reference's own fixed model (6-DoF, Chebyshev order 6: no model
choice) and with the kind fixed (``--model 6dof``: the bases still chosen), each against the reference:
the floor the imports and the fit of one model set under the ratio, and what each part of the choice adds;
then the default fit's CPU phase by phase on the first two campaigns (``benchmarks/fit_phases.py``).

Every process runs as an installed package does, its modules' bytecode cached (a pip install compiles
it): ``PYTHONDONTWRITEBYTECODE`` is dropped, the cache kept under the work folder, one untimed run first.

Run: python benchmarks/bench_fit_speed.py [--campaigns 6] [--pairs 3] [--part 1|2|all]
                                          [--record FILE] [--before FILE] [--before-src DIR] [--no-page]
The ``vecpin`` run is the one on PYTHONPATH (this worktree's, set here), or ``--src DIR``.
"""
import argparse
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PAGE = ROOT / "docs" / "results" / "fit_speed.md"
BUNDLED = ("cincinnati_20v", "flow_xyzcb", "head_table_bc", "ingersoll_xyzca", "master_mill", "production_xyzbaw",
           "snk_120v", "spar_mill_23", "trunnion_xyzac", "trunnion_xyzbc", "ur10", "ur5", "xyzac_trt")


def run(argv: list[str], env: dict) -> tuple[float, float, subprocess.CompletedProcess]:
    """(wall s, CPU s of the child, result) of one fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    r = subprocess.run(argv, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode:
        raise RuntimeError(f"{' '.join(argv)} failed:\n{r.stderr[-2000:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), r


def vecpin(*args: str) -> list[str]:
    return [sys.executable, "-m", "vecpin", *args]


def draw(seed: int, folder: Path) -> dict:
    """One generator campaign (head or gantry, clean, 520 rows) written to ``folder``."""
    sys.path.insert(0, str(HERE))
    from generator import draw_campaign
    camp = draw_campaign(seed, kind=("head", "gantry")[seed % 2], family=None, n_commands=260)
    return camp.write(folder)


def cached(env: dict, work: Path) -> dict:
    """``env`` with Python's bytecode cache on, kept under ``work`` (as an installed package has it)."""
    out = {k: v for k, v in env.items() if k != "PYTHONDONTWRITEBYTECODE"}
    return out | {"PYTHONPYCACHEPREFIX": str(work / "pycache")}


def floors(paths: dict, pairs: int, env: dict, work: Path) -> list[str]:
    """What is left under the ratio on one campaign: median CPU s (and wall s) of processes that only
    import, of ``vecpin fit`` with the reference's fixed model, of the default fit and of the reference."""
    urdf, csv = str(paths["urdf"]), str(paths["csv"])
    out = str(work / "floor.json")
    what = [("import numpy (the reference's only library)", [sys.executable, "-c", "import numpy"]),
            ("import numpy, scipy.linalg, pinocchio",
             [sys.executable, "-c", "import numpy, scipy.linalg, pinocchio"]),
            ("import every module `vecpin fit` imports",
             [sys.executable, "-c", "import vecpin.cli.main, vecpin.cli.fitting, vecpin.workflows.fitting"]),
            ("vecpin fit, the reference's model (6dof chebyshev 6)",
             vecpin("fit", urdf, csv, "--model", "6dof", "--basis", "chebyshev", "--order", "6", "--out", out,
                    "--quiet")),
            ("vecpin fit --model 6dof (bases chosen, one kind)", vecpin("fit", urdf, csv, "--model", "6dof", "--out",
                                                                       out, "--quiet")),
            ("vecpin fit (default: kind and bases chosen)", vecpin("fit", urdf, csv, "--out", out, "--quiet")),
            ("reference fit (numpy, one solve)", [sys.executable, str(HERE / "reference_fit.py"), urdf, csv])]
    runs: dict = {label: [] for label, _ in what}
    for _ in range(pairs):
        for label, argv in what:
            runs[label].append(run(argv, env)[:2])
    ref = statistics.median(c for _, c in runs[what[-1][0]])
    lines = [f"{'process (first campaign)':<55s} {'CPU s':>6s} {'wall s':>7s} {'CPU / reference':>15s}"]
    for label, _ in what:
        cpu, wall = statistics.median(c for _, c in runs[label]), statistics.median(w for w, _ in runs[label])
        lines.append(f"{label:<55s} {cpu:6.2f} {wall:7.2f} {cpu / ref:15.2f}")
    print("\n".join("  " + s for s in lines), flush=True)
    return lines


def phases(seeds: list[int], pairs: int, env: dict, work: Path) -> list[str]:
    """Where the CPU of the default fit goes on these campaigns (``benchmarks/fit_phases.py`` in fresh
    processes, in turn with the reference): per phase the median CPU s and in the reference's CPU."""
    runs: dict = {}
    for seed in seeds:
        paths = draw(seed, work / f"gen{seed}")
        argv = [sys.executable, str(HERE / "fit_phases.py"), str(paths["urdf"]), str(paths["csv"]),
                str(work / f"phases{seed}.json")]
        ref = [sys.executable, str(HERE / "reference_fit.py"), str(paths["urdf"]), str(paths["csv"])]
        if seed == seeds[0]:   # untimed: the bytecode caches written
            run(argv, env)
        for _ in range(pairs):
            got = json.loads(run(argv, env)[2].stdout)
            for name, (cpu, _) in got.items():
                runs.setdefault(name, {}).setdefault(seed, []).append(cpu)
            runs.setdefault("reference fit (numpy, one solve; whole process)", {}).setdefault(seed, []).append(
                run(ref, env)[1])
    ref_cpu = {seed: statistics.median(runs["reference fit (numpy, one solve; whole process)"][seed]) for seed in seeds}
    head = "".join(f" {f'seed {s} CPU s':>14s} {'/ ref':>6s}" for s in seeds)
    lines = [f"{'phase of vecpin fit (default)':<55s}{head}"]
    for name, per in runs.items():
        cells = "".join(f" {statistics.median(per[s]):14.3f} {statistics.median(per[s]) / ref_cpu[s]:6.2f}"
                        for s in seeds)
        lines.append(f"{name:<55s}{cells}")
    print("\n".join("  " + s for s in lines), flush=True)
    return lines


def speed(n: int, pairs: int, env: dict, work: Path, env_before: dict | None = None
          ) -> tuple[list[str], list[float], list[float]]:
    """Part 1: the printed lines and the per-campaign ratios (wall) of this vecpin and, with
    ``env_before``, of an earlier one (same campaigns, run in the same turns)."""
    lines = [f"{'seed':>5s} {'layout':<7s} {'rows':>5s} {'vecpin fit s':>12s} {'reference s':>11s} {'ratio':>6s} "
             f"{'CPU ratio':>9s} {'before: ratio':>13s} {'CPU':>5s}  chosen model"]
    print("Part 1: whole process, vecpin fit (default) vs the plain reference fitter, median of "
          f"{pairs} runs each, in turn", flush=True)
    print("  " + lines[0], flush=True)
    ratios, before = [], []
    for seed in range(100, 100 + n):
        paths = draw(seed, work / f"gen{seed}")
        fit = vecpin("fit", str(paths["urdf"]), str(paths["csv"]), "--out", str(work / f"gen{seed}.json"), "--quiet")
        ref = [sys.executable, str(HERE / "reference_fit.py"), str(paths["urdf"]), str(paths["csv"])]
        runs = {"fit": [], "ref": [], "before": []}
        if seed == 100:   # untimed: the bytecode caches written, the files read once
            run(fit, env), run(ref, env)
            if env_before is not None:
                run(fit[:-3] + ["--out", str(work / f"gen{seed}_before.json"), "--quiet"], env_before)
        for _ in range(pairs):
            runs["fit"].append(run(fit, env)[:2])
            runs["ref"].append(run(ref, env)[:2])
            if env_before is not None:
                runs["before"].append(run(fit[:-3] + ["--out", str(work / f"gen{seed}_before.json"), "--quiet"],
                                          env_before)[:2])
        f, r = (statistics.median(w for w, _ in runs[k]) for k in ("fit", "ref"))
        fc, rc = (statistics.median(c for _, c in runs[k]) for k in ("fit", "ref"))
        b, bc = ((statistics.median(w for w, _ in runs["before"]), statistics.median(c for _, c in runs["before"]))
                 if runs["before"] else (math.nan, math.nan))
        chosen = json.loads((work / f"gen{seed}.json").read_text())["selection"]["chosen"]
        label = f"{chosen['kind']} " + "/".join(chosen["bases"].values())
        if runs["before"]:
            was = json.loads((work / f"gen{seed}_before.json").read_text())["selection"]["chosen"]
            same = (was["kind"], was["bases"]) == (chosen["kind"], chosen["bases"])
            label += "" if same else f"  (before: {was['kind']} " + "/".join(was["bases"].values()) + ")"
        ratios.append(f / r)
        before.append(b / r)
        rows = sum(1 for _ in open(paths["csv"])) - 1
        line = (f"{seed:5d} {('head', 'gantry')[seed % 2]:<7s} {rows:5d} {f:12.2f} {r:11.2f} {f / r:6.2f} "
                f"{fc / rc:9.2f} {b / r:13.2f} {bc / rc:5.2f}  {label}")
        lines.append(line)
        print("  " + line, flush=True)
    print(f"  median ratio {statistics.median(ratios):.2f} (issue 43: <= 2.0); before "
          f"{statistics.median(before):.2f}", flush=True)
    return lines, ratios, before


def choices(env: dict, work: Path) -> dict:
    """Part 2: per bundled machine the chosen model, its held-out and validation errors (mm), fit time."""
    out = {}
    for name in BUNDLED:
        sim = work / f"sim_{name}"
        if not (sim / "campaign.csv").exists():
            run(vecpin("simulate", name, "--seed", "0", "--out", str(sim)), env)
        model = work / f"model_{name}.json"
        wall, cpu, _ = run(vecpin("fit", name, str(sim / "campaign.csv"), "--out", str(model), "--quiet"), env)
        ev = work / f"eval_{name}.json"
        run(vecpin("evaluate", str(model), str(sim / "validation_truth.csv"), "--json", str(ev)), env)
        sel = json.loads(model.read_text())["selection"]
        out[name] = {"kind": sel["chosen"]["kind"], "bases": sel["chosen"]["bases"],
                     "heldout_mean_mm": sel["chosen"]["heldout_mean_mm"], "candidates": len(sel["candidates"]),
                     "validation_mean_mm": json.loads(ev.read_text())["model_residual"]["all"]["mean"],
                     "fit_wall_s": wall, "fit_cpu_s": cpu}
        print(f"  {name:<18s} {out[name]['kind']:<5s} {'/'.join(out[name]['bases'].values()):<60s} "
              f"held-out {out[name]['heldout_mean_mm']:.4f} validation {out[name]['validation_mean_mm']:.4f} mm, "
              f"{out[name]['candidates']} candidates, {wall:.1f} s", flush=True)
    return out


def compare(now: dict, before: dict) -> list[str]:
    """Lines: each bundled machine's choice now against before."""
    lines = [f"{'machine':<18s} {'same model':<10s} {'validation mm before':>20s} {'now':>7s} "
             f"{'candidates before':>17s} {'now':>5s}  model now"]
    for name, c in now.items():
        b = before.get(name)
        if b is None:
            continue
        same = b["kind"] == c["kind"] and b["bases"] == c["bases"]
        lines.append(f"{name:<18s} {'yes' if same else 'NO':<10s} {b['validation_mean_mm']:20.4f} "
                     f"{c['validation_mean_mm']:7.4f} {b['candidates']:17d} {c['candidates']:5d}  "
                     f"{c['kind']} {'/'.join(c['bases'].values())}")
    return lines


def write_page(speed_lines, ratios, before, cmp_lines, load, label: str, floor_lines=(), phase_lines=()) -> None:
    text = ["# The default fit's speed against a plain fitter (issue 43)", "",
            "Made by `python benchmarks/bench_fit_speed.py`. Whole processes (a fresh Python each, imports "
            "included): `vecpin fit URDF CSV` with its default model choice against "
            "`benchmarks/reference_fit.py`, a plain fitter written without vecpin (numpy only: one 6-DoF "
            "Chebyshev order-6 model, one linear solve, no model choice), each run in turn on the same campaign "
            "of a machine drawn by `benchmarks/generator`. The machine (2 CPUs) was shared with other jobs "
            f"(load average {load[0]:.1f} at the start, {load[1]:.1f} at the end): absolute times are upper "
            "bounds, the ratio of processes measured in turn is the figure.", "", "```text", *speed_lines, "```", "",
            f"Median ratio over {len(ratios)} campaigns: **{statistics.median(ratios):.2f}x** (issue 43's target: "
            "at most 2.0x)" + (f"; {label}, run in the same turns: "
                               f"{statistics.median(before):.2f}x." if not math.isnan(statistics.median(before))
                               else "."), "",
            "Every process ran with its modules' bytecode cached, as an installed package has it (a pip install "
            "compiles it; without the cache each `vecpin fit` compiles its 100 modules again, about 0.35 s of CPU).",
            ""]
    if floor_lines:
        text += ["What is left under the ratio, on the first campaign (median CPU of the same runs in turn): "
                 "processes that only import, and `vecpin fit` with the reference's own fixed model (no model "
                 "choice: its one candidate is still scored for gross rows and the noise level, then fitted by "
                 "Gauss-Newton with its redundancy analysis) and with the kind fixed (its bases still chosen). "
                 "Row by row: what the imports cost beyond numpy, what the fit of one model adds, what the choice "
                 "of the bases of one kind adds, and what the second kind (AP: scored at 6-DoF's bases, searched only "
                 "where it could be chosen) adds:", "", "```text", *floor_lines,
                 "```", ""]
    if phase_lines:
        text += ["Where the default fit's CPU goes, phase by phase (`benchmarks/fit_phases.py`: the command run in "
                 "one process with a CPU clock around each part; median of the same runs, in turn with the "
                 "reference), on the first campaign (one gross row: the choice is made twice, the second time "
                 "without it) and the second (none). The common-basis stage runs twice when the noise level is "
                 "taken from the data (first at the stated noise, to find the gross rows and the level, then at "
                 "the level found); 'the rest' is reading, checks, reports and the choice's bookkeeping:", "",
                 "```text", *phase_lines, "```", ""]
    if cmp_lines:
        text += [f"The model chosen on every bundled machine (simulated, seed 0) by {label} ('before') and now, "
                 "judged on the simulator's noise-free validation readings:", "", "```text", *cmp_lines, "```", ""]
    PAGE.write_text("\n".join(text))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--campaigns", type=int, default=6)
    p.add_argument("--pairs", type=int, default=3)
    p.add_argument("--part", choices=("1", "2", "all"), default="all")
    p.add_argument("--src", default=str(ROOT), help="the vecpin source tree to run (default: this one)")
    p.add_argument("--before-src", help="an earlier vecpin source tree: part 1 also times its fit, in the same turns")
    p.add_argument("--before-label", default="the earlier vecpin", help="what --before-src and --before are, for "
                                                                         "the page (e.g. a commit)")
    p.add_argument("--record", metavar="FILE", help="write part 2's choices here (JSON)")
    p.add_argument("--before", metavar="FILE", help="compare part 2 with this recording")
    p.add_argument("--work", help="keep campaigns and models here (default: a temporary folder)")
    p.add_argument("--no-page", action="store_true")
    a = p.parse_args()
    tmp = None if a.work else tempfile.TemporaryDirectory()
    work = Path(a.work or tmp.name).resolve()
    work.mkdir(parents=True, exist_ok=True)
    a.src, a.before_src = str(Path(a.src).resolve()), a.before_src and str(Path(a.before_src).resolve())
    a.record, a.before = (a.record and str(Path(a.record).resolve())), (a.before and str(Path(a.before).resolve()))
    os.chdir(work)   # `python -m` puts the working folder first on sys.path: in a source tree it would run that tree
    env = cached(dict(os.environ, PYTHONPATH=os.pathsep.join([a.src, os.environ.get("PYTHONPATH", "")])), work)
    load0 = os.getloadavg()[0]
    speed_lines, ratios, before, cmp_lines, floor_lines, phase_lines = [], [], [], [], [], []
    env_before = (cached(dict(os.environ, PYTHONPATH=os.pathsep.join([a.before_src, os.environ.get("PYTHONPATH", "")])),
                         work) if a.before_src else None)
    if a.part in ("1", "all"):
        speed_lines, ratios, before = speed(a.campaigns, a.pairs, env, work, env_before)
        print("What is left: CPU of processes that only import, and of a fit of the reference's model", flush=True)
        floor_lines = floors(draw(100, work / "gen100"), a.pairs, env, work)
        print("Where the default fit's CPU goes, phase by phase (benchmarks/fit_phases.py)", flush=True)
        phase_lines = phases([100, 101], a.pairs, env, work)
    if a.part in ("2", "all"):
        print("Part 2: the default choice on every bundled machine (simulated, seed 0)", flush=True)
        now = choices(env, work)
        if a.record:
            Path(a.record).write_text(json.dumps(now, indent=1))
        if a.before:
            cmp_lines = compare(now, json.loads(Path(a.before).read_text()))
            print("\n".join("  " + s for s in cmp_lines))
    if ratios and not a.no_page:
        write_page(speed_lines, ratios, before, cmp_lines, (load0, os.getloadavg()[0]), a.before_label, floor_lines,
                   phase_lines)
        print(f"wrote {PAGE}")


if __name__ == "__main__":
    main()
