"""The sign test tells a controller that applies the files as documented from one that
applies them with the opposite sign.

The simulated controllers below read the written files with their own small parsers and
apply the values by the vendor's documented rule (sources in each function), on a machine
with its own axis error; the check's readings then go through ``vecpin evaluate
--sign-test``. Nothing here uses vecpin's readers."""
import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest

from gcode import run
from vecpin.cli import main
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.simulate import Design, simulate
from vecpin.workflows.tables import check_sign, make_tables

PROFILE = Path(__file__).parent / "data" / "controllers" / "flow_xyzcb_profile.json"


@pytest.fixture(scope="module")
def model(machines):
    flow = machines["flow_xyzcb"]
    sim = simulate(flow, seed=4, design=Design(n_commands=150))
    return make_model("ap", flow, 3).fit(sim.campaign, NoiseModel.default(flow, "spherical"))


# ---------------------------------------------------------------- simulated controllers
def siemens_eec(folder: Path, axis: str, x_mm: np.ndarray) -> np.ndarray:
    """K3 p.238: 'A positive compensation value causes the machine axis to move in the negative direction.'"""
    text = (folder / "AX_EEC.INI").read_text()
    vals = {int(n): float(v) for n, v in re.findall(rf"\$AA_ENC_COMP\[0,(\d+),{axis}\]=(\S+)", text)}
    step = float(re.search(rf"\$AA_ENC_COMP_STEP\[0,{axis}\]=(\S+)", text).group(1))
    lo = float(re.search(rf"\$AA_ENC_COMP_MIN\[0,{axis}\]=(\S+)", text).group(1))
    v = np.array([vals[n] for n in range(len(vals))])
    return -np.interp(x_mm, lo + step * np.arange(len(v)), v)


def siemens_cec(folder: Path, inp: str, out: str, x_mm: np.ndarray) -> np.ndarray:
    """K3 sag section (840D sl FM 03/2009 p.372): a positive value moves the compensation axis negative."""
    text = (folder / "NC_CEC.INI").read_text()
    t = next(k for k, i in re.findall(r"\$AN_CEC_INPUT_AXIS\[(\d+)\]=\((\w+)\)", text)
             if i == inp and re.search(rf"\$AN_CEC_OUTPUT_AXIS\[{k}\]=\({out}\)", text))
    vals = {int(n): float(v) for n, v in re.findall(rf"\$AN_CEC\[{t},(\d+)\]=(\S+)", text)}
    step = float(re.search(rf"\$AN_CEC_STEP\[{t}\]=(\S+)", text).group(1))
    lo = float(re.search(rf"\$AN_CEC_MIN\[{t}\]=(\S+)", text).group(1))
    v = np.array([vals[n] for n in range(len(vals))])
    return -np.interp(x_mm, lo + step * np.arange(len(v)), v)


def fanuc_pitch(folder: Path, number: int, x_mm: np.ndarray, ref_mm=0.0, unit=0.001) -> np.ndarray:
    """B-63980EN p.100: point n at (n - 3620) x 3624 from the reference; its value is the
    compensation over the section ending at n, x 3623 detection units; zero at the reference."""
    para = (folder / "CNC-PARA.TXT").read_text()
    p = {int(n): re.search(rf"A{number}P(-?[\d.]+)", body).group(1)
         for n, body in re.findall(r"N0(\d{4})Q1(\S+)", para)}
    ref, first, last, mag, interval = int(p[3620]), int(p[3621]), int(p[3622]), int(p[3623]), float(p[3624])
    data = {int(n): int(v) for n, v in re.findall(r"N1(\d{4})Q0P(-?\d+)", (folder / "PITCH.TXT").read_text())}
    points = np.arange(first - 1, last + 1)
    absolute = np.array([sum(data[k] for k in range(ref + 1, n + 1)) - sum(data[k] for k in range(n + 1, ref + 1))
                         for n in points]) * mag * unit
    return np.interp(x_mm, ref_mm + (points - ref) * interval, absolute)


def linuxcnc_type0(folder: Path, axis: str, x_mm: np.ndarray) -> np.ndarray:
    """usrmotintf.cc: trim = nominal - actual (type 0); control.c: motor_pos_cmd = pos_cmd + trim."""
    rows = []
    for ln in (folder / f"comp_{axis}.txt").read_text().splitlines():
        try:
            rows.append([float(v) for v in ln.split()[:3]])
        except ValueError:
            break
    a = np.array(rows)
    return np.interp(x_mm, a[:, 0], a[:, 0] - a[:, 1])


def beckhoff_ssfk(folder: Path, axis: str, x_mm: np.ndarray) -> np.ndarray:
    """TF5200: compensation value = actual - programmed (0.1 um); the NC takes it off the setpoint."""
    kv = dict(ln.split(None, 1) for ln in (folder / f"achskw_{axis}.lis").read_text().splitlines()
              if ln.strip() and not ln.startswith("#"))
    n = int(kv["kw.ssfk.kw_nr_max"])
    sp = np.array([int(kv[f"kw.ssfk.table[{i}].setpoint"]) for i in range(n)]) * 1e-4
    pos = np.array([int(kv[f"kw.ssfk.table[{i}].pos"]) for i in range(n)]) * 1e-4
    return -np.interp(x_mm, sp, pos)


