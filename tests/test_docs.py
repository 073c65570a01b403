"""The documentation runs as written: README.md, ARCHITECTURE.md and every page under docs/
(the results pages excepted: the benchmarks write them, with no code in them).

* Every fenced block names its language. ```bash, ```sh and ```python blocks run; ```text
  (synopses with placeholders, printouts), ```console and ```json (a file's content shown,
  or a fragment of one) are shown, not run: nothing else is skipped.
* A page's runnable blocks run in order, in one empty temporary folder (where the
  repository's examples/, benchmarks/ and tests/ are linked, as in a checkout), as a reader
  following the page would: shell blocks with bash (`vecpin` is the installed entry point),
  Python blocks each in a fresh `python`. Lines that set up the environment or run this
  test suite (the venv, `pip install`, `python -m pytest`) are not run here: CI runs them
  (`.ci/run`), and the test checks that they are the lines .ci/run has.
* Pages whose blocks take more than a few seconds are marked slow (SLOW, with why).
* Synopses name real commands and options; the machine tables are what `vecpin info`
  lists; every example and benchmark is named; the site builds with `mkdocs build --strict`
  (failing, not skipping, under CI=true when MkDocs is missing).
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from vecpin.cli.main import build_parser

ROOT = Path(__file__).resolve().parents[1]
CI_RUN = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
RESULTS = ROOT / "docs" / "results"   # written by the benchmarks, except its index
PAGES = [ROOT / "README.md", ROOT / "ARCHITECTURE.md"] + sorted(
    p for p in (ROOT / "docs").rglob("*.md") if p.parent != RESULTS or p.name == "index.md")
RUN = {"bash": "bash", "sh": "bash", "python": "python"}
SHOWN = {"text", "console", "json"}
SETUP = ("python3 -m venv ", ". .venv/bin/activate", "pip install ", "python -m pytest")
SLOW = {  # page -> why its blocks take long (seconds on two shared cores)
    "README.md": "vecpin demo: the seed's campaign, the model choice and three fits (about a minute)",
    "docs/getting-started.md": "the demo by hand: a 590-row default fit (about 20 s)",
    "docs/whole-day.md": "plan, measurement, default fit, tables and validation (about a minute)",
    "docs/fitting.md": "a 6-DoF order-6 fit of 590 rows",
    "docs/diagnosis.md": "the diagnosis' search over effects",
    "docs/linuxcnc.md": "a fit and the LinuxCNC tables with the HAL component",
    "docs/real-data.md": "the default fit of 400 real UR10 poses",
}


def rel(page: Path) -> str:
    return page.relative_to(ROOT).as_posix()


def blocks(page: Path) -> list[tuple[int, str, str]]:
    """(line, language, body) of every fenced block of a page; indented fences (in lists) too."""
    text = page.read_text(encoding="utf-8")
    out = []
    for m in re.finditer(r"^([ \t]*)```([\w-]*)[^\n]*\n(.*?)^\1```[ \t]*$", text, re.M | re.S):
        body = "\n".join(ln[len(m.group(1)):] for ln in m.group(3).splitlines())
        out.append((text[:m.start()].count("\n") + 1, m.group(2), body + "\n"))
    return out


ALL = [(page, *b) for page in PAGES for b in blocks(page)]


def test_every_block_names_a_language_that_runs_or_is_shown():
    bad = [f"{rel(p)}:{line} ```{lang}" for p, line, lang, _ in ALL if lang not in RUN and lang not in SHOWN]
    assert not bad, f"blocks with no language or an unknown one (use bash/python to run, text/console/json to show): {bad}"


def setup_lines(body: str) -> tuple[list[str], str]:
    """The environment set-up lines of a shell block (CI runs them) and the rest."""
    setup, rest = [], []
    for line in body.splitlines():
        (setup if line.strip().startswith(SETUP) else rest).append(line)
    return setup, "\n".join(rest) + "\n"


def test_setup_lines_are_the_ones_ci_runs():
    lines = [ln.strip() for p, _, lang, body in ALL if lang in ("bash", "sh") for ln in setup_lines(body)[0]]
    assert lines, "the README shows how to install and test"
    ci = {ln.strip() for ln in CI_RUN.splitlines()}
    missing = [ln for ln in lines if ln not in ci]
    assert not missing, f"set-up lines the docs show that .ci/run does not run: {missing}"


def environment() -> dict[str, str]:
    """The shell of a reader: the installed `vecpin` and `python` first, this checkout's package."""
    env = dict(os.environ)
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    env["MPLBACKEND"] = "Agg"
    return env


