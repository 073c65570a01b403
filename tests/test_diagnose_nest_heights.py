"""``vecpin diagnose --nest-heights``: the nests' heights above the table's face reach both model
files, as ``fit``'s model carries them, so ``vecpin tables`` on the diagnosis' model keeps the face;
a height file naming a nest the campaign lacks is refused before any fit."""
from __future__ import annotations

import json

import pytest

from vecpin.cli import main

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    d = tmp_path_factory.mktemp("dn")
    assert main(["simulate", "trunnion_xyzac", "--out", str(d / "sim"), "--seed", "2", "--points", "60",
                 "--nests", "3"]) == 0
    return d


def test_both_model_files_carry_the_heights(sim, capsys):
    heights = sim / "sim" / "nest_heights.csv"
    given = {r.split(",")[0]: float(r.split(",")[2]) for r in heights.read_text().splitlines()[1:]}
    assert main(["diagnose", "trunnion_xyzac", str(sim / "sim" / "campaign.csv"), "--out", str(sim / "d"),
                 "--effects", "backlash", "--nest-heights", str(heights), "--quiet"]) == 0
    for name in ("model_base.json", "model_best.json"):
        carried = json.loads((sim / "d" / name).read_text())["tracker"]["nest_heights_mm"]
        assert carried == pytest.approx(given, abs=1e-9)


def test_an_unknown_nest_is_refused_before_any_fit(sim, tmp_path, capsys):
    bad = tmp_path / "h.csv"
    bad.write_text("nest,planned_mm,height_mm\n1,60,60\n2,70,70\n7,50,50\n")
    assert main(["diagnose", "trunnion_xyzac", str(sim / "sim" / "campaign.csv"), "--out", str(tmp_path / "d"),
                 "--nest-heights", str(bad), "--quiet"]) != 0
    err = capsys.readouterr().err
    assert "h.csv" in err and "'7'" in err and not (tmp_path / "d").exists()
