"""The hostile corpus, round three (issue 42): plausible numbers that are wrong, names that
collide, output folders.

Refusals are asserted as in tests/test_hostile.py (exit status 2, one ``vecpin: error:``
line naming the input, no traceback, nothing written). Classes: lengths typed in metres
where mm are meant (against the model's tools and the axes' travel), model files whose
numbers disagree with what they record (a parameter x1000, T_offset x1000), names the
controller reads without case, and output folders (a symbolic link leaving ``--out``, the
manifest of one generation checked with hashlib against the files on disk, an
interrupted run that the manifest tells apart).

Built from the corpora's small simulated campaign and its AP order-1 model (one module
fixture, :func:`hostile_helpers.simulated_base`).
"""
from __future__ import annotations

import copy
import hashlib
import json
import os
from pathlib import Path

import pytest
from hostile_helpers import edited_model, ok, refused, simulated_base

from vecpin.cli import main
from vecpin.errors import OutputError
from vecpin.fileio import OutputSet

DATA = Path(__file__).parent / "data"
PROFILE = json.loads((DATA / "controllers" / "flow_xyzcb_profile.json").read_text())
FIT = ["--model", "ap", "--order", "1", "--quiet"]


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    """A simulated flow_xyzcb campaign (60 rows, tools 214.88 and 312.86 mm) and an AP
    order-1 model of it."""
    return simulated_base(tmp_path_factory.mktemp("hostile3"), FIT)


def to_priors(name: str, priors: float):
    """The parameter set to ``priors`` times its prior scale: within what the prior check allows, but a
    value no fit gave, so only the recomputed figure can tell."""
    def edit(d):
        for p in d["parameters"]:
            if p["name"] == name:
                p["value"] = priors * p["prior"] * (1.0 if p["value"] >= 0 else -1.0)
    return edit


def times(name: str, factor: float, drop=()):
    def edit(d):
        for p in d["parameters"]:
            if p["name"] == name:
                p["value"] *= factor
        for k in drop:
            d.pop(k, None)
    return edit


def manifest_matches(folder: Path) -> tuple[dict, set[str], set[str]]:
    """(manifest, files whose SHA-256 and size on disk match it, other files), by hashlib."""
    m = json.loads((folder / "vecpin-manifest.json").read_text())
    listed = {f["name"]: f for f in m["files"]}
    match, other = set(), set()
    for p in folder.rglob("*"):
        if not p.is_file() or p.name == "vecpin-manifest.json":
            continue
        n = p.relative_to(folder).as_posix()
        f = listed.get(n)
        same = f is not None and f["bytes"] == p.stat().st_size and f["sha256"] == hashlib.sha256(
            p.read_bytes()).hexdigest()
        (match if same else other).add(n)
    return m, match, other


# ============================================================ 1. plausible lengths that are metres
@pytest.mark.parametrize("argv, words", [
    (["--tools", "0.21488", "0.31286"], ["--tools 0.21488", "1/1000 of the model's tools", "metres?", "214.88 mm"]),
    (["--zone", "X=0.3:5.4"], ["--zone X=0.3:5.4", "1/1000 of X's travel", "metres?", "X=300:5400"]),
])
def test_tables_lengths_in_metres(base, tmp_path, capsys, argv, words):
    refused(["tables", base.model, "--out", tmp_path / "t"] + argv, capsys, *words)
    assert not (tmp_path / "t").exists()


@pytest.mark.parametrize("argv, words", [
    (["--safe-z", "0.5"], ["--safe-z 0.5", "not a safe height", "metres?"]),
    (["--tools", "0.21488", "0.31286"], ["--tools", "shorter than 1 mm", "metres?", "214.88"]),
])
def test_plan_lengths_in_metres(tmp_path, capsys, argv, words):
    refused(["plan", "flow_xyzcb", "--points", "80", "--out", tmp_path / "p"] + argv, capsys, *words)
    assert not (tmp_path / "p").exists()


# ============================================================ 1. model files against what they record
@pytest.mark.parametrize("edit, words", [
    (times("X->Z.1", 1000), ["field 'parameters'", "X->Z.1", "times its prior scale", "x1000"]),
    (times("T_offset", 1000), ["field 'parameters'", "T_offset", "times its prior scale"]),
    (to_priors("C->C.1", 15.0), ["field 'check'", "where the file records", "changed after the fit"]),
    (lambda d: [p.update(value=15.0) for p in d["parameters"] if p["name"] == "X->Z.1"] and d.pop("check"),
     ["field 'selection.uncompensated_mm'", "more than 10 times", "the campaign measured"]),
])
def test_model_file_against_what_it_records(base, tmp_path, capsys, edit, words):
    model = edited_model(base, tmp_path, edit)
    refused(["tables", model, "--controller", "siemens-840d", "--profile", DATA / "controllers" /
             "flow_xyzcb_profile.json", "--out", tmp_path / "t"], capsys, str(model), *words)
    assert not (tmp_path / "t").exists()