def run_page(page: Path, folder: Path) -> list[str]:
    """Run the page's blocks in order in ``folder``; the outputs, one per block."""
    for name in ("examples", "benchmarks", "tests"):
        (folder / name).symlink_to(ROOT / name, target_is_directory=True)
    outputs, env = [], environment()
    for line, lang, body in blocks(page):
        if lang not in RUN:
            continue
        if RUN[lang] == "bash":
            argv = ["bash", "-e", "-o", "pipefail", "-c", setup_lines(body)[1]]
        else:
            argv = [sys.executable, "-c", body]
        done = subprocess.run(argv, cwd=folder, env=env, capture_output=True, text=True, timeout=900)
        assert done.returncode == 0, (f"{rel(page)}:{line} ```{lang} block failed (exit {done.returncode}):\n"
                                      f"{body}\n--- stdout\n{done.stdout[-3000:]}\n--- stderr\n{done.stderr[-3000:]}")
        outputs.append(done.stdout)
    return outputs


OWN_TEST = {  # page -> the test that runs its blocks as written, and judges what they wrote
    "docs/whole-day-machines.md": "tests/test_whole_day_machines.py",
}
RUNNABLE = [p for p in PAGES if any(lang in RUN for _, lang, _ in blocks(p)) and rel(p) not in OWN_TEST]


@pytest.mark.parametrize("page", [pytest.param(p, id=rel(p), marks=[pytest.mark.slow] if rel(p) in SLOW else [])
                                  for p in RUNNABLE])
def test_the_page_runs_as_written(page, tmp_path):
    outputs = run_page(page, tmp_path)
    assert outputs
    CHECKS.get(rel(page), lambda folder, out: None)(tmp_path, "".join(outputs))


def check_readme(folder: Path, out: str) -> None:
    """The demo printed its before/after table beside the seed's; the Python example wrote and
    read back tables."""
    assert "Uncompensated" in out and "6-DoF order 6" in out and "seed, Paper I Table 2" in out, out[-2000:]
    tables = json.loads((folder / "tables" / "tables.json").read_text())
    assert tables["tables"], "the example wrote no tables"


