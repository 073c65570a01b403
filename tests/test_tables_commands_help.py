"""``vecpin tables --commands``: its help states the default the printout shows: the
tables are fitted and judged on at least 1000 quasi-random commands, more when the table
set has many coefficients (a five-axis machine with a rotary axis over two turns: more)."""
import re

import pytest

from hostile_helpers import ok

from vecpin.cli import main
from vecpin.compensation.plan import MIN_TABLE_COMMANDS, table_commands


@pytest.mark.slow   # an end-to-end run: kept out of the fast tier (its 180 s budget)
def test_the_default_number_of_commands_is_the_one_the_help_states(machines, tmp_path, capsys):
    m = machines["trunnion_xyzac"]
    assert main(["simulate", "trunnion_xyzac", "--out", str(tmp_path / "s"), "--seed", "1", "--points", "60",
                 "--validation-count", "5"]) == 0
    assert main(["fit", "trunnion_xyzac", str(tmp_path / "s" / "campaign.csv"), "--out", str(tmp_path / "m.json"),
                 "--model", "ap", "--order", "1", "--quiet"]) == 0
    capsys.readouterr()
    cap = ok(["tables", tmp_path / "m.json", "--controller", "generic", "--out", tmp_path / "t", "--quiet"], capsys)
    n = int(re.search(r"at (\d+) quasi-random commands in the measured region", cap.out)[1])
    assert n == table_commands(m, 2) and n > MIN_TABLE_COMMANDS    # C turns 1440 deg: more than the minimum
    try:
        main(["tables", "--help"])
    except SystemExit:
        pass
    help_text = " ".join(capsys.readouterr().out.split())
    assert f"at least {MIN_TABLE_COMMANDS}, more when the table set has many coefficients" in help_text