def test_model_file_as_written_reads(base, capsys):
    """The check figure a fit records is the one the file's parameters give back."""
    d = json.loads(base.model.read_text())
    assert d["check"]["commands"] > 0 and d["check"]["mean_mm"] > 0
    ok(["evaluate", base.model, base.val], capsys)


# ============================================================ 2. names unique as the controller reads them
@pytest.mark.parametrize("controller", ["heidenhain", "fanuc-30i", "siemens-840d", "linuxcnc"])
def test_nc_names_differing_only_by_case(base, tmp_path, capsys, controller):
    d = copy.deepcopy(PROFILE)
    d["axes"]["X"]["nc_name"], d["axes"]["Y"]["nc_name"] = "X", "x"
    prof = tmp_path / "profile.json"
    prof.write_text(json.dumps(d))
    refused(["tables", base.model, "--controller", controller, "--profile", prof, "--out", tmp_path / "t"], capsys,
            str(prof), "'axes.X.nc_name' and 'axes.Y.nc_name'", "differ only by case")
    assert not (tmp_path / "t").exists()


def test_axis_map_and_program_names_differing_only_by_case(base, tmp_path, capsys):
    prof = DATA / "controllers" / "flow_xyzcb_profile.json"
    refused(["tables", base.model, "--controller", "heidenhain", "--profile", prof, "--axis-map", "X=A",
             "--axis-map", "Y=a", "--out", tmp_path / "t"], capsys, "nc_name", "differ only by case")
    d = copy.deepcopy(PROFILE)
    d["axes"]["C"]["program_name"], d["axes"]["B"]["program_name"] = "C", "c"
    p = tmp_path / "profile.json"
    p.write_text(json.dumps(d))
    refused(["tables", base.model, "--controller", "siemens-840d", "--profile", p, "--out", tmp_path / "t"], capsys,
            "'axes.C.program_name' and 'axes.B.program_name'", "differ only by case")
    assert not (tmp_path / "t").exists()


def test_output_set_refuses_file_names_differing_only_by_case(tmp_path):
    with pytest.raises(OutputError, match="differ only by case"):
        with OutputSet(tmp_path / "o") as out:
            out.write_text("X.COM", "x\n")
            out.write_text("x.com", "y\n")
    assert sorted(os.listdir(tmp_path / "o")) == []


# ============================================================ 3. output folders
def test_manifest_lists_the_generation(base):
    """simulate's folder (the fixture's): the manifest, checked by hashlib, holds every file."""
    m, match, other = manifest_matches(base.csv.parent)
    assert m["complete"] is True and m["command"][:2] == ["vecpin", "simulate"] and len(m["generation"]) == 32
    assert other == set() and match == {f["name"] for f in m["files"]} and "campaign.csv" in match


def test_interrupted_run_is_told_apart_by_the_manifest(base, tmp_path, capsys, monkeypatch):
    out = tmp_path / "sim"
    argv = ["simulate", "flow_xyzcb", "--out", out, "--points", "6", "--validation-count", "5", "--seed"]
    ok(argv + ["1"], capsys)
    first, _, _ = manifest_matches(out)
    real, count = os.replace, {"n": 0}

    def replace(src, dst):   # Ctrl-C after the first file of the second run is in place
        if Path(dst).parent == out and Path(dst).name != "vecpin-manifest.json" and not str(src).endswith(".tmp"):
            count["n"] += 1
            if count["n"] > 1:
                raise KeyboardInterrupt
        return real(src, dst)
    monkeypatch.setattr(os, "replace", replace)
    assert main([str(a) for a in argv + ["2"]]) == 130
    monkeypatch.undo()
    capsys.readouterr()
    m, new, old = manifest_matches(out)
    assert m["complete"] is False and m["previous"] == first["generation"]
    assert len(new) == 1 and len(old) >= 2   # the one file in place is the new generation's; the rest are not


def test_symbolic_link_inside_out_leading_outside(tmp_path):
    outside, out = tmp_path / "outside", tmp_path / "out"
    outside.mkdir()
    out.mkdir()
    (out / "figures").symlink_to(outside)
    with pytest.raises(OutputError, match="figures is a symbolic link to .*outside the output folder"):
        with OutputSet(out) as s:
            s.write_text("figures/a.png", "png")
    assert list(outside.iterdir()) == [] and sorted(p.name for p in out.iterdir()) == ["figures"]


