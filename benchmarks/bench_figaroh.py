"""vecpin's default against FIGAROH on real data (issue 25): the public UR10 laser-tracker
dataset (tests/data/ipa_ur10/random_poses_400.csv: 400 random poses of series C of
github.com/christianlandgraf/ipa-robot-accuracy, MIT; PROVENANCE.md there), split four
ways into training and held-out poses:

* ``interleaved``: every 4th pose held out (new poses in the measured workspace);
* ``region``: the 20 % of poses whose nominal tool point lies farthest from joint 1's axis
  (the outer workspace: never measured by the fit);
* ``joint1``: the 20 % of poses with the highest joint 1 angle (a joint range the fit never
  saw);
* ``time``: the last 20 % of poses in the order of measurement (a time window; series C's
  time stamps were rounded away by a spreadsheet, its row order is the order of
  measurement).

Times: vecpin's default and FIGAROH's default run ``--repeat`` times each (default 5), in
turn, and the median is reported (a single run's time on a shared machine varies by 20 %).

vecpin: ``vecpin fit ur10 train.csv`` with no options (kind, bases, orders and the noise
level from the data). FIGAROH 1.0.2 (``pip install vecpin[figaroh]``): its geometric
calibration of the same URDF (base frame and the T-Mac's point on the flange unknown,
position-only markers), with its default (``estimation.method: structural``,
``calibration_level: full_params``) and the other settings it offers (methods
``structural``, ``excitation``, ``map``, ``map_cv``, ``cv_subset`` at the levels
``full_params`` and ``joint_offset``): "best" is the setting with the lowest held-out mean
on that split, chosen after seeing the held-out poses (an oracle: FIGAROH's best case), among
:data:`SEARCHED` (``--all-settings``: all ten).
Beside them vecpin's simplest model, ``vecpin fit --model 6dof --order 0`` (constant errors
of every joint: a geometric calibration like FIGAROH's ``full_params``), which shows how
much of any difference is the model vecpin's default chooses.

Each fit runs in a fresh Python process timed from start to exit (imports, reading, fitting,
predicting the held-out poses): the whole-process time. Held-out distances are between the
measured T-Mac centre and each tool's prediction, in the tracker frame, mm.

Run: python benchmarks/bench_figaroh.py [--out docs/results/real_data.md] [--quick] [--all-settings | --settings map_cv/full_params ...] [--splits joint1 ...]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "ipa_ur10" / "random_poses_400.csv"
DATA_ENV = "VECPIN_BENCH_UR10"   # the series file the child processes read (``--data``)
README = ROOT / "README.md"
README_MARKS = ("<!-- bench_figaroh:start -->", "<!-- bench_figaroh:end -->")
SPLITS = ("interleaved", "region", "joint1", "time")
METHODS = ("structural", "excitation", "map", "map_cv", "cv_subset")
LEVELS = ("full_params", "joint_offset")
FIGAROH_DEFAULT = ("structural", "full_params")
#: the settings searched for FIGAROH's best by default: its default, its two choices of the
#: parameters by cross-validation, and its default method at joint offsets only (every one
#: of the ten with ``--all-settings``: about 6 minutes each per split on a loaded 2-core machine)
SEARCHED = (FIGAROH_DEFAULT, ("map_cv", "full_params"), ("cv_subset", "full_params"), ("structural", "joint_offset"))


def held_out(machine, campaign, split: str) -> np.ndarray:
    """The held-out rows of ``split`` (module text), a boolean mask over the campaign."""
    n = len(campaign)
    if split == "interleaved":
        return np.arange(n) % 4 == 3
    if split == "joint1":
        return campaign.q[:, 0] > np.quantile(campaign.q[:, 0], 0.8)
    if split == "time":
        return np.arange(n) >= int(round(0.8 * n))
    tip = machine.tool_tip(campaign.q, campaign.tool)
    reach = np.hypot(tip[:, 0], tip[:, 1])
    return reach > np.quantile(reach, 0.8)


def _split(split: str):
    import vecpin
    from vecpin.measurement.robotaccuracy import read_dataset
    m = vecpin.Machine.load("ur10")
    c = read_dataset(Path(os.environ.get(DATA_ENV, DATA)), m).campaign
    test = held_out(m, c, split)
    return m, c.subset(~test), c.subset(test)


def run_vecpin(split: str, work: Path, *options: str) -> dict:
    """``vecpin fit`` (no options: the default; or ``options``) on the training poses;
    held-out distances [mm]."""
    import vecpin
    from vecpin.cli import main
    from vecpin.units import norm_mm
    m, train, held = _split(split)
    vecpin.write_campaign(work / "train.csv", train, m)
    if main(["fit", "ur10", str(work / "train.csv"), "--out", str(work / "model.json"), "--quiet", *options]) != 0:
        raise SystemExit("vecpin fit failed")
    model = vecpin.ErrorModel.load(work / "model.json")
    e = norm_mm(model.residuals(held))
    chosen = json.loads((work / "model.json").read_text()).get("selection", {}).get("chosen", {})
    setting = f"{chosen.get('kind', model.kind)}, {chosen.get('model_terms', model.n_parameters)} terms"
    return {"mean": float(e.mean()), "max": float(e.max()), "setting": setting, "errors": e.round(5).tolist()}


def figaroh_config(work: Path, robot: str, joints, tool_frame: str, markers: dict, n: int, method: str,
                   level: str, tool_pose_m=(0.0, 0.0, 0.0)) -> Path:
    """FIGAROH's calibration settings (``work``/figaroh.yaml) for ``n`` training poses in
    ``work``/figaroh_train.csv: ``markers`` {name: position-only}, the tool pose [m] on
    ``tool_frame``, the base frame unknown from ``universe``."""
    lines = "\n".join(f"        - name: {name}\n          measurable_dof: [true, true, true, false, false, false]"
                      for name in markers)
    cfg = work / "figaroh.yaml"
    cfg.write_text(f"""robot:
  name: {robot}
  properties:
    joints:
      active_joints: [{", ".join(joints)}]
