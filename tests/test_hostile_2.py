"""The hostile corpus, round two (issue 28): input a user or an attacker gives vecpin.

Every refusal is asserted like tests/test_hostile.py does it: exit status 2, one
``vecpin: error:`` line, no traceback, the words naming the input (file and row/column,
profile field, option) and never a staging file. Classes (issue 28): files written
outside ``--out`` (names are data, not paths), duplicate names, campaign semantics
(nests without a table, identical verify runs, target ids), tracebacks, messages naming
a staging file, silently accepted input, and the view and model files.

Built from one small simulated campaign (30 commands x 2 tools on the bundled
flow_xyzcb) and its AP order-1 model (module fixture); the test of every name against
every controller checks the folders on disk with ``os.walk``, not with vecpin.
"""
from __future__ import annotations

import copy
import hashlib
import json
import os
import re
from pathlib import Path
from types import SimpleNamespace

import pytest
from hostile_helpers import ok, refused, simulated_base

from vecpin.cli import main
from vecpin.errors import OutputError
from vecpin.export.registry import controller_names
from vecpin.fileio import OutputSet

pytestmark = pytest.mark.slow   # a long matrix: the edit loop (-m 'not slow') leaves it to CI

DATA = Path(__file__).parent / "data"
PROFILE = json.loads((DATA / "controllers" / "flow_xyzcb_profile.json").read_text())
FLOW_URDF = (Path(__file__).parent.parent / "robots" / "flow_xyzcb.urdf").read_text()
FIT = ["--model", "ap", "--order", "1", "--quiet"]
CONTROLLERS = ["siemens-840d", "siemens-828d", "fanuc-30i", "linuxcnc", "beckhoff", "heidenhain", "iso230", "generic"]


# ------------------------------------------------------------------ helpers
def all_files(folder: Path) -> set[str]:
    """Every file and folder under ``folder``, by os.walk (independent of vecpin)."""
    out = set()
    for root, dirs, files in os.walk(folder):
        out |= {os.path.relpath(os.path.join(root, n), folder) for n in dirs + files}
    return out


def profile_file(folder: Path, edit=None, name: str = "profile.json", text: str | None = None) -> Path:
    """The flow_xyzcb test profile, edited: ``edit(dict)`` changes it in place."""
    d = copy.deepcopy(PROFILE)
    if edit is not None:
        edit(d)
    p = folder / name
    p.write_text(text if text is not None else json.dumps(d))
    return p


def renamed_urdf(name: str) -> str:
    """flow_xyzcb with its X joint named ``name`` (XML-escaped)."""
    esc = name.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;").replace(">", "&gt;")
    text = FLOW_URDF.replace('<joint name="X" type="prismatic">', f'<joint name="{esc}" type="prismatic">')
    assert text != FLOW_URDF
    return text


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    """A simulated flow_xyzcb campaign (60 rows, 2 tools), its validation run and an AP
    order-1 model of it."""
    return simulated_base(tmp_path_factory.mktemp("hostile2"), FIT)


@pytest.fixture
def work(tmp_path):
    return tmp_path


# ============================================================ 1. names are data, not paths
PATHLIKE = ["../../../X", "/tmp/vecpin-hostile-abs/X", "sub/X", "..", "=1+1", "-X", "@X", "X.Y", "X\\..\\Y"]


@pytest.mark.parametrize("name", PATHLIKE)
def test_urdf_axis_joint_that_is_no_plain_name(base, work, capsys, name):
    urdf = work / "m.urdf"
    urdf.write_text(renamed_urdf(name))
    refused(["fit", urdf, base.csv, "--out", work / "m.json"] + FIT, capsys, str(urdf), "not a plain name",
            "rename the joint")
    assert all_files(work) == {"m.urdf"}


