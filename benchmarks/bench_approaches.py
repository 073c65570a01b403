"""Approaches that cannot collide (issue 41): on a trunnion (trunnion_xyzac), an all-table
machine (xyzac_trt) and a head machine (flow_xyzcb), the default plan (100 commands x 2
holders) and its NC programs, judged position by position.

Per machine: how many of the plan's approach positions the old rule (5 mm / 1 deg below
the point on every axis, Z included: a rapid past the point toward the work) would put
the target holder into the machine, how many of the chosen ones do, the candidates the
plan drops because every approach collides, the rotary swings the programs make; then
the plan program in G-code (LinuxCNC, run by tests/gcode.py) and in HEIDENHAIN
conversational (run by tests/heidenhain.py: interpreters from the controls' manuals, no
vecpin code) with every move's ends and quarter points posed with the machine's URDF
geometry (vecpin's holder check, SightLine.collisions), and whether every dwell stands at
the planned command.

Run: python benchmarks/bench_approaches.py [--out docs/results/approaches.md]
"""
from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from gcode import Start, run  # noqa: E402

import vecpin  # noqa: E402
from vecpin.planning.ncprogram import write_program  # noqa: E402
from vecpin.planning.plan import PlanSettings, make_plan  # noqa: E402
from vecpin.planning.programroute import Router  # noqa: E402
from vecpin.planning.sightline import SightLine  # noqa: E402

MACHINES = ["trunnion_xyzac", "xyzac_trt", "flow_xyzcb"]


def judge(m, text: str, dialect: str, template, sight: SightLine) -> tuple[int, int, bool]:
    """(positions posed, positions colliding, every dwell at its command) of one program."""
    prog = run(text, dialect, {a.name: (a.lower_user, a.upper_user) for a in m.axes}, Start())
    mounts = [(ln, float(re.search(r"holder of ([\d.]+) mm", c, re.I).group(1)) / 1000.0)
              for ln, c in prog.stops if re.search(r"holder of ([\d.]+) mm", c, re.I)]  # the holder each stop mounts
    pos, hold = [], []
    for mv in prog.moves:
        if any(mv.pos[a] is None for a in m.axis_names):
            continue
        L = max([(ln, x) for ln, x in mounts if ln < mv.line] or [mounts[0]])[1]
        b = np.array([mv.pos[a] for a in m.axis_names])
        a = b if any(mv.before[x] is None for x in m.axis_names) else np.array([mv.before[x] for x in m.axis_names])
        for t in (0.0, 0.25, 0.5, 0.75, 1.0):
            pos.append(a + t * (b - a))
            hold.append(L)
    hits = sight.collisions(m.to_si(np.array(pos)), np.array(hold))
    at = [prog.moves[max(i for kind, i in prog.events[:j] if kind == "move")]
          for j, e in enumerate(prog.events) if e[0] == "dwell"]
    rows = template.tool_rows
    ok = len(at) == len(rows) and np.allclose([[mv.pos[a] for a in m.axis_names] for mv in at],
                                              m.to_user(template.q[rows]), atol=5e-4)
    return len(pos), int((hits != "").sum()), bool(ok)


def measure(name: str) -> dict:
    m = vecpin.Machine.load(name)
    t0 = time.time()
    p = make_plan(m, PlanSettings())
    plan_s = time.time() - t0
    sl = SightLine(m, p.tracker)
    tr = p.template.take(p.template.tool_rows)
    old = sl.collisions(tr.q - p.steps, tr.tool)
    new = sl.collisions(tr.q - tr.approach * p.steps, tr.tool)
    dropped = sum(str(b).endswith("(approach)") for b in p.sight_by[p.removed == "collision"])
    swings = sum(s.what == "swing" for s in Router(m, p.template, p.steps, sl).steps())
    out = dict(machine=name, rows=len(tr), plan_s=plan_s, old=int((old != "").sum()),
               old_by=", ".join(sorted(set(old[old != ""]))) or "-", new=int((new != "").sum()), dropped=dropped,
               candidates=len(p.candidates), swings=swings)
    for dialect in ("gcode", "heidenhain"):
        t0 = time.time()
        text = write_program(dialect, m, p.template, p.steps, sight=sl)
        out[f"{dialect}_s"] = time.time() - t0
        out[dialect] = judge(m, text, dialect, p.template, sl)
    return out


def page(rows: list[dict]) -> str:
    s = ["# Approaches that cannot collide", "",
         "Written by `benchmarks/bench_approaches.py` (issue 41). The default plan (100 commands x 2 holders) per "
         "machine; the programs run by the tests' own interpreters (tests/gcode.py, tests/heidenhain.py) and every "
         "move's ends and quarter points posed with the machine's URDF geometry (the holder's axis, gauge line to "
         "target centre).", "",
         "| machine | tool rows | old rule: approach positions in the machine | chosen: in the machine | candidates "
         "dropped (every approach collides) | rotary swings | G-code positions posed / colliding / dwells at the "
         "commands | Klartext positions posed / colliding / dwells at the commands | plan s | program s (G-code, "
         "Klartext) |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        g, h = r["gcode"], r["heidenhain"]
        s.append(f"| {r['machine']} | {r['rows']} | {r['old']} ({r['old_by']}) | {r['new']} | {r['dropped']} of "
                 f"{r['candidates']} | {r['swings']} | {g[0]} / {g[1]} / {'yes' if g[2] else 'NO'} | {h[0]} / {h[1]} / "
                 f"{'yes' if h[2] else 'NO'} | {r['plan_s']:.0f} | {r['gcode_s']:.1f}, {r['heidenhain_s']:.1f} |")
    s += ["", "Old rule: the point minus the approach distance on every axis (`below`), Z included, as the programs "
          "approached before issue 41. Chosen: the approach the plan's approach column now names (Z always from "
          "the side away from the work). Times on the machine the benchmark ran on, loaded by other work.", ""]
    return "\n".join(s)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help="write the results page here (e.g. docs/results/approaches.md)")
    args = ap.parse_args()
    rows = []
    for name in MACHINES:
        rows.append(measure(name))
        print(rows[-1], flush=True)
    text = page(rows)
    print(text)
    if args.out:
        Path(args.out).write_text(text, encoding="utf-8")


if __name__ == "__main__":
    main()
