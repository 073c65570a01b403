"""README.md says what the code does: every command it shows is one the CLI takes.

* every ```bash block is runnable as written: each `vecpin ...` command in it parses
  with the CLI's own parser (arguments valid), the other commands are pip/python/git;
* ```text blocks are synopses (placeholders in capitals, [optional parts]): each
  `vecpin CMD` names a command and every --option in it is one of CMD's options; the
  same for inline `vecpin ...` spans in the prose;
* the quick start is two commands, and the commands the README says are "the same as
  the demo" run in a fresh folder and write what the demo writes; the Python examples
  run;
* the table of bundled machines is the list `vecpin info` prints, with its layouts.
"""
import argparse
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from vecpin.cli.main import build_parser, main

README = Path(__file__).resolve().parents[1] / "README.md"
TEXT = README.read_text(encoding="utf-8")


def _blocks(lang: str) -> list[tuple[int, str]]:
    """(line number, body) of every fenced block of this language."""
    out = []
    for m in re.finditer(rf"^```{lang}\n(.*?)^```", TEXT, re.M | re.S):
        out.append((TEXT[:m.start()].count("\n") + 1, m.group(1)))
    return out


def _commands(body: str) -> list[str]:
    """Shell commands of a block: continuation lines joined, comments dropped, split at
    && and ;."""
    joined = re.sub(r"\\\n\s*", " ", body)
    out = []
    for line in joined.splitlines():
        line = re.sub(r"(^|\s)#.*$", "", line).strip()
        out += [c.strip() for c in re.split(r"&&|;", line) if c.strip()]
    return out


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    p = build_parser()
    return [a for a in p._actions if isinstance(a, argparse._SubParsersAction)][0].choices


def _parse(argv: list[str]) -> argparse.Namespace:
    try:
        return build_parser().parse_args(argv)
    except SystemExit as exc:  # argparse reports on stderr and exits 2
        raise AssertionError(f"`vecpin {' '.join(argv)}` does not parse (exit {exc.code})") from None


BASH = _blocks("bash")
TEXT_BLOCKS = _blocks("text")


def test_the_readme_has_runnable_blocks_and_synopses():
    assert len(BASH) >= 4 and len(TEXT_BLOCKS) >= 3


@pytest.mark.parametrize("line, body", BASH, ids=[f"line{n}" for n, _ in BASH])
def test_every_bash_command_parses(line, body):
    cmds = _commands(body)
    assert cmds, f"README line {line}: an empty bash block"
    for cmd in cmds:
        argv = shlex.split(cmd)
        if argv[0] == "vecpin":
            holders = [a for a in argv if re.search(r"[\[\]|]|\.\.\.", a) or re.fullmatch(r"[A-Z]{2,}[A-Z0-9_]*(\.[a-z]+)?", a)]
            assert not holders, (f"README line {line}: placeholders {holders} in a runnable block ({cmd}); "
                                 "use a ```text block for a synopsis")
            _parse(argv[1:])
        else:
            assert argv[0] in ("pip", "python", "python3", "git", "cd", "xacro"), f"README line {line}: {cmd}"


def _synopsis_lines() -> list[tuple[str, str]]:
    out = []
    for line, body in TEXT_BLOCKS:
        out += [(f"line {line}", c) for c in _commands(body) if c.startswith("vecpin ")]
    for m in re.finditer(r"`(vecpin [^`]+)`", TEXT):
        out.append((f"line {TEXT[:m.start()].count(chr(10)) + 1}", m.group(1)))
    return out


SYNOPSES = _synopsis_lines()


@pytest.mark.parametrize("where, cmd", SYNOPSES, ids=[f"{w}:{c[:40]}" for w, c in SYNOPSES])
def test_every_synopsis_names_real_options(where, cmd):
    words = cmd.split()
    subs = _subparsers()
    if words[1] in ("--version", "--help"):
        return
    assert words[1] in subs, f"README {where}: no command '{words[1]}' ({cmd})"
    known = {o for a in subs[words[1]]._actions for o in a.option_strings}
    for opt in re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", cmd):
        assert opt in known, f"README {where}: vecpin {words[1]} has no option {opt} ({cmd})"