@pytest.mark.parametrize("link", ["=1+1", "@tool", "+tool", "-tool"])
def test_tool_link_copied_into_csv_cells_is_no_formula(base, work, capsys, link):
    urdf = work / "m.urdf"
    urdf.write_text(FLOW_URDF.replace('"spindle"', f'"{link}"'))
    refused(["plan", urdf, f"--tool-link={link}", "--points", "20", "--out", work / "p"], capsys, str(urdf),
            f"tool link '{link}'", "spreadsheet")
    assert all_files(work) == {"m.urdf"}


def _model_with_joint(base, folder: Path, name: str) -> Path:
    """The base model file with the embedded URDF's X joint renamed and its checksum
    recomputed (an attacker's edit that the checksum does not catch)."""
    d = json.loads(base.model.read_text())
    xml = d["machine"]["urdf"].replace('<joint name="X" type="prismatic">',
                                      f'<joint name="{name}" type="prismatic">')
    assert xml != d["machine"]["urdf"]
    d["machine"]["urdf"], d["machine"]["urdf_sha256"] = xml, hashlib.sha256(xml.encode()).hexdigest()
    p = folder / "model.json"
    p.write_text(json.dumps(d))
    return p


def _set(path: str, value):
    """An edit of the profile: ``path`` like 'axes.X.nc_name' set to ``value``."""
    def edit(d):
        keys = path.split(".")
        node = d
        for k in keys[:-1]:
            node = node.setdefault(k, {})
        node[keys[-1]] = value
    return edit


def _following(value):
    def edit(d):
        d["axes"]["X"]["following"] = {"nc_name": value, "reference_position": 0.0}
    return edit


def _axis_key(value):
    def edit(d):
        d["axes"][value] = d["axes"].pop("X")
    return edit


# field -> (profile edit of a value, extra argv of a value, words of the refusal)
NAME_FIELDS = {
    "urdf joint": (None, None, ["not a plain name", "rename the joint"]),
    "nc_name": (lambda v: _set("axes.X.nc_name", v), None, ["field 'axes.X.nc_name'", "not a plain name"]),
    "general_name": (lambda v: _set("axes.Y.general_name", v), None, ["field 'axes.Y.general_name'",
                                                                        "not a plain name"]),
    "program_name": (lambda v: _set("axes.Z.program_name", v), None, ["field 'axes.Z.program_name'",
                                                                        "not a plain name"]),
    "following nc_name": (_following, None, ["field 'axes.X.following.nc_name'", "not a plain name"]),
    "profile axis": (_axis_key, None, ["has no axis"]),
    "--axis-map": (None, lambda v: ["--axis-map", f"C={v}"], ["--axis-map C=", "not a plain name"]),
}


@pytest.mark.parametrize("controller", CONTROLLERS)
@pytest.mark.parametrize("field", sorted(NAME_FIELDS))
def test_no_name_writes_outside_out(base, work, capsys, controller, field):
    """Every name-bearing field with path-like values against every controller: refused,
    naming the field, and nothing is written anywhere (inside --out or above it)."""
    edit, extra, words = NAME_FIELDS[field]
    for k, value in enumerate(["../../../X", str(work / "abs" / "X"), "a/../../X", "=1+1", ".."]):
        sandbox = work / f"v{k}"
        out = sandbox / "a" / "b" / "out"
        out.parent.mkdir(parents=True)
        model = _model_with_joint(base, sandbox, value) if field == "urdf joint" else base.model
        argv = ["tables", model, "--controller", controller, "--out", out, "--quiet"]
        if edit is not None:
            argv += ["--profile", profile_file(sandbox, edit(value))]
        else:
            argv += ["--profile", profile_file(sandbox)]
        if extra is not None:
            argv += extra(value)
        before = all_files(work)
        refused(argv, capsys, *words)
        assert all_files(work) == before, f"{field}={value!r}: {sorted(all_files(work) - before)}"
        assert not (work / "abs").exists() and not out.exists()


