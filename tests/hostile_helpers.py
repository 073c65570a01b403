"""Shared by the hostile corpora (tests/test_hostile.py, tests/test_hostile_2.py): a
refusal is exit status 2, one ``vecpin: error:`` line, no traceback and no staging file
named; a success is exit status 0 without a traceback."""
from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

from vecpin.cli import main


def refused(argv, capsys, *fragments):
    """Run the CLI in-process; assert a refusal whose text contains every fragment;
    return the message."""
    rc = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert rc == 2, f"exit {rc}, stderr: {err}"
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.startswith("vecpin: error:")]
    assert len(lines) == 1, err
    msg = lines[0]
    assert ".vecpin-staging" not in msg, msg  # the user's input is named, never a staging copy
    for f in fragments:
        assert f in msg, f"'{f}' not in: {msg}"
    return msg


def ok(argv, capsys) -> SimpleNamespace:
    """Run the CLI in-process; assert success; return the captured output."""
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    assert "Traceback" not in cap.err
    return cap


def simulated_base(folder, fit_args) -> SimpleNamespace:
    """The corpora's starting point in ``folder``: a simulated flow_xyzcb campaign (30
    commands x 2 tools, seed 5), its validation run (10 commands) and a model fitted
    with ``fit_args``; returns (dir, csv, val, model)."""
    assert main(["simulate", "flow_xyzcb", "--out", str(folder / "sim"), "--seed", "5", "--points", "30",
                 "--validation-count", "10"]) == 0
    csv = folder / "sim" / "campaign.csv"
    model = folder / "model.json"
    assert main(["fit", "flow_xyzcb", str(csv), "--out", str(model)] + list(fit_args)) == 0
    return SimpleNamespace(dir=folder, csv=csv, val=folder / "sim" / "validation.csv", model=model)


def edited_model(base, folder: Path, edit) -> Path:
    """The base model file with ``edit(dict)`` applied (what a script or a hand would do)."""
    d = json.loads(base.model.read_text())
    edit(d)
    p = folder / "edited.json"
    p.write_text(json.dumps(d))
    return p