def test_quick_start_is_two_commands_that_install_and_run_the_demo():
    section = TEXT.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    body = re.search(r"```bash\n(.*?)```", section, re.S).group(1)
    lines = [ln for ln in body.splitlines() if ln.strip()]
    assert len(lines) == 2, lines
    assert lines[0].startswith('pip install -e ".[test]"') and "vecpin demo" in lines[0]
    assert lines[1] == "python -m pytest -q"
    demo = shlex.split(lines[0].split("&&")[1])
    args = _parse(demo[1:])
    assert args.command == "demo"


def _same_as_demo_block() -> str:
    section = TEXT.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```bash\n(.*?)```", section, re.S)
    assert len(blocks) == 2, "the quick start shows the install/demo line and the demo by hand"
    return blocks[1]


def test_the_demo_by_hand_runs_as_written(tmp_path, monkeypatch, capsys):
    """The README's "the demo is the same as" commands, run in a fresh folder; then the
    README's Python examples in the same folder (they read demo/campaign.csv)."""
    monkeypatch.chdir(tmp_path)
    cmds = _commands(_same_as_demo_block())
    assert [shlex.split(c)[1] for c in cmds] == ["simulate", "fit", "evaluate"]
    for c in cmds:
        argv = shlex.split(c)[1:]
        assert main(argv + (["--quiet"] if argv[0] == "fit" else [])) == 0, c
    out = capsys.readouterr().out
    assert "reduction of the mean" in out
    for name in ("campaign.csv", "validation.csv", "validation_truth.csv", "truth.json", "model.json"):
        assert (tmp_path / "demo" / name).is_file()

    # the Python examples, with the arrays their comments describe
    from vecpin.kinematics.machine import Machine
    m = Machine.load("flow_xyzcb")
    q = np.array([[0.5 * (a.lower + a.upper) for a in m.axes]] * 3)
    env = {"q": q, "tool": np.full(3, 0.2), "p_wp": np.array([0.1, 0.0, 0.05])}
    pys = _blocks("python")
    assert len(pys) >= 2
    for line, body in pys:
        if "register" in body:  # plug-in examples live in ARCHITECTURE.md and tests/test_plugins.py
            continue
        try:
            exec(compile(body, f"README.md:{line}", "exec"), dict(env))
        except Exception as exc:  # noqa: BLE001 - name the README line
            raise AssertionError(f"README line {line}: the Python example fails: {exc!r}") from exc


def test_the_bundled_machine_table_is_what_vecpin_info_lists():
    from vecpin.kinematics.machine import Machine, bundled_machines
    section = TEXT.split("## Machines", 1)[1].split("\n## ", 1)[0]
    rows = {}
    for ln in section.splitlines():
        m = re.match(r"\|\s*`([a-z0-9_]+)`\s*\|\s*(\d+)\s*\|\s*([^|]+?)\s*\|", ln)
        if m:
            rows[m.group(1)] = (int(m.group(2)), m.group(3))
    assert sorted(rows) == sorted(bundled_machines())
    for name, (n_axes, layout) in rows.items():
        mach = Machine.load(name)
        assert (n_axes, layout) == (mach.n_axes, mach.layout), name


def test_every_example_and_benchmark_named_exists():
    root = README.parent
    named = set(re.findall(r"python ((?:examples|benchmarks)/[\w.]+\.py)", TEXT))
    assert named, "the README names its examples and benchmarks"
    for p in named:
        assert (root / p).is_file(), p
    for p in list((root / "examples").glob("*.py")) + list((root / "benchmarks").glob("bench_*.py")):
        assert f"{p.parent.name}/{p.name}" in named, f"the README does not mention {p.parent.name}/{p.name}"