@pytest.fixture(scope="module")
def unchecked(base, tmp_path_factory):
    """A model of flow_xyzcb whose X joint is named '../../../X', fitted with the name
    checks switched off: what the writers would do if a name got past the checks."""
    d = tmp_path_factory.mktemp("unchecked")
    with pytest.MonkeyPatch.context() as mp:
        _no_name_checks(mp)
        urdf = d / "m.urdf"
        urdf.write_text(renamed_urdf("../../../X"))
        lines = base.csv.read_text().split("\n")
        cells = lines[0].split(",")
        cells[cells.index("X")] = "../../../X"
        (d / "c.csv").write_text("\n".join([",".join(cells)] + lines[1:]))
        assert main(["fit", str(urdf), str(d / "c.csv"), "--out", str(d / "m.json")] + FIT) == 0
    return SimpleNamespace(dir=d, model=d / "m.json")


def _no_name_checks(mp) -> None:
    """Switch the plain-name checks of axes and profiles off (``mp``: a MonkeyPatch)."""
    import vecpin.export.profile as profile_mod
    import vecpin.kinematics.axes as axes_mod
    anything = re.compile(r".+", re.S)
    mp.setattr(axes_mod, "PLAIN_NAME", anything)
    mp.setattr(profile_mod, "PLAIN_NAME", anything)


@pytest.mark.parametrize("controller", CONTROLLERS)
def test_output_set_keeps_files_inside_out_by_construction(unchecked, work, capsys, monkeypatch, controller):
    """With the name checks switched off, a joint and an NC name '../../../X' reach the
    writers: the output set refuses the file name (or the format does not use it), and
    nothing is written outside --out, no staging folder is left."""
    _no_name_checks(monkeypatch)
    prof = copy.deepcopy(PROFILE)
    prof["axes"]["../../../X"] = prof["axes"].pop("X")
    prof["axes"]["../../../X"]["nc_name"] = "../../../X"
    prof["options"] = {"rotary_any_range": True}
    if controller == "linuxcnc":                                       # LinuxCNC joints count from 0
        for k, facts in enumerate(prof["axes"].values()):
            facts["number"] = k
    p = work / "profile.json"
    p.write_text(json.dumps(prof))
    out = work / "a" / "b" / "c" / "out"
    out.parent.mkdir(parents=True)
    fewer = ["--max-tables", "0"]                                      # pitch tables only
    rc = main(["tables", str(unchecked.model), "--controller", controller, "--profile", str(p), "--out", str(out),
               "--quiet"] + fewer)
    err = capsys.readouterr().err
    assert "Traceback" not in err and ".vecpin-staging" not in err
    if rc == 2:
        assert "would not stay in the output folder" in err or "does not read back" in err, err
        assert not out.exists() or all_files(out) == set()
    else:
        assert rc == 0, err
    outside = {f for f in all_files(work) if not f.startswith(os.path.join("a", "b", "c", "out"))}
    assert outside == {"profile.json", "a", os.path.join("a", "b"), os.path.join("a", "b", "c")}
    if out.exists():
        assert not any(".vecpin-staging" in f for f in all_files(out))
    if controller in ("heidenhain", "iso230", "linuxcnc", "beckhoff"):  # formats that name files by axis
        assert rc == 2


@pytest.mark.parametrize("name", ["../x.csv", "../../x.csv", "/tmp/vecpin-hostile-x.csv", "a/../../x.csv", "",
                                  ".", "sub/./x", "C:x.csv", "x\n.csv"])
def test_output_set_refuses_names_leaving_the_folder(work, name):
    out_dir = work / "a" / "out"
    with pytest.raises(OutputError, match="would not stay in the output folder"):
        with OutputSet(out_dir) as out:
            out.write_text("fine.csv", "1\n")
            out.write_text(name, "2\n")
    assert all_files(work) == {"a", os.path.join("a", "out")}  # nothing committed, staging removed
    assert not Path("/tmp/vecpin-hostile-x.csv").exists()


