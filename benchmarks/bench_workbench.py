"""Start-up of ``vecpin workbench`` to a usable page (issue 45: at most 2 s on this machine).

Each run is a fresh process, ``python -m vecpin workbench FOLDER --port 0 --no-browser`` on an
empty folder (a new day), timed from just before it is started until the page's every request
has answered HTTP 200: the page (``/``), its assets (``/static/app.js``, ``/static/style.css``)
and the three calls the page makes before it is usable (``/api/choices``, ``/api/options``,
``/api/state``: the stages' forms and the session), in that order, as a browser asks for
them. The CPU time is the server's own (user + system, from /proc, at that moment): the
stages' warm process, which the server starts beside the page, is a process of its own and
is not counted. The server is then stopped (SIGTERM, as Ctrl-C stops it) before the next run.

The machine (2 CPUs) is shared with other jobs: the load average at the start and the end is
printed beside the figures, and the median and the minimum over the runs are both given.

Run: python benchmarks/bench_workbench.py [--runs 10] [--no-page]
The ``vecpin`` run is the one in this worktree (PYTHONPATH set here).
"""
import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "results" / "workbench_startup.md"
TARGET_S = 2.0
REQUESTS = ("/", "/static/app.js", "/static/style.css", "/api/choices", "/api/options", "/api/state")


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of process ``pid`` so far (/proc/PID/stat fields 14, 15)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def one_start(folder: Path, env: dict) -> tuple[float, float, float]:
    """(wall s to the usable page, CPU s of the server by then, wall s to its first line) of one fresh server."""
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "vecpin", "workbench", str(folder), "--port", "0", "--no-browser"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        line = proc.stdout.readline()
        first = time.perf_counter() - t0
        url = re.search(r"http://127\.0\.0\.1:\d+", line)
        if not url:
            raise RuntimeError(f"the workbench did not start: {line}{proc.stdout.read()}")
        for path in REQUESTS:
            with urllib.request.urlopen(url.group(0) + path, timeout=30) as r:
                r.read()
                if r.status != 200:
                    raise RuntimeError(f"{path}: HTTP {r.status}")
        wall = time.perf_counter() - t0
        return wall, cpu_s(proc.pid), first
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=10, help="fresh starts (default 10)")
    ap.add_argument("--no-page", action="store_true", help=f"do not write {PAGE.relative_to(ROOT)}")
    args = ap.parse_args()
    env = dict(os.environ, PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1")
    load0 = os.getloadavg()
    walls, cpus, firsts = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.runs):
            wall, cpu, first = one_start(Path(tmp) / f"day{k}", env)
            walls.append(wall)
            cpus.append(cpu)
            firsts.append(first)
            print(f"  run {k + 1:2d}: usable page {wall:.2f} s (address printed {first:.2f} s), server CPU {cpu:.2f} s",
                  flush=True)
    load1 = os.getloadavg()
    rows = [("usable page (the 6 requests answered), wall s", walls), ("address printed, wall s", firsts),
            ("server CPU by the usable page, s", cpus)]
    table = [f"{'':<48s} {'median':>7s} {'min':>7s} {'max':>7s}"]
    table += [f"{name:<48s} {statistics.median(v):7.2f} {min(v):7.2f} {max(v):7.2f}" for name, v in rows]
    verdict = "within" if statistics.median(walls) <= TARGET_S else "over"
    load = (f"load average {load0[0]:.1f} at the start, {load1[0]:.1f} at the end "
            f"({os.cpu_count()} CPUs, shared with other jobs)")
    print("\n".join(table))
    print(f"{load}; median {statistics.median(walls):.2f} s: {verdict} the target of {TARGET_S:g} s")
    if not args.no_page:
        write_page(args.runs, table, load, walls, verdict)
        print(f"wrote {PAGE.relative_to(ROOT)}")
    return 0


def write_page(runs: int, table: list[str], load: str, walls: list[float], verdict: str) -> None:
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    PAGE.write_text(
        "# Start-up of the workbench (issue 45)\n\n"
        f"Made by `python benchmarks/bench_workbench.py --runs {runs}` (commit {head.stdout.strip() or 'unknown'}). "
        "Each run starts `vecpin workbench FOLDER --port 0 --no-browser` as a fresh process on an empty folder and "
        "times it until every request the page makes before it is usable has answered HTTP 200: the page, its "
        "two assets and the three calls that build the stages' forms and read the session "
        f"(`{'`, `'.join(REQUESTS)}`), asked in turn as a browser asks them. The CPU time is the server's "
        "own; the stages' warm process it starts beside the page is not counted. "
        f"The machine was shared: {load}.\n\n"
        "```text\n" + "\n".join(table) + "\n```\n\n"
        f"Median **{statistics.median(walls):.2f} s** to a usable page, {verdict} issue 45's target of "
        f"{TARGET_S:g} s.\n")


if __name__ == "__main__":
    sys.exit(main())
