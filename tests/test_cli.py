"""The command line: runs in-process, bad input gives one line and status 2."""
import json
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


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    d = tmp_path_factory.mktemp("sim")
    assert main(["simulate", "flow_xyzcb", "--out", str(d), "--seed", "3", "--points", "150"]) == 0
    return d


@pytest.mark.parametrize("model, extra", [("ap", []), ("6dof", ["--cartesian", "--tool-corrections"])])
def test_fit_then_evaluate(simulated, tmp_path, capsys, model, extra):
    import json
    out = tmp_path / "m.json"
    argv = ["fit", "flow_xyzcb", str(simulated / "campaign.csv"), "--model", model, "--order", "4", "--out", str(out)] + extra
    assert main(argv) == 0
    cap = capsys.readouterr()
    assert "chi2" in cap.out and "uncompensated" in cap.out and out.is_file()
    assert "iteration 1" in cap.err  # progress
    assert main(["evaluate", str(out), str(simulated / "validation_truth.csv"), "--json", str(tmp_path / "e.json")]) == 0
    text = capsys.readouterr().out
    assert "reduction of the mean" in text
    e = json.loads((tmp_path / "e.json").read_text())
    assert e["units"] == "mm" and e["model_residual"]["all"]["mean"] < 0.2 * e["uncompensated"]["all"]["mean"]
    assert main(["evaluate", str(out), str(simulated / "validation.csv"), "--reregister"]) == 0


def test_orders_prints_the_table(simulated, capsys):
    assert main(["orders", "flow_xyzcb", str(simulated / "campaign.csv"), "--models", "ap", "--orders", "1,3",
                 "--validation", str(simulated / "validation.csv"), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "Uncompensated" in out and "best ap order" in out
    # flow_xyzcb's C travels more than a turn: judged with Chebyshev series, the printout names the per-turn basis
    assert "C travels more than a turn" in out and "--basis fourier" in out
    best = int(out.split("best ap order on held-out data (validation file): ")[1].split()[0])
    assert ("is the highest tried (3)" in out and "--orders 1-7" in out) == (best == 3)


def test_demo_prints_before_and_after(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "Uncompensated" in out and "6-DoF order 6" in out and "AP order 6" in out
    assert (tmp_path / "model_ap.json").is_file() and (tmp_path / "model_6dof.json").is_file()


def test_fit_and_evaluate_bad_input(simulated, tmp_path, capsys):
    assert main(["fit", "cincinnati_20v", str(simulated / "campaign.csv"), "--out", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert "campaign.csv" in err and "Traceback" not in err
    (tmp_path / "junk.json").write_text("[1, 2]")
    assert main(["evaluate", str(tmp_path / "junk.json"), str(simulated / "campaign.csv")]) == 2
    assert "not a vecpin model file" in capsys.readouterr().err


PROFILE = str(DATA / "controllers" / "flow_xyzcb_profile.json")


@pytest.mark.parametrize("controller, extra", [("generic", []), ("siemens-840d", ["--profile", PROFILE, "--axis-map", "X=X1"]),
                                               ("fanuc-30i", ["--profile", PROFILE, "--method", "ga"]),
                                               ("generic", ["--max-tables", "4", "--no-circular", "--forbid-output", "X", "--method", "heuristic"]),
                                               ("linuxcnc", [])])
def test_tables_command(simulated, tmp_path, capsys, controller, extra):
    model = tmp_path / "m.json"
    assert main(["fit", "flow_xyzcb", str(simulated / "campaign.csv"), "--order", "4", "--out", str(model), "--quiet"]) == 0
    capsys.readouterr()
    out_dir = tmp_path / "tables"
    assert main(["tables", str(model), "--controller", controller, "--out", str(out_dir), "--quiet"] + extra) == 0
    out = capsys.readouterr().out
    assert "pitch only" in out and "full tables" in out and "gauge line" in out
    assert "model-predicted" in out and "every row on these points" in out   # honest labels
    assert (out_dir / "tables.json").is_file()
    # tables.json keeps the printout's figures of what the machine gets (the files as written where read back)
    predicted = json.loads((out_dir / "tables.json").read_text())["predicted"]
    row = predicted["written"]
    if controller != "generic" or not extra:
        assert row["label"] == ("full tables (model-predicted)" if controller == "generic" else
                                "files as written (model-predicted)")
    line = next(ln for ln in out.splitlines() if ln.startswith(f"  {row['label']}  "))
    tables, mean, top, _, shape = line[len(row["label"]) + 2:].split()[:5]   # the printout's columns
    assert (int(tables), mean, top, shape) == (row["tables"], *(f"{row[k]:.4f}" for k in
                                                                 ("mean_mm", "max_mm", "shape_mean_mm"))), line
    assert "part's frame" in predicted["frame"] and predicted["uncompensated"]["label"] == "uncompensated (model)"
    if controller == "siemens-840d":
        assert (out_dir / "NC_CEC.INI").is_file() and (out_dir / "README_SIEMENS.md").is_file()
        assert "files as written" in out
    if controller == "fanuc-30i":
        assert (out_dir / "PITCH.TXT").is_file() and (out_dir / "CNC-PARA.TXT").is_file() and "selection (genetic)" in out
    if controller == "linuxcnc":   # the COMP_FILEs alone: their row, and the command for pitch tables fitted alone
        assert "comp files without the component" in out
        assert f"`vecpin tables {model} --controller linuxcnc --max-tables 0 --out DIR`" in (
            out_dir / "README_LINUXCNC.md").read_text()
    if "--forbid-output" in extra:
        line = [ln for ln in out.splitlines() if ln.strip().startswith("tables:")][0]
        assert not any(t.startswith("x") and t != "xx" for t in line.split()[1:])


def test_tables_command_errors(simulated, tmp_path, capsys):
    model = tmp_path / "m.json"
    assert main(["fit", "flow_xyzcb", str(simulated / "campaign.csv"), "--order", "3", "--out", str(model), "--quiet"]) == 0
    assert main(["tables", str(model), "--controller", "siemens-840d", "--max-tables", "70", "--out", str(tmp_path / "t")]) == 2
    assert "at most 64" in capsys.readouterr().err
    assert main(["tables", str(model), "--forbid-output", "Q", "--out", str(tmp_path / "t")]) == 2
    assert "no axis 'Q'" in capsys.readouterr().err
    assert main(["tables", str(model), "--table-points", "10000000", "--out", str(tmp_path / "t")]) == 2
    assert "--table-points 10000000" in capsys.readouterr().err
    assert main(["tables", str(model), "--controller", "fanuc-30i", "--out", str(tmp_path / "t")]) == 2
    err = capsys.readouterr().err
    assert "controlled-axis number" in err and "--profile" in err and "Traceback" not in err
