"""The thermal day end to end on the command line: a campaign measured while the hall warms,
the thermal terms fitted and written beside the tables, and a validation run 6 K warmer than
the campaign's mean commanded through the tables with and without the terms: the saved true
machine (its drift kept in the truth file) ends closer with them."""
import re

import pytest

from vecpin.cli import main

pytestmark = pytest.mark.slow   # five CLI runs of a 100-command campaign


def _through_tables(text: str) -> float:
    return float(re.search(r"validation run through the tables\s+mean\s+([\d.]+) mm", text).group(1))


def test_thermal_terms_hold_at_another_temperature(tmp_path, capsys):
    s, t = tmp_path / "s", tmp_path / "t"
    assert main(["simulate", "flow_xyzcb", "--out", str(s), "--seed", "4", "--points", "100",
                 "--effect", "thermal:strength=0.05", "--temperature-profile", "warmup:18:22:3"]) == 0
    assert main(["fit", "flow_xyzcb", str(s / "campaign.csv"), "--model", "6dof", "--order", "4",
                 "--out", str(tmp_path / "m.json"), "--quiet"]) == 0
    assert main(["tables", str(tmp_path / "m.json"), "--thermal", str(s / "campaign.csv"), "--out", str(t)]) == 0
    capsys.readouterr()
    mean = {}
    for name, extra in (("without", []), ("with", ["--thermal", str(t / "thermal.json")])):
        assert main(["simulate", "flow_xyzcb", "--out", str(tmp_path / name), "--seed", "4", "--points", "100",
                     "--truth", str(s / "truth.json"), "--tables", str(t), "--temperature-profile",
                     "warmup:18:28:1", "--validation-after", "3", *extra]) == 0
        mean[name] = _through_tables(capsys.readouterr().out)
    assert mean["with"] < 0.7 * mean["without"], mean
