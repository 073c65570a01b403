"""The demo's before/after table: columns stay aligned whatever the chosen model's label,
and the chosen model's time shows the model choice and the fit."""
import numpy as np

from vecpin.workflows.demo import DemoResult, DemoRow


def _row(label, seconds=None, choice_seconds=None, n=(590, 35, 35)):
    rng = np.random.default_rng(len(label))
    return DemoRow(label, rng.random(n[0]), rng.random(n[1]), rng.random(n[2]), seconds, choice_seconds)


def test_columns_stay_aligned_with_a_long_label():
    long = "chosen: AP cheb4/spline15/cheb4/fourier12+trend8/cheb4/fourier6+trend2"
    res = DemoResult(0, [_row("Uncompensated"), _row(long, 1.36, 12.5), _row("6-DoF order 6", 2.61),
                         _row("AP order 6", 1.86)])
    lines = res.table()
    body = [ln for ln in lines if ln.count("|") >= 3]
    assert len(body) == 6  # two header lines and four models
    bars = {tuple(i for i, ch in enumerate(ln) if ch == "|") for ln in body}
    assert len(bars) == 1, "the | separators move from line to line"
    assert any(long in ln for ln in body)


def test_the_chosen_model_shows_choice_and_fit_time():
    res = DemoResult(0, [_row("Uncompensated"), _row("chosen: 6-DoF cheb6", 1.36, 12.5), _row("AP order 6", 1.86)])
    text = "\n".join(res.table())
    assert "time (choice + fit)" in text
    chosen = next(ln for ln in text.splitlines() if "chosen: 6-DoF cheb6" in ln)
    assert chosen.rstrip().endswith("12.50 + 1.36 s")
    fixed = next(ln for ln in text.splitlines() if "AP order 6" in ln and "|" in ln)
    assert fixed.split("|")[-1].strip() == "1.86 s"
    uncomp = next(ln for ln in text.splitlines() if ln.strip().startswith("Uncompensated"))
    assert uncomp.rstrip().endswith("|")


def test_the_header_counts_the_rows_it_judges():
    res = DemoResult(0, [_row("Uncompensated", n=(100, 20, 20)), _row("AP order 6", 1.0, n=(100, 20, 20))])
    text = "\n".join(res.table())
    assert "identification (100)" in text and "validation (20)" in text
