"""The sign test tells a controller that applies the files as documented from one that
applies them with the opposite sign.

The simulated controllers (tests/controller_appliers.py) read the written files with their
own small parsers and apply the values by the vendor's documented rule, on a machine
with its own axis error; the check's readings then go through ``vecpin evaluate
--sign-test-file``. Nothing here uses vecpin's readers."""
import csv
import json
from pathlib import Path

import numpy as np
import pytest
from controller_appliers import beckhoff_ssfk, fanuc_pitch, linuxcnc_type0, siemens_cec, siemens_eec

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
    prof = PROFILE.with_name("flow_xyzcb_linuxcnc_profile.json") if controller == "linuxcnc" else PROFILE
    run = make_tables(model, tmp_path, controller, profile=prof, sign_test=which, uncertainty=False, **kw)
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
    make_tables(model, tmp_path, "linuxcnc", profile=PROFILE.with_name("flow_xyzcb_linuxcnc_profile.json"),
                sign_test="X", uncertainty=False)
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
    assert "--sign-test-file SIGNTEST_XX.json" in (out / "SIGNTEST_XX.md").read_text()
    check = tmp_path / "check.csv"
    check_csv(check, test, lambda x: siemens_eec(out, "X1", x), -1.0, np.random.default_rng(3))
    assert main(["evaluate", str(model_path), str(check), "--sign-test-file", str(out / "SIGNTEST_XX.json")]) == 0
    assert "sign REVERSED" in capsys.readouterr().out
    bad = tmp_path / "bad.csv"
    bad.write_text("compensation,command,reading\noff,1.0,0.1\n")
    assert main(["evaluate", str(model_path), str(bad), "--sign-test-file", str(out / "SIGNTEST_XX.json")]) == 2
    err = capsys.readouterr().err
    assert "bad.csv" in err and "neither test position" in err
