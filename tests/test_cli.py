"""The command line: runs in-process, bad input gives one line and status 2."""
import subprocess
import sys
from pathlib import Path

import pytest

from vecpin.cli import main

DATA = Path(__file__).parent / "data"


def test_info_bundled(capsys):
    assert main(["info", "flow_xyzcb"]) == 0
    out = capsys.readouterr().out
    assert "X" in out and "6101.0000 mm" in out and "272.0000 deg" in out and "98.000 mm" in out


def test_info_urdf_path(capsys, flow):
    assert main(["info", str(flow.urdf_path)]) == 0
    assert "bundled machines" in capsys.readouterr().out


def test_simulate_writes_files(tmp_path, capsys):
    assert main(["simulate", "flow_xyzcb", "--out", str(tmp_path), "--seed", "2", "--points", "40"]) == 0
    out = capsys.readouterr().out
    assert "80 rows" in out and "uncompensated" in out
    for f in ("campaign.csv", "validation.csv", "validation_truth.csv", "truth.json"):
        assert (tmp_path / f).is_file()


@pytest.mark.parametrize("argv, message", [
    (["info", "no_such_machine"], "neither a URDF file nor a bundled machine"),
    (["simulate", "flow_xyzcb", "--out", "OUT", "--exclude", "X=bad"], "exclusion zone"),
])
def test_user_errors_exit_2_without_traceback(argv, message, tmp_path, capsys):
    argv = [str(tmp_path) if a == "OUT" else a for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_console_script_entry_point(tmp_path):
    """The installed `vecpin` module entry runs as a separate process."""
    r = subprocess.run([sys.executable, "-m", "vecpin", "info", "snk_120v"], capture_output=True, text=True)
    assert r.returncode == 0 and "snk_120v" in r.stdout