def test_output_set_keeps_subfolders(work):
    with OutputSet(work / "out") as out:
        out.write_text("figures/a.txt", "1\n")
    assert (work / "out" / "figures" / "a.txt").read_text() == "1\n"


# ============================================================ 2. the controller profile, field by field
def _deep(n):
    return '{"format": "vecpin-controller-profile", "version": 1, "comment": ' + "[" * n + "]" * n + "}"


PROFILE_REFUSALS = {  # name: (edit, controller, words)
    "nc_name with a newline": (_set("axes.X.nc_name", "X\n1"), "siemens-840d", ["axes.X.nc_name", "plain name"]),
    "nc_name empty": (_set("axes.X.nc_name", " "), "siemens-840d", ["axes.X.nc_name", "non-empty text"]),
    "nc_name a number": (_set("axes.X.nc_name", 5), "siemens-840d", ["axes.X.nc_name", "non-empty text"]),
    "nc_name 65 characters": (_set("axes.X.nc_name", "X" * 65), "heidenhain", ["axes.X.nc_name", "at most 64"]),
    "duplicate nc_name": (_set("axes.Y.nc_name", "X1"), "siemens-840d", ["both have nc_name 'X1'"]),
    "duplicate general_name": (_set("axes.Y.general_name", "AX1"), "siemens-840d",
                               ["axes.Y.general_name", "axes X and Y both have general_name 'AX1'"]),
    "duplicate number": (_set("axes.C.number", 2), "fanuc-30i", ["axes.C.number", "both have number 2"]),
    "following drive repeats a name": (_following("Y1"), "siemens-840d",
                                       ["X (following drive)", "both have nc_name 'Y1'"]),
    "negative Fanuc number": (_set("axes.X.number", -3), "fanuc-30i", ["axes.X.number", "0..999, not -3"]),
    "number 1.5": (_set("axes.X.number", 1.5), "fanuc-30i", ["axes.X.number", "a whole number, not 1.5"]),
    "number true": (_set("axes.X.number", True), "fanuc-30i", ["axes.X.number", "a whole number, not True"]),
    "reference_position NaN": (_set("axes.X.reference_position", float("nan")), "fanuc-30i",
                               ["axes.X.reference_position", "a finite number, not nan"]),
    "reference_position Infinity": (_set("axes.Y.reference_position", float("inf")), "siemens-840d",
                                    ["axes.Y.reference_position", "a finite number, not inf"]),
    "reference_position text": (_set("axes.X.reference_position", "0"), "fanuc-30i",
                                ["axes.X.reference_position", "a finite number, not '0'"]),
    "reference_position 99,999 mm": (_set("axes.X.reference_position", 99999.0), "fanuc-30i",
                                     ["axes.X.reference_position", "outside the travel of X", "6101"]),
    "reference_position 1e9": (_set("axes.Z.reference_position", 1e9), "fanuc-30i",
                               ["axes.Z.reference_position", "beyond any machine's travel"]),
    "following reference beyond travel": (lambda d: d["axes"]["X"].update(
        following={"nc_name": "X2", "reference_position": -500.0}), "siemens-840d",
        ["axes.X.following.reference_position", "outside the travel"]),
    "detection_unit NaN": (_set("axes.X.detection_unit", float("nan")), "fanuc-30i",
                           ["axes.X.detection_unit", "a finite number, not nan"]),
    "detection_unit 0": (_set("axes.X.detection_unit", 0), "fanuc-30i", ["axes.X.detection_unit", "> 0"]),
    "detection_unit negative": (_set("axes.C.detection_unit", -0.001), "fanuc-30i", ["axes.C.detection_unit", "> 0"]),
    "detection_unit in metres^-1": (_set("axes.C.detection_unit", 1000), "fanuc-30i",
                                    ["axes.C.detection_unit", "at most 1"]),
    "modulo as text": (_set("axes.C.modulo", "yes"), "heidenhain", ["axes.C.modulo", "true or false"]),
    "modulo on a linear axis": (_set("axes.X.modulo", True), "heidenhain", ["axes.X.modulo", "only rotary"]),
    "drive separation NaN": (lambda d: d["axes"]["X"].update(following={"nc_name": "X2"},
                                                             drive_separation_mm=[0.0, float("nan"), 0.0]),
                             "generic", ["axes.X.drive_separation_mm", "three finite numbers"]),
    "drive separation 1e9": (lambda d: d["axes"]["X"].update(following={"nc_name": "X2"},
                                                             drive_separation_mm=[0.0, 1e9, 0.0]),
                             "siemens-840d", ["axes.X.drive_separation_mm", "at most 1e6 mm"]),
    "drive separation without a following drive": (_set("axes.X.drive_separation_mm", [0, 4200, 0]),
                                                   "siemens-840d", ["axes.X.drive_separation_mm", "'following'"]),
    "following modulo": (lambda d: d["axes"]["X"].update(following={"modulo": True}), "siemens-840d",
                         ["axes.X.following.modulo", "unknown"]),
    "unknown axis field": (_set("axes.X.ncname", "X1"), "siemens-840d",
                           ["axes.X.ncname", "unknown (known: nc_name, general_name"]),
    "unknown top field": (_set("axis", {}), "generic", ["unknown field 'axis'", "known: $schema, axes, comment"]),
    "unknown option": (_set("options.rotary_anyrange", True), "heidenhain",
                       ["options.rotary_anyrange", "unknown option (known: comp_file_type, ini, rotary_any_range)"]),
    "option of the wrong type": (_set("options.rotary_any_range", "yes"), "heidenhain",
                                 ["options.rotary_any_range", "true or false"]),
    "unknown limit": (_set("limits.max_tables", 3), "siemens-840d", ["limits: 'max_tables'", "not a limit of"]),
    "limit NaN": (_set("limits.max_cross_points", float("nan")), "siemens-840d",
                  ["limits.max_cross_points", "finite number"]),
    "axis of another machine": (_set("axes.W", {"nc_name": "W1"}), "generic", ["axes.W", "has no axis 'W'"]),
    "machine name a number": (_set("machine", 5), "generic", ["field 'machine'", "non-empty text"]),
    "axes a list": (_set("axes", ["X"]), "generic", ["field 'axes'", "an object of axis name"]),
}


