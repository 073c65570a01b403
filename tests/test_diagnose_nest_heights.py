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


def test_simulate_writes_the_face_swept_on_its_truth(sim):
    """On a turning table with nests, ``vecpin simulate`` writes table_face.csv beside nest_heights.csv: X and
    Y swept 300 mm about the middle of the measured commands, the rotaries at zero, read on its truth with a
    2 µm normal error (sd_um 2, stated): each change within 4 sd of the reading the independent judge makes on
    the same truth (tests/part_frame_judge.py's indicator_sweep, exact), and the file reads back as the fit's."""
    import numpy as np
    from part_frame_judge import indicator_sweep
    import vecpin
    from vecpin.measurement.campaign import read_campaign
    from vecpin.measurement.tableface import read_table_face
    from vecpin.simulation.truth import TrueMachine
    m = vecpin.Machine.load("trunnion_xyzac")
    folder = sim / "sim"
    readings = read_table_face(folder / "table_face.csv", m)
    truth = TrueMachine.load(folder / "truth.json", m)
    c = read_campaign(folder / "campaign.csv", m)
    box = (c.q.min(axis=0), c.q.max(axis=0))
    assert sorted(readings) == ["X", "Y"]
    for axis, (d_mm, change_um, sd_um) in readings.items():
        moved, exact = indicator_sweep(truth, m, box, axis, 0.3, min(c.tool_lengths()), 0.0,
                                        np.random.default_rng(0))
        assert sd_um == 2.0 and d_mm == pytest.approx(moved * 1e3, abs=1e-3)
        assert abs(change_um - exact * 1e6) < 4 * sd_um and abs(exact) > 1e-6   # a real slope, read to its noise
