"""Reading and writing campaign files; every broken file in the corpus gets a clear
message naming the file, row and column."""
import json
from pathlib import Path

import numpy as np
import pytest

from vecpin.measurement.campaign import min_rows, read_campaign, write_campaign
from vecpin.errors import CampaignFileError

DATA = Path(__file__).parent / "data"
CASES = json.loads((DATA / "broken" / "cases.json").read_text())


def test_good_file_reads_in_si(flow):
    c = read_campaign(DATA / "good_flow.csv", flow)
    assert len(c) == 16 and c.axis_names == flow.axis_names
    raw = np.genfromtxt(DATA / "good_flow.csv", delimiter=",", names=True)
    np.testing.assert_allclose(c.q[:, 0], raw["X"] * 1e-3)
    np.testing.assert_allclose(c.q[:, 3], np.radians(raw["C"]))
    np.testing.assert_allclose(c.tool, raw["tool"] * 1e-3)
    np.testing.assert_allclose(c.xyz[:, 2], raw["z"] * 1e-3)
    assert set(c.extra) == {"time", "temperature"}
    np.testing.assert_allclose(c.time, raw["time"])
    np.testing.assert_allclose(c.tool_lengths(), [0.21488, 0.31286])


def test_round_trip_keeps_values_and_extra_columns(flow, tmp_path):
    c = read_campaign(DATA / "good_flow.csv", flow)
    c.extra["humidity"] = np.linspace(40, 45, len(c))
    write_campaign(tmp_path / "c.csv", c, flow)
    d = read_campaign(tmp_path / "c.csv", flow)
    np.testing.assert_allclose(d.q, c.q, atol=1e-9)
    np.testing.assert_allclose(d.xyz, c.xyz, atol=1e-9)
    np.testing.assert_allclose(d.extra["humidity"], c.extra["humidity"], atol=1e-6)
    sub = d.subset([0, 2, 4])
    assert len(sub) == 3 and sub.extra["humidity"].shape == (3,)


@pytest.mark.parametrize("case", sorted(CASES))
def test_broken_file_gives_clear_message(flow, case):
    spec = CASES[case]
    path = DATA / "broken" / f"{case}.csv"
    with pytest.raises(CampaignFileError) as info:
        read_campaign(path, flow)
    err = info.value
    text = str(err)
    assert str(path) in text
    assert spec["contains"] in text
    assert err.row == spec["row"]
    assert err.column == spec["column"]
    if spec["row"] is not None:
        assert f"row {spec['row']}" in text
    if spec["column"] is not None:
        assert f"column '{spec['column']}'" in text


def test_missing_file(flow, tmp_path):
    with pytest.raises(CampaignFileError, match="no such file"):
        read_campaign(tmp_path / "nope.csv", flow)


def test_min_rows_counts_the_smallest_model():
    assert min_rows(5) == 5  # ceil(12 / 3) + 1
    assert min_rows(3) == 5


def test_unknown_numeric_columns_are_kept(flow, tmp_path):
    text = (DATA / "good_flow.csv").read_text().splitlines()
    text = [text[0] + ",operator_id"] + [ln + f",{i}" for i, ln in enumerate(text[1:])]
    (tmp_path / "c.csv").write_text("\n".join(text) + "\n")
    c = read_campaign(tmp_path / "c.csv", flow)
    np.testing.assert_array_equal(c.extra["operator_id"], np.arange(len(c)))