@pytest.mark.parametrize("case", sorted(PROFILE_REFUSALS))
def test_profile_field_refused_on_load(base, work, capsys, case):
    edit, controller, words = PROFILE_REFUSALS[case]
    p = profile_file(work, edit)
    out = work / "out"
    refused(["tables", base.model, "--controller", controller, "--profile", p, "--out", out, "--quiet"], capsys,
            str(p), *words)
    assert not out.exists()


@pytest.mark.parametrize("depth", [100_000, 1_000_000])
def test_deeply_nested_profile(base, work, capsys, depth):
    p = profile_file(work, text=_deep(depth))
    refused(["tables", base.model, "--profile", p, "--out", work / "out"], capsys, f"--profile {p}",
            "nested too deeply")


def test_profile_that_is_a_folder_or_binary(base, work, capsys):
    refused(["tables", base.model, "--profile", work, "--out", work / "out"], capsys, f"--profile {work}",
            "no such file")
    p = work / "p.json"
    p.write_bytes(b"\xff\xfe\x00garbage")
    refused(["tables", base.model, "--profile", p, "--out", work / "out"], capsys, f"--profile {p}",
            "not a JSON file")


def test_valid_profile_still_writes_and_names_are_plain(base, work, capsys):
    """The unedited profile is accepted by every controller that needs it (the checks
    refuse only what is wrong); tables.csv cells hold no spreadsheet formula."""
    p = profile_file(work, _set("options", {"rotary_any_range": True}))
    for controller in ("siemens-840d", "fanuc-30i", "heidenhain"):
        out = work / controller
        cap = ok(["tables", base.model, "--controller", controller, "--profile", p, "--out", out, "--quiet"], capsys)
        assert f"wrote {out}" in cap.out
        cells = [c for ln in (out / "tables.csv").read_text().splitlines() if not ln.startswith("#")
                 for c in ln.split(",")]
        assert cells and not any(c[:1] in "=+@" or (c[:1] == "-" and not re.fullmatch(r"-[0-9.]+", c))
                                 for c in cells)


