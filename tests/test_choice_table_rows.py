"""The model choice's table says which rows it judges: on a table machine its
"uncompensated" row and held-out means count the table nests' readings with the tool's
(the campaign's rows counted here with the csv module); on a head machine, the tool's."""
import csv

from vecpin.measurement.campaign import read_campaign, write_campaign
from vecpin.selection.choice import choose_model
from vecpin.simulation.simulate import Design, simulate


def _table_head(machine, tmp_path, name):
    sim = simulate(machine, 3, design=Design(n_commands=40, n_validation=2))
    write_campaign(tmp_path / name, sim.campaign, machine)
    rows = list(csv.DictReader(open(tmp_path / name)))
    choice = choose_model(machine, read_campaign(tmp_path / name, machine), kinds=["ap"], orders=[0, 1], per_axis=False)
    return rows, choice.table().splitlines()


def test_the_rows_judged_are_named_with_the_nests_among_them(machines, tmp_path):
    rows, lines = _table_head(machines["trunnion_xyzac"], tmp_path, "t.csv")
    nests = sum(r["instrument"] == "nest" for r in rows)
    assert nests > 0
    assert (f"({len(rows)} rows judged: every reading of a point, the tool's and any table nest's; linearised)"
            in lines[0]), lines[0]
    assert lines[2].split()[:3] == ["uncompensated,", "the", "rows"]
    rows, lines = _table_head(machines["flow_xyzcb"], tmp_path, "f.csv")
    assert f"({len(rows)} rows judged: every reading of a point, the tool's; linearised)" in lines[0], lines[0]
