"""The held-out discipline of the generator benches (issue 40): a frozen seed set nobody looks at.

The draws of ``bench_unseen.py``, ``bench_model_choice.py`` and ``bench_generator_tables.py`` are
fresh every run while the method is developed. Their held-out draws are fixed by a committed rule
with no secret in it (:func:`heldout_seeds`: the i-th seed of a bench is the first four bytes of
SHA-256 of ``"vecpin held-out <bench> <i>"``), so anyone can rerun them, and they are judged only
by ``--heldout``, which

* refuses to run on uncommitted code (``vecpin/``, ``benchmarks/``, ``tests/``): the figures belong
  to one commit;
* prints no draw's details (no seed, no machine, no per-draw figure; progress is a count), only the
  summary of the bench's page;
* appends that summary to ``docs/results/heldout.md`` with the date, the commit and the number of
  draws; every held-out run stays on that page, so a second look is seen.

The discipline (docs/results/heldout.md says it to the reader): develop on fresh seeds, run
``--heldout`` once per stop (a release, the end of a round of work) and put its figures in the
note as they come; never change the method because of them, and never look at the draws.
"""
from __future__ import annotations

import fcntl
import hashlib
import re
import subprocess
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "results" / "heldout.md"
RULE = "vecpin held-out {bench} {i}"
CODE = ("vecpin", "benchmarks", "tests")
INTRO = """# Held-out draws of the generator benches (issue 40)

Written only by `--heldout` runs of `benchmarks/bench_unseen.py`, `bench_model_choice.py` and
`bench_generator_tables.py` (the discipline: `benchmarks/heldout.py`). Their draws are fixed by a
committed rule without a secret (seed i of a bench: the first four bytes of SHA-256 of
`"vecpin held-out <bench> <i>"`); a held-out run refuses uncommitted code, shows no draw's
details, only the summary, and adds it here with its date and commit. The method is developed on
fresh seeds; these figures are reported once per stop and never tuned to. Every held-out run stays
on this page, newest last.

The earlier frozen list (`benchmarks/generator/heldout_seeds.txt`, 40 seeds) is retired: a run of
it printed every campaign on `unseen.md`, so its draws were seen.
"""


def heldout_seeds(bench: str, n: int) -> list[int]:
    """The first ``n`` held-out seeds of ``bench`` (a name such as "unseen"), each in [0, 2**31)."""
    return [int.from_bytes(hashlib.sha256(RULE.format(bench=bench, i=i).encode()).digest()[:4], "big") % 2 ** 31
            for i in range(n)]


def _git(*args: str) -> str:
    return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True).stdout.strip()


def commit_or_refuse() -> str:
    """The commit the held-out figures belong to (short hash); SystemExit when the code has uncommitted
    changes or is not in a git repository."""
    head = _git("rev-parse", "--short", "HEAD")
    if not head:
        raise SystemExit("held-out run refused: not a git checkout, the figures would belong to no commit")
    dirty = _git("status", "--porcelain", "--", *CODE)
    if dirty:
        raise SystemExit("held-out run refused: commit first, the figures must belong to one commit; "
                         f"uncommitted: {', '.join(ln[3:] for ln in dirty.splitlines()[:5])}")
    return head


def is_draw_row(line: str) -> bool:
    """A table row about one draw (its first cell a seed)."""
    return bool(re.match(r"^\|\s*\d+\s*\|", line))


def aggregate(lines: list[str]) -> list[str]:
    """A bench page without any draw's details: the title dropped, the rows of one draw, the tables left
    with no row and the sections listing every draw ("## Every ...", "## per draw") left out, the remaining
    sections one level down."""
    out, skip = [], False
    for ln in lines[1:] if lines and lines[0].startswith("# ") else lines:
        if ln.startswith("## "):
            skip = ln.startswith(("## Every", "## per draw"))
            ln = "#" + ln
        if skip or is_draw_row(ln):
            continue
        out.append(ln)
    empty = {i for i, ln in enumerate(out) if i and ln.startswith("|---") and out[i - 1].startswith("|")
             and not (i + 1 < len(out) and out[i + 1].startswith("|"))}
    return [ln for i, ln in enumerate(out) if i not in empty and i + 1 not in empty]


class Run:
    """One held-out run of ``bench``: its page entry (replaced as the run goes, added once)."""

    def __init__(self, bench: str, n: int):
        self.bench, self.n, self.page = bench, n, PAGE
        self.commit = commit_or_refuse()
        self.started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
        self.title = f"## {bench}: {self.started}, commit {self.commit}"

    def progress(self, done: int) -> None:
        """The only line printed per draw: how many are done."""
        print(f"held-out {self.bench}: {done} of {self.n} draws done", flush=True)

    def write(self, page_lines: list[str], final: bool) -> str:
        """Add (or replace) this run's entry on the page: the aggregate of ``page_lines``; the entry's text."""
        state = "" if final else " (interim: the run had not finished)"
        entry = "\n".join([self.title, "", f"{self.n} held-out draws (seeds 0..{self.n - 1} of the rule for "
                           f"`{self.bench}`){state}.", *aggregate(page_lines)]).rstrip() + "\n"
        with open(Path(tempfile.gettempdir()) / "vecpin_heldout_page.lock", "w") as lock:   # two runs at once
            fcntl.flock(lock, fcntl.LOCK_EX)
            old = self.page.read_text(encoding="utf-8") if self.page.exists() else INTRO
            parts = old.split("\n" + self.title + "\n")
            if len(parts) == 2:   # this run's interim entry: replace it (it runs to the next entry or the end)
                rest = parts[1].split("\n## ", 1)
                old = parts[0] + ("\n## " + rest[1] if len(rest) == 2 else "")
            self.page.write_text(old.rstrip("\n") + "\n\n" + entry, encoding="utf-8")
        return entry