# ============================================================ 3. campaign semantics
def _csv_with(base, work, name, columns: dict, rows=None) -> Path:
    """The base campaign with extra columns ({name: value per row or callable(k)})."""
    lines = base.csv.read_text().strip("\n").split("\n")
    head = lines[0] + "," + ",".join(columns)
    body = [ln + "," + ",".join(str(v(k) if callable(v) else v) for v in columns.values())
            for k, ln in enumerate(lines[1:] if rows is None else lines[1:rows + 1])]
    p = work / name
    p.write_text("\n".join([head] + body) + "\n")
    return p


def test_nest_rows_on_a_machine_without_a_table(base, work, capsys):
    p = _csv_with(base, work, "nests.csv", {"instrument": lambda k: "nest" if k < 5 else "tracker",
                                            "target": lambda k: "N1" if k < 5 else ""})
    refused(["fit", "flow_xyzcb", p, "--out", work / "m.json"] + FIT, capsys, f"{p}, row 2, column 'instrument'",
            "flow_xyzcb has no table", "'workpiece'")
    assert not (work / "m.json").exists()


def test_verify_with_the_same_file_twice(base, work, capsys):
    refused(["verify", base.val, base.val, "--machine", "flow_xyzcb"], capsys, "the same file is given",
            "AFTER is a second run")


def test_verify_with_a_copy_of_the_before_run(base, work, capsys):
    copy_ = work / "after.csv"
    copy_.write_bytes(base.val.read_bytes())
    refused(["verify", base.val, copy_, "--machine", "flow_xyzcb", "--model-file", base.model], capsys,
            "hold the same measurements", str(copy_))


@pytest.fixture(scope="module")
def targets(tmp_path_factory):
    d = tmp_path_factory.mktemp("targets")
    assert main(["simulate", "flow_xyzcb", "--out", str(d), "--points", "30", "--target", "0,0,100", "--target",
                 "150,0,60", "--seed", "1"]) == 0
    return d


TARGET_REFUSALS = {  # name: (file text, words)
    "lower-case ids": ("target,x,y,z\nt1,0,0,100\nt2,150,0,60\n", ["target ids t1, t2 are not measured",
                                                                   "its targets: T1, T2", "case-sensitive"]),
    "an id the campaign lacks": ("target,x,y,z\nT1,0,0,100\nT3,150,0,60\n", ["target ids T3 are not measured"]),
    "offsets in metres": ("target,x,y,z\nT1,0,0,0.1\nT2,0.15,0,0.06\n", ["column 'x'", "not metres"]),
    "offset 1e9 mm": ("target,x,y,z\nT1,0,0,1e9\nT2,150,0,60\n", ["row 2", "at most 10000 mm"]),
    "formula id": ("target,x,y,z\n=1+1,0,0,100\n", ["row 2", "column 'target'", "spreadsheet"]),
}


@pytest.mark.parametrize("case", sorted(TARGET_REFUSALS))
def test_targets_file_refused_naming_the_targets_file(targets, work, capsys, case):
    text, words = TARGET_REFUSALS[case]
    t = work / "t.csv"
    t.write_text(text)
    msg = refused(["fit", "flow_xyzcb", targets / "campaign.csv", "--targets", t, "--out", work / "m.json"] + FIT,
                  capsys, f"{t}", *words)
    assert msg.startswith(f"vecpin: error: {t}")  # the targets file is blamed, not the campaign


