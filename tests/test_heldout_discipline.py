"""The held-out discipline of the generator benches (benchmarks/heldout.py, issue 40) and the validation
after gross errors of bench_unseen (benchmarks/unseen_gross.py): the seeds follow the rule the page
states, a held-out run refuses uncommitted code, shows no draw and keeps every run on its page; the
clean campaign is the campaign without exactly the gross lines. Imports no vecpin code.
"""
import hashlib
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import heldout  # noqa: E402
from unseen_gross import validation_lines, without_lines  # noqa: E402


def test_the_seeds_follow_the_stated_rule():
    """Seed i of a bench: the first four bytes of SHA-256 of "vecpin held-out <bench> <i>" (the page's words),
    below 2**31; a longer set begins with the shorter one; two benches share no seed here."""
    text = heldout.INTRO
    assert '"vecpin held-out <bench> <i>"' in text and "first four bytes of SHA-256" in text
    own = [int(hashlib.sha256(f"vecpin held-out unseen {i}".encode()).hexdigest()[:8], 16) % 2 ** 31
           for i in range(5)]
    assert heldout.heldout_seeds("unseen", 5) == own
    assert heldout.heldout_seeds("unseen", 8)[:5] == own
    assert not set(heldout.heldout_seeds("model_choice arm", 50)) & set(heldout.heldout_seeds("unseen", 50))


def _repo(tmp_path: Path) -> Path:
    git = ["git", "-c", "user.name=t", "-c", "user.email=t@t", "-C", str(tmp_path)]
    subprocess.run(["git", "init", "-q", str(tmp_path)], check=True)
    (tmp_path / "vecpin").mkdir()
    (tmp_path / "vecpin" / "a.py").write_text("x = 1\n")
    subprocess.run(git + ["add", "."], check=True)
    subprocess.run(git + ["commit", "-q", "-m", "one"], check=True)
    return tmp_path


def test_a_heldout_run_refuses_uncommitted_code_and_keeps_every_run(tmp_path, monkeypatch, capsys):
    repo = _repo(tmp_path)
    monkeypatch.setattr(heldout, "ROOT", repo)
    (repo / "vecpin" / "a.py").write_text("x = 2\n")
    with pytest.raises(SystemExit, match="commit first"):
        heldout.Run("unseen", 3)
    subprocess.run(["git", "-C", str(repo), "checkout", "-q", "--", "vecpin/a.py"], check=True)
    page = ["# title", "", "* clean campaigns silent: 2/2", "| family | x |", "|---|---|", "| thermal | 1 |",
            "## Model choice", "| seed | ratio |", "|---|---|", "| 662839765 | 1.02 |", "median 1.02",
            "## Every campaign", "| seed | layout |", "| 7 | x |"]
    runs = []
    for _ in range(2):
        run = heldout.Run("unseen", 3)
        run.page = repo / "heldout.md"
        run.title += f" #{len(runs)}"       # two runs in the same minute
        run.write(page[:6], final=False)
        run.write(page, final=True)         # replaces the interim entry
        runs.append(run)
    text = (repo / "heldout.md").read_text()
    assert text.startswith("# Held-out draws") and all(text.count(r.title) == 1 for r in runs)
    assert "interim" not in text and "clean campaigns silent: 2/2" in text and "### Model choice" in text
    assert "| thermal | 1 |" in text and "median 1.02" in text    # the summaries stay
    assert not any(s in text for s in ("662839765", "| seed | ratio |", "Every campaign", "| 7 |"))
    runs[0].progress(2)
    assert capsys.readouterr().out == "held-out unseen: 2 of 3 draws done\n"


def test_the_clean_campaign_drops_exactly_the_gross_lines(tmp_path):
    csv = tmp_path / "c.csv"
    csv.write_text("".join(f"line{i}\n" for i in range(1, 8)))
    out = without_lines(csv, [3, 6], tmp_path / "clean.csv")
    assert out.read_text().split() == ["line1", "line2", "line4", "line5", "line7"]


def test_the_validation_share_counts_within_ten_percent():
    def frac(k, n):
        return f"{k}/{n}"
    rec = {"seed": 1, "truth": {"kind": "head", "rows": 300}, "gross_true": 3, "gross_found": 3, "gross_false": 0}
    records = [rec | {"validation": {"vecpin_mm": v, "clean_mm": 0.01, "ratio": v / 0.01}}
               for v in (0.0105, 0.0109, 0.0125)] + [rec]
    lines = validation_lines(records, frac, detail=False)
    assert any("within 10% of a clean fit: 2/3" in ln and "worst 1.25" in ln for ln in lines)