tasks:
  calibration:
    enabled: true
    parameters:
      calibration_level: {level}
      include_non_geometric: false
      estimation:
        method: {method}
    kinematics:
      base_frame: universe
      tool_frame: {tool_frame}
    measurements:
      markers:
{lines}
      poses:
        base_pose: [0, 0, 0, 0, 0, 0]
        tool_pose: [{", ".join(str(v) for v in tool_pose_m)}, 0, 0, 0]
    data:
      source_file: {work / 'figaroh_train.csv'}
      number_of_samples: {n}
""")
    return cfg


def solve_figaroh(robot, cfg: Path, q_held: np.ndarray):
    """FIGAROH's calibration of ``robot`` (a pinocchio RobotWrapper) with the settings ``cfg``
    (base frame and tip point unknown, its printout silenced); (its parameters, the updated
    kinematics' marker points [m] at the held-out joint positions ``q_held``: (3 x markers, N))."""
    from figaroh.calibration.base_calibration import BaseCalibration
    from figaroh.calibration.calibration_tools import calc_updated_fkm

    class Calibration(BaseCalibration):
        def cost_function(self, var):   # the markers' points, m, in the measuring instrument's frame
            return self.PEE_measured - calc_updated_fkm(self.model, self.data, var, self.q_measured,
                                                        self.calib_config)

    cal = Calibration(robot, str(cfg))
    cal.calib_config["known_baseframe"] = False
    cal.calib_config["known_tipframe"] = False
    cal.initialize()
    with open(os.devnull, "w") as null:
        out, sys.stdout = sys.stdout, null
        try:
            result = cal.solve(enable_logging=False)
        finally:
            sys.stdout = out
    q = np.zeros((len(q_held), robot.model.nq))
    q[:, cal.calib_config["config_idx"]] = q_held
    cfg = dict(cal.calib_config, NbSample=len(q_held))
    return result.x, calc_updated_fkm(cal.model, cal.data, result.x, q, cfg)


def run_figaroh(split: str, work: Path, method: str, level: str) -> dict:
    """FIGAROH's geometric calibration of the bundled ur10 URDF with ``method`` and
    ``level`` on the training poses (base frame and marker point unknown, started at
    FIGAROH's closed-form guess); held-out distances [mm] of its updated kinematics."""
    import logging
    import pandas as pd
    import pinocchio as pin
    from vecpin.measurement.robotaccuracy import JOINTS, TMAC_TOOL_MM
    logging.disable(logging.WARNING)
    m, train, held = _split(split)
    df = pd.DataFrame({"x1": train.xyz[:, 0], "y1": train.xyz[:, 1], "z1": train.xyz[:, 2]})
    for j, name in enumerate(JOINTS):
        df[name] = train.q[:, j]
    df.to_csv(work / "figaroh_train.csv", index=False)
    robot = pin.RobotWrapper.BuildFromURDF(str(m.urdf_path))
    cfg = figaroh_config(work, "ur10", JOINTS, "tool0", {"tmac": True}, len(train), method, level,
                         (0.0, 0.0, TMAC_TOOL_MM / 1000))
    x, p = solve_figaroh(robot, cfg, held.q)
    e = np.linalg.norm(p.reshape(3, -1).T - held.xyz, axis=1) * 1000.0
    return {"mean": float(e.mean()), "max": float(e.max()), "setting": f"{method}/{level}",
            "parameters": len(x), "errors": e.round(5).tolist()}


def split_arguments(ap: argparse.ArgumentParser, page: str) -> None:
    """``--data``, ``--splits`` and ``--out`` of a benchmark on these splits (``page``: the
    stem of its results page under docs/results/)."""
    ap.add_argument("--data", help="series C's whole measurements_random_poses.csv (as bench_figaroh --data)")
    ap.add_argument("--splits", nargs="+", default=list(SPLITS), choices=SPLITS)
    ap.add_argument("--out", help=f"the results page (default docs/results/{page}.md; with --data "
                    f"docs/results/{page}_series_c.md)")


def split_setting(args: argparse.Namespace, page: str) -> tuple[str, Path]:
    """(the poses' description, the results page) of :func:`split_arguments`' ``args``;
    points this process and its children at the data."""
    os.environ[DATA_ENV] = str(Path(args.data).resolve()) if args.data else str(DATA)
    source = (f"the whole of series C ({Path(args.data).name}, fetched)" if args.data else
              "the 400 poses of series C in tests/data")
    return source, Path(args.out or ROOT / "docs" / "results" / (f"{page}_series_c.md" if args.data else f"{page}.md"))


def child(argv: list[str]) -> None:
    """One fit in this process; its figures as one JSON line on stdout."""
    tool, split, *setting = argv
    with tempfile.TemporaryDirectory() as d:
        r = run_vecpin(split, Path(d), *setting) if tool == "vecpin" else run_figaroh(split, Path(d), *setting)
    print("RESULT " + json.dumps(r))


def timed(args: list[str], script: str = __file__) -> dict:
    """Run one fit in a fresh process, ``script --child args`` (this bench's by default, also
    bench_tiago's); its figures and the process' wall time [s]."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    env.setdefault(DATA_ENV, str(DATA))
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, script, "--child", *args], capture_output=True, text=True, env=env)
    seconds = time.perf_counter() - t0
    line = next((ln for ln in p.stdout.splitlines() if ln.startswith("RESULT ")), None)
    if p.returncode or line is None:
        return {"error": (p.stderr.strip().splitlines() or ["no output"])[-1][:300], "seconds": seconds}
    return dict(json.loads(line[7:]), seconds=seconds)


def timed_in_turn(a: list[str], b: list[str], repeat: int) -> tuple[dict, dict]:
    """:func:`timed` of ``a`` and ``b``, ``repeat`` times each in turn (a, b, a, b, ...):
    the first run's figures (the fits are deterministic) with the median of the times,
    ``runs_s`` every time."""
    runs = [(timed(a), timed(b)) for _ in range(max(repeat, 1))]
    out = []
    for k in range(2):
        times = [r[k]["seconds"] for r in runs]
        out.append(dict(runs[0][k], seconds=float(np.median(times)), runs_s=[round(t, 2) for t in times]))
    return out[0], out[1]


def _cell(r: dict) -> str:
    return f"{r['mean']:.3f} / {r['max']:.3f}" if "mean" in r else "failed"


def paired(a: dict, b: dict) -> str:
    """The held-out mean of ``a`` less that of ``b`` on the same poses, with the standard
    error of the mean of the per-pose differences (mm), and whether it resolves a winner:
    a difference under two standard errors is a tie at this number of held-out poses."""
    if "errors" not in a or "errors" not in b:
        return "-"
    d = np.asarray(a["errors"]) - np.asarray(b["errors"])
    se = float(d.std(ddof=1) / np.sqrt(len(d)))
    verdict = "tie" if abs(d.mean()) < 2 * se else ("better" if d.mean() < 0 else "worse")
    return f"{d.mean():+.3f} ± {se:.3f} ({verdict})"


def table(rows: dict) -> list[str]:
    """The real-data table: per split, vecpin's default, FIGAROH's default and best, and
    the paired difference of vecpin's default from FIGAROH's default (:func:`paired`)."""
    out = ["| split | train / held out | vecpin default, mean / max mm | FIGAROH default | FIGAROH best (setting) "
           "| vecpin 6-DoF constant | vecpin default − FIGAROH default, mean ± SE mm "
           "| time vecpin / FIGAROH default / FIGAROH best / 6-DoF constant, s |",
           "|---|---|---|---|---|---|---|---|"]
    for split, r in rows.items():
        v, fd, fb, c = r["vecpin"], r["figaroh_default"], r["figaroh_best"], r["vecpin_constant"]
        out.append(f"| {split} | {r['train']} / {r['held']} | {_cell(v)} | {_cell(fd)} | {_cell(fb)} "
                   f"({fb.get('setting', '-')}) | {_cell(c)} | {paired(v, fd)} | {v['seconds']:.1f} / "
                   f"{fd['seconds']:.1f} / {fb['seconds']:.1f} / {c['seconds']:.1f} |")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", help="the results page (default docs/results/real_data.md; with --data "
                    "docs/results/real_data_series_c.md)")
    ap.add_argument("--data", help="series C's whole measurements_random_poses.csv (2,773 poses; fetched from the "
                    "dataset's repository, not in vecpin's) instead of the 400 poses in tests/data")
    ap.add_argument("--quick", action="store_true", help="FIGAROH's default only (no search for its best)")
    ap.add_argument("--all-settings", action="store_true", help="search all ten FIGAROH settings for its best")
    ap.add_argument("--settings", nargs="+", metavar="METHOD/LEVEL",
                    help="search these FIGAROH settings (its default always runs), e.g. map_cv/full_params")
    ap.add_argument("--splits", nargs="+", default=list(SPLITS), choices=SPLITS)
    ap.add_argument("--repeat", type=int, default=5, help="run vecpin's and FIGAROH's defaults this many times each, "
                    "in turn, and report the median time (one run's time on a shared machine varies by 20 %%)")
    ap.add_argument("--json", help="also save the figures to this file (a run per split can go in parallel)")
    ap.add_argument("--from-json", nargs="+", metavar="FILE", help="write the table from saved runs; fit nothing")
    args = ap.parse_args()
    if args.data:
        os.environ[DATA_ENV] = str(Path(args.data).resolve())
    source = (f"the whole of series C ({Path(args.data).name}, fetched)" if args.data else
              "the 400 poses of series C in tests/data")
    args.out = args.out or str(ROOT / "docs" / "results" / ("real_data_series_c.md" if args.data else "real_data.md"))
    if args.from_json:
        saved = [json.loads(Path(f).read_text()) for f in args.from_json]
        rows = {k: v for s in saved for k, v in s["rows"].items()}
        rows = {k: rows[k] for k in SPLITS if k in rows}
        write(args.out, rows, [e for s in saved for e in s["every"]], saved[0].get("searched", ""),
              saved[0].get("source", source))
        if not args.data and set(rows) == set(SPLITS):
            readme_table(rows, saved[0].get("source", source))
        return
    settings = ([FIGAROH_DEFAULT] if args.quick else [(m, lv) for lv in LEVELS for m in METHODS] if args.all_settings
                else list(SEARCHED))
    if args.settings:
        asked = [tuple(t.split("/")) for t in args.settings]
        bad = [t for t in asked if len(t) != 2 or t[0] not in METHODS or t[1] not in LEVELS]
        if bad:
            ap.error(f"--settings {'/'.join(bad[0])}: METHOD/LEVEL with METHOD one of {', '.join(METHODS)} "
                     f"and LEVEL one of {', '.join(LEVELS)}")
        settings = list(dict.fromkeys([FIGAROH_DEFAULT, *asked]))
    rows, every = {}, []
    for split in args.splits:
        m, train, held = _split(split)
        v, fd = timed_in_turn(["vecpin", split], ["figaroh", split, *FIGAROH_DEFAULT], args.repeat)
        const = timed(["vecpin", split, "--model", "6dof", "--order", "0"])
        print(f"{split}: vecpin {_cell(v)} ({v.get('setting', v.get('error'))}; {v['seconds']:.1f} s); 6-DoF constant "
              f"{_cell(const)} ({const['seconds']:.1f} s)", flush=True)
        figs = {}
        for s in settings:
            figs[s] = fd if s == FIGAROH_DEFAULT else timed(["figaroh", split, *s])
            print(f"  FIGAROH {'/'.join(s):24s} {_cell(figs[s])} ({figs[s]['seconds']:.1f} s)"
                  + (f" {figs[s]['error']}" if "error" in figs[s] else ""), flush=True)
        ok = {s: r for s, r in figs.items() if "mean" in r}
        best = min(ok, key=lambda s: ok[s]["mean"]) if ok else FIGAROH_DEFAULT
        rows[split] = {"train": len(train), "held": len(held), "vecpin": v, "figaroh_default": figs[FIGAROH_DEFAULT],
                       "figaroh_best": dict(figs[best], setting="/".join(best)), "vecpin_constant": const}
        every += [f"| {split} | {'/'.join(s)} | {_cell(r)} | {r['seconds']:.1f} |" for s, r in figs.items()]
    searched = ", ".join("/".join(st) for st in settings)
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "every": every, "searched": searched, "source": source}))
    write(args.out, rows, every, searched, source)
    if not args.data and set(rows) == set(SPLITS):
        readme_table(rows, source)


def write(out: str, rows: dict, every: list[str], searched: str = "", source: str = "") -> None:
    """The results page: the table per split and every FIGAROH setting's figures
    (``searched``: the settings FIGAROH's best was chosen from; ``source``: the poses)."""
    text = "\n".join(["# Real data: vecpin's default against FIGAROH (UR10, ipa-robot-accuracy)", "",
                      f"Written by `python benchmarks/bench_figaroh.py` on {source} (module docstring: the data, "
                      "the splits, the settings). Held-out distance between the measured T-Mac centre and the prediction, mm; "
                      "times are whole processes (start to exit) on a shared 2-core machine"
                      + (f", those of vecpin's and FIGAROH's defaults the median of {runs} runs each, in turn"
                         if (runs := _runs(rows)) > 1 else "") + ". The difference column "
                      "pairs the two tools' errors pose by pose: a tie is a difference under two standard errors "
                      "of its mean, which this many held-out poses cannot resolve."
                      + (f" FIGAROH's best among: {searched}." if searched else ""), "",
                      *table(rows), "", "## Every FIGAROH setting", "", "| split | setting | mean / max mm | time, s |",
                      "|---|---|---|---|", *every, ""])
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    Path(out).write_text(text)
    print("\n".join(table(rows)))
    print(f"written {out}")


def _runs(rows: dict) -> int:
    """How many runs the default times are the median of (1: one run)."""
    return min((len(r["vecpin"].get("runs_s", [0])) for r in rows.values()), default=1)


def readme_table(rows: dict, source: str) -> None:
    """The README's real-data table (between :data:`README_MARKS`): per split, vecpin's
    default, FIGAROH's default and best, the paired difference and the times."""
    runs = _runs(rows)
    lines = [f"UR10, {source}; held-out mean / max distance, mm; whole-process times, s"
             + (f" (the median of {runs} runs each, in turn)" if runs > 1 else "")
             + " (`python benchmarks/bench_figaroh.py`, [all figures](docs/results/real_data.md)):", "",
             "| split | vecpin default | FIGAROH default | FIGAROH best | vecpin − FIGAROH default | time vecpin / FIGAROH |",
             "|---|---|---|---|---|---|"]
    for split, r in rows.items():
        v, fd, fb = r["vecpin"], r["figaroh_default"], r["figaroh_best"]
        lines.append(f"| {split} | {_cell(v)} | {_cell(fd)} | {_cell(fb)} | {paired(v, fd)} "
                     f"| {v['seconds']:.1f} / {fd['seconds']:.1f} |")
    text = README.read_text()
    start, end = (text.index(mark) for mark in README_MARKS)
    README.write_text(text[:start + len(README_MARKS[0])] + "\n" + "\n".join(lines) + "\n" + text[end:])
    print(f"written the table in {README}")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2:])
    else:
        main()