def test_matching_targets_file_is_used(targets, work, capsys):
    cap = ok(["fit", "flow_xyzcb", targets / "campaign.csv", "--targets", targets / "targets.csv", "--out",
              work / "m.json"] + FIT, capsys)
    assert "target T" not in cap.out and "wrote" in cap.out  # known offsets: nothing to find


def test_campaign_target_id_that_is_a_formula(base, work, capsys):
    p = _csv_with(base, work, "f.csv", {"target": lambda k: "@SUM(A1)" if k == 3 else "T1"})
    refused(["fit", "flow_xyzcb", p, "--out", work / "m.json"] + FIT, capsys, f"{p}, row 5, column 'target'",
            "spreadsheet")


# ============================================================ 4. tracebacks
@pytest.mark.parametrize("command", ["plan", "fit", "tables", "simulate"])
def test_output_on_a_path_nobody_can_write(base, work, capsys, command):
    out = Path("/proc/vecpin-hostile/out")
    argv = {"plan": ["plan", "flow_xyzcb", "--points", "20", "--out", out],
            "fit": ["fit", "flow_xyzcb", base.csv, "--out", "/proc/vecpin-hostile.json"] + FIT,
            "tables": ["tables", base.model, "--out", out],
            "simulate": ["simulate", "flow_xyzcb", "--points", "20", "--out", out]}[command]
    msg = refused(argv, capsys, "--out", "/proc")
    assert "cannot be written" in msg or "no permission" in msg


def test_fit_of_a_campaign_of_few_commands_repeated_many_times(base, work, capsys, monkeypatch):
    """The model choice subsamples a large campaign by command; a campaign whose commands
    each repeat more often than the subsample holds (issue 28: 1,000,000 rows, 'zero-size
    array' in command_folds) keeps a share of every command: reproduced with the
    subsample's size lowered to 100 rows and 30 commands repeated 120 times."""
    import vecpin.selection.choice as choice
    monkeypatch.setattr(choice, "MAX_SELECTION_ROWS", 100)
    lines = base.csv.read_text().strip("\n").split("\n")
    head = lines[0].split(",")
    t = head.index("time")
    rows = []
    for k in range(60):
        for ln in lines[1:]:
            c = ln.split(",")
            c[t] = f"{len(rows) + 1.0:.1f}"
            rows.append(",".join(c))
    p = work / "repeated.csv"
    p.write_text("\n".join([lines[0]] + rows) + "\n")
    cap = ok(["fit", "flow_xyzcb", p, "--out", work / "m.json", "--model", "ap", "--order", "1"], capsys)
    assert re.search(r"model choice: \d+ candidates .* \(100 rows judged", cap.out), cap.out
    assert (work / "m.json").is_file()


# ============================================================ 5. messages name the input, not a staging file
def test_simulate_tracker_a_million_km_away(work, capsys):
    refused(["simulate", "flow_xyzcb", "--points", "20", "--tracker=1e9,0,0", "--out", work / "s"], capsys,
            "--tracker 1e+09,0,0", "within 100 m")
    assert not (work / "s").exists()


def test_simulate_tracker_not_finite(work, capsys):
    refused(["simulate", "flow_xyzcb", "--points", "20", "--tracker=nan,0,0", "--out", work / "s"], capsys,
            "--tracker")


# ============================================================ 6. silently accepted before
@pytest.mark.parametrize("argv, words", [
    (["plan", "flow_xyzcb", "--points", "30", "--repeat", "5000", "50"], ["--repeat 5000 50", "at most --points (30)"]),
    (["simulate", "flow_xyzcb", "--points", "30", "--repeat", "5000", "50"],
     ["--repeat 5000 50", "at most --points (30)"]),
    (["plan", "flow_xyzcb", "--points", "30", "--tools", "200,200"], ["--tools 200,200", "same length"]),
    (["simulate", "flow_xyzcb", "--points", "30", "--tools", "200", "200"], ["--tools 200 200", "same length"]),
    (["simulate", "flow_xyzcb", "--points", "30", "--tools", "214.88", "312.86", "214.88"],
     ["--tools 214.88 312.86 214.88", "same length"]),
], ids=["plan repeat", "simulate repeat", "plan same holders", "simulate same tools", "simulate three tools"])
def test_options_accepted_silently_before(work, capsys, argv, words):
    refused(argv + ["--out", work / "o"], capsys, *words)
    assert not (work / "o").exists()