@pytest.mark.parametrize("make", ["file", "dangling link"])
def test_out_that_is_no_folder(base, tmp_path, capsys, make):
    out = tmp_path / "o"
    if make == "file":
        out.write_text("mine")
    else:
        out.symlink_to(tmp_path / "nowhere")
    refused(["simulate", "flow_xyzcb", "--out", out, "--points", "6"], capsys, "--out", str(out))
    assert make != "file" or out.read_text() == "mine"


def test_profile_reference_position_in_metres_is_warned_first(base, tmp_path, capsys):
    """A reference point 0.3 mm is possible, so a warning (first line), not a refusal; the
    run then stops at the tools typed in metres, before any table is computed."""
    d = copy.deepcopy(PROFILE)
    d["axes"]["X"]["reference_position"] = 0.3
    prof = tmp_path / "profile.json"
    prof.write_text(json.dumps(d))
    refused(["tables", base.model, "--controller", "siemens-840d", "--profile", prof, "--tools", "0.21488",
             "--out", tmp_path / "t"], capsys, "--tools 0.21488")
    rc = main([str(a) for a in ["tables", base.model, "--controller", "siemens-840d", "--profile", prof, "--tools",
                                "0.21488", "--out", tmp_path / "t"]])
    first = capsys.readouterr().err.splitlines()[0]
    assert rc == 2 and first.startswith("vecpin: warning:") and "'axes.X.reference_position'" in first
    assert "metres?" in first and "300 mm" in first


@pytest.mark.parametrize("argv, words", [
    (["plan", "flow_xyzcb", "--points", "80", "--tracker", "2,3,0.5"],
     ["--tracker 2,3,0.5", "metres?", "2000,3000,500"]),
    (["simulate", "flow_xyzcb", "--points", "6", "--tracker", "2,3,0.5"], ["--tracker 2,3,0.5", "metres?"]),
    (["simulate", "flow_xyzcb", "--points", "6", "--target", "0.05,0,0.02"], ["--target 0.05,0,0.02", "metres?",
                                                                              "50,0,20"]),
])
def test_positions_and_offsets_in_metres(tmp_path, capsys, argv, words):
    refused(argv + ["--out", tmp_path / "o"], capsys, *words)
    assert not (tmp_path / "o").exists()


# ============================================================ 4. round two's leftovers
NESTS = {
    "one nest": (["--nest", "1=100,0,20"], ["one nest", "not on one line"]),
    "in a row": (["--nest", "1=100,0,20", "--nest", "2=120,0,20", "--nest", "3=140,0,20"], ["on one line"]),
    "on the C axis": (["--nest", "1=0,0,20", "--nest", "2=0,0,50"], ["on the axis of C"]),
    "off the table": (["--nest", "1=1000,0,20", "--nest", "2=0,100,20", "--nest", "3=-100,0,20"],
                      ["beyond its edge", "radius 160 mm"]),
    "in metres": (["--nest", "1=0.1,0,0.02", "--nest", "2=0,0.1,0.02", "--nest", "3=-0.1,0,0.02"], ["metres?"]),
}


@pytest.mark.parametrize("case", sorted(NESTS))
def test_plan_nests_that_cannot_register_the_table(tmp_path, capsys, case):
    argv, words = NESTS[case]
    refused(["plan", "trunnion_xyzac", "--points", "60", "--order", "1", "--out", tmp_path / "p"] + argv, capsys,
            "--nest", *words)
    assert not (tmp_path / "p").exists()


@pytest.mark.parametrize("argv, words", [
    (["--mean-error", "100", "--long-term", "0.01"], ["--mean-error 100", "micrometres", "Give it in mm"]),
    (["--mean-error", "0.5", "--long-term", "0.01", "--short-term", "0.03"], ["--short-term 0.03", "--long-term 0.01",
                                                                              "swapped?"]),
])
def test_assess_numbers_that_cannot_be(capsys, argv, words):
    refused(["assess"] + argv, capsys, *words)


def test_campaign_whose_clock_restarted(base, tmp_path, capsys):
    lines = base.csv.read_text().splitlines()
    col = lines[0].split(",").index("time")
    t0 = float(lines[1].split(",")[col])
    out = [lines[0]]
    for k, line in enumerate(lines[1:], start=1):
        cells = line.split(",")
        if k > 30:   # a second session counted from 0 again
            cells[col] = f"{float(cells[col]) - float(lines[31].split(',')[col]) + t0:.3f}"
        out.append(",".join(cells))
    csv = tmp_path / "restarted.csv"
    csv.write_text("\n".join(out) + "\n")
    refused(["fit", "flow_xyzcb", csv, "--out", tmp_path / "m.json"] + FIT, capsys, str(csv), "column 'time'",
            "the clock restarted")
    assert not (tmp_path / "m.json").exists()