CASES = {
    "siemens-840d X": ("siemens-840d", "X", {}, lambda d, x: siemens_eec(d, "X1", x)),
    "siemens-840d yx": ("siemens-840d", "yx", {}, lambda d, x: siemens_cec(d, "AX1", "AX2", x)),
    "fanuc-30i X": ("fanuc-30i", "X", {"max_tables": 1, "method": "heuristic"}, lambda d, x: fanuc_pitch(d, 1, x)),
    "linuxcnc X": ("linuxcnc", "X", {}, lambda d, x: linuxcnc_type0(d, "X", x)),
    "beckhoff X": ("beckhoff", "X", {"method": "heuristic"}, lambda d, x: beckhoff_ssfk(d, "X", x)),
}


def machine_error(x_mm):
    """The simulated machine's own error along the measured axis [mm] (unknown to the test)."""
    return 0.02 * np.sin(x_mm / 700.0) + 1e-5 * x_mm


def check_csv(path: Path, test: dict, applied, sign: float, rng) -> None:
    """Three runs off and on, 0.5 um indicator noise, an arbitrary indicator zero."""
    p = np.array(test["positions"])
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["compensation", "command", "reading"])
        for state, s in (("off", 0.0), ("on", sign)):
            for _ in range(3):
                r = 12.3 + p + machine_error(p) + s * applied(p) + rng.normal(0, 0.0005, 2)
                for x, v in zip(p, r):
                    w.writerow([state, f"{x:.3f}", f"{v:.5f}"])


@pytest.mark.parametrize("case", list(CASES))
def test_the_check_tells_the_documented_sign_from_the_opposite(model, tmp_path, case):
    controller, which, kw, rule = CASES[case]
    run = make_tables(model, tmp_path, controller, profile=PROFILE, sign_test=which, uncertainty=False, **kw)
    tag = run.sign_test.table.upper()
    test = json.loads((tmp_path / f"SIGNTEST_{tag}.json").read_text())
    applied = lambda x: rule(tmp_path, x)                                     # noqa: E731
    # the prediction (from vecpin's own read-back) equals what the documented rule applies
    p = np.array(test["positions"])
    assert applied(p[1]) - applied(p[0]) == pytest.approx(test["predicted_shift"], abs=2e-6)
    assert abs(test["predicted_shift"]) > 0.01
    rng = np.random.default_rng(1)
    verdicts = {}
    for sign in (1.0, -1.0):
        path = tmp_path / f"check_{sign:+.0f}.csv"
        check_csv(path, test, applied, sign, rng)
        verdicts[sign] = check_sign(tmp_path / f"SIGNTEST_{tag}.json", path)
    assert verdicts[1.0].verdict == "right" and verdicts[1.0].ratio == pytest.approx(1.0, abs=0.05)
    assert verdicts[-1.0].verdict == "reversed" and verdicts[-1.0].ratio == pytest.approx(-1.0, abs=0.05)


def test_inactive_tables_and_unit_errors_are_not_called_right(model, tmp_path):
    make_tables(model, tmp_path, "linuxcnc", profile=PROFILE, sign_test="X", uncertainty=False)
    test = json.loads((tmp_path / "SIGNTEST_XX.json").read_text())
    applied = lambda x: linuxcnc_type0(tmp_path, "X", x)                     # noqa: E731
    rng = np.random.default_rng(2)
    for sign, words in ((0.0, "table active"), (10.0, "units")):
        path = tmp_path / "check.csv"
        check_csv(path, test, applied, sign, rng)
        v = check_sign(tmp_path / "SIGNTEST_XX.json", path)
        assert v.verdict == "unclear" and words in v.reason


def test_program_instructions_and_the_evaluate_command(model, machines, tmp_path, capsys):
    model_path = tmp_path / "m.json"
    model.save(model_path)
    out = tmp_path / "t"
    assert main(["tables", str(model_path), "--controller", "siemens-840d", "--profile", str(PROFILE),
                 "--sign-test", "X", "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "sign test xx" in printed
    test = json.loads((out / "SIGNTEST_XX.json").read_text())
    # the program as a SINUMERIK runs it (tests/gcode.py): machine coordinates (SUPA), from inch mode
    flow = machines["flow_xyzcb"]
    prog = run((out / "SIGNTEST_XX.MPF").read_text(), "siemens-840d", {"X": (flow.axis("X").lower_user,
                                                                            flow.axis("X").upper_user)})
    assert {mv.frame for mv in prog.moves} == {"machine"} and len(prog.stops) == 2
    at_stops = [prog.moves[max(i for k, i in prog.events[:j] if k == "move")] for j, e in enumerate(prog.events)
                if e[0] == "stop"]
    assert [mv.pos["X"] for mv in at_stops] == pytest.approx(test["positions"], abs=5e-4)
    assert all(mv.code == 1 and mv.before["X"] < mv.pos["X"] for mv in at_stops)
    assert "--sign-test SIGNTEST_XX.json" in (out / "SIGNTEST_XX.md").read_text()
    check = tmp_path / "check.csv"
    check_csv(check, test, lambda x: siemens_eec(out, "X1", x), -1.0, np.random.default_rng(3))
    assert main(["evaluate", str(model_path), str(check), "--sign-test", str(out / "SIGNTEST_XX.json")]) == 0
    assert "sign REVERSED" in capsys.readouterr().out
    bad = tmp_path / "bad.csv"
    bad.write_text("compensation,command,reading\noff,1.0,0.1\n")
    assert main(["evaluate", str(model_path), str(bad), "--sign-test", str(out / "SIGNTEST_XX.json")]) == 2
    err = capsys.readouterr().err
    assert "bad.csv" in err and "neither test position" in err