def test_repeat_within_points_is_still_written(work, capsys):
    cap = ok(["simulate", "flow_xyzcb", "--points", "30", "--repeat", "5", "3", "--out", work / "o"], capsys)
    rows = (work / "o" / "campaign.csv").read_text().strip().split("\n")[1:]
    assert len(rows) == 30 * 2 + 5 * 3 * 2 or len(rows) == 30 * 2 + 5 * 3, (len(rows), cap.out)


# ============================================================ 7. view and model files
@pytest.fixture(scope="module")
def stations(tmp_path_factory):
    d = tmp_path_factory.mktemp("stations")
    assert main(["simulate", "flow_xyzcb", "--out", str(d), "--points", "30", "--stations", "2", "--seed", "2"]) == 0
    assert main(["fit", "flow_xyzcb", str(d / "campaign.csv"), "--out", str(d / "m.json")] + FIT) == 0
    return d


@pytest.mark.parametrize("row, words", [(70, ["--row 70", "not a tracker row of station 0"]),
                                        (121, ["--row 121", "not a tracker row of station 0"]),
                                        (122, ["--row 122", "has rows 2 .. 121"])])
def test_view_row_past_the_drawn_rows(stations, work, capsys, row, words):
    refused(["view", stations / "m.json", stations / "campaign.csv", f"--row={row}", "--no-tables", "--html",
             work / "v.html"], capsys, *words)
    assert not (work / "v.html").exists()


def test_view_row_of_station_0_is_drawn(stations, work, capsys):
    cap = ok(["view", stations / "m.json", stations / "campaign.csv", "--row=5", "--no-tables", "--html",
              work / "v.html"], capsys)
    assert "row 5 posed" in (work / "v.html").read_text() and "wrote" in cap.out


def _model_edit(base, work, edit) -> Path:
    d = json.loads(base.model.read_text())
    edit(d)
    p = work / "edited.json"
    p.write_text(json.dumps(d))
    return p


MODEL_REFUSALS = {
    "noise null": (lambda d: d.update(noise=None), ["field 'noise'", "section is null"]),
    "noise missing": (lambda d: d.pop("noise"), ["field 'noise'", "section is missing"]),
    "fit a text": (lambda d: d.update(fit="ok"), ["field 'fit'", "not an object"]),
    "tracker a list": (lambda d: d.update(tracker=[]), ["field 'tracker'", "not an object"]),
    "parameters an object": (lambda d: d.update(parameters={}), ["field 'parameters'", "a list of parameters"]),
    "NaN parameter": (lambda d: d["parameters"][7].update(value=float("nan")),
                      ["field 'parameters'", "value nan is not a finite number"]),
    "null std": (lambda d: d["parameters"][8].update(std=None), ["field 'parameters'", "std None"]),
}


@pytest.mark.parametrize("case", sorted(MODEL_REFUSALS))
def test_model_file_refused_naming_the_field(base, work, capsys, case):
    edit, words = MODEL_REFUSALS[case]
    p = _model_edit(base, work, edit)
    msg = refused(["tables", p, "--out", work / "out"], capsys, str(p), *words)
    assert "TypeError" not in msg
    if case in ("NaN parameter", "null std"):
        k = 7 if case.startswith("NaN") else 8
        assert json.loads(base.model.read_text())["parameters"][k]["name"] in msg  # the parameter is named


def test_every_controller_is_tried():
    """The name test covers every built-in controller format."""
    assert sorted(CONTROLLERS) == sorted(controller_names())
