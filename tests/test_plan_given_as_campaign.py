"""A plan's template given where a campaign belongs (``fit``, ``evaluate``, ``assess``)
is named as such, not as an empty cell in row 2; one empty reading in a campaign is
still refused with its row and column."""
from hostile_helpers import refused

from vecpin.cli import main


def test_a_plan_template_is_not_a_campaign(tmp_path, capsys):
    assert main(["plan", "flow_xyzcb", "--points", "40", "--order", "2", "--dialect", "gcode", "--out",
                 str(tmp_path / "plan"), "--quiet"]) == 0
    plan = tmp_path / "plan" / "plan.csv"
    for argv in (["fit", "flow_xyzcb", plan, "--out", tmp_path / "m.json"], ["assess", plan, "--machine", "flow_xyzcb"]):
        refused(argv, capsys, "plan.csv", "column 'x'", "no readings", "plan's template", "vecpin import")
    assert not (tmp_path / "m.json").exists()


def test_one_empty_reading_still_names_its_row(tmp_path, capsys):
    assert main(["simulate", "flow_xyzcb", "--out", str(tmp_path / "s"), "--points", "30", "--validation-count",
                 "5"]) == 0
    lines = (tmp_path / "s" / "campaign.csv").read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[4].split(",")
    cells[header.index("y")] = ""
    lines[4] = ",".join(cells)
    (tmp_path / "c.csv").write_text("\n".join(lines) + "\n")
    refused(["fit", "flow_xyzcb", tmp_path / "c.csv", "--out", tmp_path / "m.json"], capsys,
            "c.csv, row 5, column 'y'", "empty cell")