def check_whole_day(folder: Path, out: str) -> None:
    """The day made what the page says: the Siemens files with the reference point data, the
    validation program, and a verification whose reduction is the compensation's."""
    day = folder / "day"
    for f in ("PLAN_840D.MPF", "VALID_840D.MPF", "validation.csv", "plan.csv"):
        assert (day / "plan" / f).is_file(), f
    for f in ("AX_EEC.INI", "NC_CEC.INI", "MD_REFP.INI", "README_SIEMENS.md", "tables.json"):
        assert (day / "tables" / f).is_file(), f
    assert "X1" in (day / "tables" / "MD_REFP.INI").read_text()
    v = json.loads((day / "verify" / "verify.json").read_text())
    assert v["reduction_of_mean_pct"] > 60.0, v["reduction_of_mean_pct"]
    assert (day / "verify" / "verify.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def check_linuxcnc(folder: Path, out: str) -> None:
    for f in ("comp_X.txt", "vecpin_vec.comp", "vecpin_vec.hal", "README_LINUXCNC.md"):
        assert (folder / "tables" / f).is_file(), f


CHECKS = {"README.md": check_readme, "docs/whole-day.md": check_whole_day, "docs/linuxcnc.md": check_linuxcnc}


def test_slow_marks_name_pages_that_run():
    assert set(SLOW) <= {rel(p) for p in RUNNABLE}, set(SLOW) - {rel(p) for p in RUNNABLE}


# ---- what is shown but not run


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    p = build_parser()
    return next(a for a in p._actions if isinstance(a, argparse._SubParsersAction)).choices


def _commands(body: str) -> list[str]:
    """Shell commands of a block: continuation lines joined, comments dropped, split at && and ;."""
    out = []
    for line in re.sub(r"\\\n\s*", " ", body).splitlines():
        line = re.sub(r"(^|\s)#.*$", "", line).strip()
        out += [c.strip() for c in re.split(r"&&|;", line) if c.strip()]
    return out


def synopses() -> list[tuple[str, str]]:
    """Every `vecpin ...` command a page shows: in text blocks, in run blocks, inline."""
    out = []
    for page, line, lang, body in ALL:
        if lang in ("text", "bash", "sh"):
            out += [(f"{rel(page)}:{line}", c) for c in _commands(body) if c.startswith("vecpin ")]
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for m in re.finditer(r"`(vecpin [^`]+)`", text):
            out.append((f"{rel(page)}:{text[:m.start()].count(chr(10)) + 1}", m.group(1)))
    return out


def test_every_vecpin_command_shown_names_real_options():
    subs, bad = _subparsers(), []
    for where, cmd in synopses():
        words = cmd.split()
        if words[1] in ("--version", "--help", "..."):
            continue
        if words[1] not in subs:
            bad.append(f"{where}: no command '{words[1]}' ({cmd})")
            continue
        known = {o for a in subs[words[1]]._actions for o in a.option_strings}
        bad += [f"{where}: vecpin {words[1]} has no option {o}" for o in re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", cmd)
                if o not in known]
    assert not bad, "\n".join(bad)


OTHER_FLAGS = {"--strict": "mkdocs build", "--install": "halcompile", "--poses": "examples/ur10_real_data.py",
               "--quick": "benchmarks/bench_diagnosis.py", "--data": "benchmarks/bench_figaroh.py"}


def test_every_flag_named_anywhere_is_an_option():
    """A `--flag` in the prose (not only in a `vecpin ...` span) is an option of some command,
    or one of the few other tools' flags the docs name (OTHER_FLAGS)."""
    known = {o for s in _subparsers().values() for a in s._actions for o in a.option_strings} | {"--version"}
    bad = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for m in re.finditer(r"(?<![\w-])(--[a-z][a-z0-9-]*)", text):
            if m.group(1) not in known and m.group(1) not in OTHER_FLAGS:
                bad.append(f"{rel(page)}:{text[:m.start()].count(chr(10)) + 1}: {m.group(1)}")
    assert not bad, "no vecpin command has these options:\n" + "\n".join(bad)


def test_quick_start_is_the_demo_and_the_ci_test_command():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    body = re.search(r"```bash\n(.*?)```", section, re.S).group(1)
    lines = [ln for ln in body.splitlines() if ln.strip()]
    assert len(lines) == 2, lines
    assert shlex.split(lines[0])[:2] == ["vecpin", "demo"]
    test_line = next(ln.strip() for ln in CI_RUN.splitlines() if ln.strip().startswith("python -m pytest"))
    assert lines[1] == test_line


def test_readme_is_a_front_door():
    n = len((ROOT / "README.md").read_text(encoding="utf-8").splitlines())
    assert n <= 150, f"README.md has {n} lines: move details into docs/"
    png = ROOT / "docs" / "img" / "verify.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size <= 200_000
    assert "docs/img/verify.png" in (ROOT / "README.md").read_text(encoding="utf-8")


def machine_tables() -> list[tuple[str, dict[str, tuple[int, str]]]]:
    out = []
    for page in PAGES:
        rows = {}
        for ln in page.read_text(encoding="utf-8").splitlines():
            m = re.match(r"\|\s*`([a-z0-9_]+)`\s*\|\s*(\d+)\s*\|\s*([^|]+?)\s*\|", ln)
            if m:
                rows[m.group(1)] = (int(m.group(2)), m.group(3))
        if rows:
            out.append((rel(page), rows))
    return out


def test_machine_tables_are_what_vecpin_info_lists(machines):
    tables = machine_tables()
    assert "README.md" in [p for p, _ in tables]
    for page, rows in tables:
        assert sorted(rows) == sorted(machines), page
        for name, row in rows.items():
            assert row == (machines[name].n_axes, machines[name].layout), f"{page}: {name}"


def test_every_example_and_benchmark_is_named_and_exists():
    text = "".join(p.read_text(encoding="utf-8") for p in PAGES)
    named = set(re.findall(r"python ((?:examples|benchmarks)/[\w.]+\.py)", text))
    assert all((ROOT / p).is_file() for p in named), [p for p in named if not (ROOT / p).is_file()]
    files = list((ROOT / "examples").glob("*.py")) + list((ROOT / "benchmarks").glob("bench_*.py"))
    missing = [f"{p.parent.name}/{p.name}" for p in files if f"{p.parent.name}/{p.name}" not in named]
    assert not missing, f"the docs do not mention {missing}"


def test_the_api_page_names_the_facade():
    """The Python API page's table lists exactly the names `import vecpin` offers."""
    import vecpin
    text = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    named = set()
    for ln in text.splitlines():
        if ln.startswith("| `") and not ln.startswith("| `vecpin.`"):
            named |= set(re.findall(r"`(\w+)`", ln.split("|")[1]))
    assert named == set(vecpin.__all__) - {"__version__"}, set(vecpin.__all__) ^ named


# ---- the site


def _hooks():
    spec = importlib.util.spec_from_file_location("vecpin_docs", ROOT / "docs" / "hooks" / "vecpin_docs.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_controller_results_are_the_benchmarks_rows(tmp_path):
    """The compensation page's per-controller tables are the results file's rows, unchanged."""
    f = tmp_path / "r.md"
    f.write_text("Lead.\n\n| machine | controller | full |\n|---|---|---|\n| a | c1 | 0.1 |\n| b | c2 | 0.2 |\n"
                 "| c | c1 | 0.3 |\n")
    md = _hooks().controller_rows("c1", f)
    assert md.startswith("Lead.") and "| a | 0.1 |" in md and "| c | 0.3 |" in md and "0.2" not in md
    with pytest.raises(ValueError, match="c3"):
        _hooks().controller_rows("c3", f)
    page = (ROOT / "docs" / "compensation.md").read_text(encoding="utf-8")
    for name in re.findall(r"<!-- vecpin:controller-results ([\w-]+) -->", page):
        assert _hooks().controller_rows(name).count("\n| ") >= 2, name


def test_every_controller_has_its_section():
    """The compensation page prints every registered controller format's record."""
    from vecpin.export.registry import FORMATS
    page = (ROOT / "docs" / "compensation.md").read_text(encoding="utf-8")
    assert set(re.findall(r"<!-- vecpin:controller-facts ([\w-]+) -->", page)) == set(FORMATS)
    assert "sign: " in _hooks().controller_facts("fanuc-30i")


@pytest.mark.slow  # about 5 s alone, 15 s on shared cores
def test_the_site_builds_with_warnings_as_errors(tmp_path):
    mkdocs = shutil.which("mkdocs", path=str(Path(sys.executable).parent)) or shutil.which("mkdocs")
    if mkdocs is None:
        if os.environ.get("CI") == "true":
            pytest.fail("mkdocs is not installed: pip install -e '.[docs]' (CI must build the site)")
        pytest.skip("mkdocs is not installed (pip install -e '.[docs]')")
    t0 = time.perf_counter()
    done = subprocess.run([mkdocs, "build", "--strict", "--site-dir", str(tmp_path / "site")], cwd=ROOT,
                          env=environment(), capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    print(f"mkdocs build --strict: {time.perf_counter() - t0:.1f} s")
    assert (tmp_path / "site" / "whole-day" / "index.html").is_file()
    cli = (tmp_path / "site" / "cli" / "index.html").read_text(encoding="utf-8")
    assert all(f"vecpin {name}" in cli for name in _subparsers())
