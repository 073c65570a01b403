"""What the machine gets from each controller's files (issue 21): the true compensated
error of the files as written, beside vecpin's full table set and the set it planned
for that controller, on simulated machines of different layouts.

The cases (tests/controller_cases.py, shared with tests/test_controller_files_e2e.py and test_controller_files_zones.py):
a trunnion (trunnion_xyzac), a head machine whose W follows the rotaries
(production_xyzbaw) over its whole travel and in its East and West zones (the model
fitted to the zone's rows, the tables fitted in it, judged on commands in it), two more
heads (flow_xyzcb, snk_120v), and the Master Mill's twin-drive X on a true gantry that
yaws with Z (an AP model with the gantry skew; the drives' differential turns the beam).
Per case a random true machine is measured (295 commands x 2 tools) and ``make_tables``
writes each controller's files with a profile whose reference points sit where real
machines have them (linear axes 5 mm inside the positive end, rotary axes at 0). The
files are applied to the true machine:

* every controller's files by a controller simulated from the vendor's documents or
  source (tests/controller_appliers.py: its own parsers, nothing of vecpin's readers):
  Siemens 840D and Fanuc 30i with and without the reference point data (MD_REFP.INI,
  parameter 1240), Heidenhain (CONFIG.CMA and .COM tables), LinuxCNC (COMP_FILE and the
  HAL component's tables; the real controller runs them in benchmarks/bench_linuxcnc.py);
  on the twin drive each drive gets its own tables and the true beam turns by their
  difference;
* the same files read back by vecpin's own readers (column 'vecpin's reader').

Every figure is the mean true tool-tip error [mm] relative to the workpiece in the part's
frame on a table aligned to the truth's own reference frame (a translation and a turn about
the spindle removed), over 150 fresh commands x 2 tools.

Run: python benchmarks/bench_controller_files.py [--out docs/results/controller_files.md] [--cases NAME ...]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from controller_cases import CONTROLLERS, baseline, commands, judge, make_case  # noqa: E402

from vecpin.errors import VecpinError  # noqa: E402

CASES = ("trunnion_xyzac", "production_xyzbaw", "production_xyzbaw east", "production_xyzbaw west", "flow_xyzcb",
         "snk_120v", "master_mill twin")
CASE_LABELS = {"production_xyzbaw east": "production_xyzbaw, East zone X 18415-25400",
               "production_xyzbaw west": "production_xyzbaw, West zone X 11430-18415",
               "master_mill twin": "master_mill, twin-drive X (gantry yaw)"}


def attempt(case, controller: str, folder: Path, q, tool, **kw) -> dict:
    """One controller's row: judged, or refused with the first line of the reason."""
    t0 = time.time()
    try:
        r = judge(case, controller, folder, q, tool, **kw)
    except VecpinError as exc:
        return {"refused": str(exc).splitlines()[0]}
    run = r.pop("run")
    r["headline"] = run.headline
    r["seconds"] = time.time() - t0
    return r


def one(label: str) -> list[dict]:
    case = make_case(label)
    q, tool = commands(case)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        base = {"machine": CASE_LABELS.get(label, label)} | baseline(case, Path(tmp) / "generic", q, tool)
        for controller in CONTROLLERS:
            r = attempt(case, controller, Path(tmp) / controller, q, tool)
            rows.append(base | {"controller": controller} | r)
            if "refused" in r and case.twin:   # what the refusal's advice gives: the profile without the separation
                r = attempt(case, controller, Path(tmp) / f"{controller}-nosep", q, tool, separation=False)
                rows.append(base | {"machine": base["machine"] + ", profile without drive_separation_mm",
                                    "controller": controller} | r)
    return rows


def table(rows: list[dict]) -> str:
    lines = ["True compensated error [mm], mean over 150 fresh commands x 2 tools, tool tip relative to the "
             "workpiece in the part's frame on a table aligned to the truth's own reference frame (written by "
             "benchmarks/bench_controller_files.py). 'planned': the table "
             "set vecpin chose under the controller's limits; 'files as written': the files with the named machine "
             "data applied to the true machine; 'without data': without the reference point values; "
             "'vecpin's reader': the same files read back by vecpin; 'first line': what the printout and the "
             "controller's README say first when the files give up more than 2 % of what the full tables remove "
             "(model-predicted).",
             "", "| machine | controller | uncompensated | full tables | planned (tables) | files as written | "
             "files / planned | files / full | without data | vecpin's reader | first line | judged by |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        head = f"| {r['machine']} | {r['controller']} | {r['uncompensated']:.4f} | {r['full']:.4f} | "
        if "refused" in r:
            lines.append(head + f"refused: {r['refused'].replace('|', '/')} | | | | | | | |")
            continue
        wo = f"{r['without data']:.4f}" if "without data" in r else "-"
        rd = f"{r['reader']:.4f}" if "reader" in r else "-"
        lines.append(head + f"{r['planned']:.4f} ({r['tables']}) | {r['written']:.4f} | "
                     f"{r['written'] / r['planned']:.3f} | {r['written'] / r['full']:.3f} | {wo} | {rd} | "
                     f"{r['headline'] or '-'} | {r['judged by']} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "results" /
                                         "controller_files.md"))
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=CASES, metavar="CASE",
                    help="cases to run (default: all): " + ", ".join(CASES))
    args = ap.parse_args(argv)
    rows = []
    for name in args.cases:
        t0 = time.time()
        for r in one(name):
            rows.append(r)
            if "refused" in r:
                print(f"{r['machine']} {r['controller']}: refused: {r['refused']}")
            else:
                print(f"{r['machine']} {r['controller']}: planned {r['planned']:.4f} mm, files {r['written']:.4f} mm "
                      f"({r['written'] / r['planned']:.3f}x planned, {r['written'] / r['full']:.3f}x full), "
                      f"uncompensated {r['uncompensated']:.4f}, full {r['full']:.4f}"
                      + (f", without data {r['without data']:.4f}" if "without data" in r else ""))
        print(f"  {name}: {time.time() - t0:.0f} s")
    text = table(rows)
    print(text)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
