"""ruff, the linter, over the code as CI runs it (pyproject.toml [tool.ruff]: line length 120,
pycodestyle errors and warnings, pyflakes): unused imports and variables, undefined names,
ambiguous names and new lines over 120 characters fail the suite."""
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_ruff_finds_nothing():
    done = subprocess.run([sys.executable, "-m", "ruff", "check", "vecpin", "tests", "benchmarks", "examples"],
                          cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, f"ruff check (pyproject.toml [tool.ruff]):\n{done.stdout[-4000:]}{done.stderr[-2000:]}"


def test_the_long_line_allowance_only_names_files_that_need_it():
    """A file in the per-file E501 allowance whose lines are all within 120 characters leaves it."""
    import tomllib
    allowed = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["ruff"]["lint"]["per-file-ignores"]
    free = [f for f, rules in allowed.items() if "E501" in rules
            and max(map(len, (ROOT / f).read_text(encoding="utf-8").splitlines()), default=0) <= 120]
    assert not free, f"no line over 120 characters any more: take these out of the E501 allowance: {free}"
