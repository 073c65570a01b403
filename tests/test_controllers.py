"""Controller files on a real machine's tables: written, parsed back, same compensation;
limits enforced with clear errors; every --controller name resolves to a format."""
import math

import numpy as np
import pytest

from vecpin.compensation.functions import from_ap_model, pseudo_commands
from vecpin.compensation.limits import NO_LIMITS
from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.errors import ControllerLimitError, InputError, VecpinError
from vecpin.export import fanuc, fanuc_read, generic, siemens
from vecpin.export.common import ExportJob
from vecpin.export.profile import ControllerProfile
from vecpin.export.registry import FORMATS, get_format
from vecpin.fileio import OutputSet
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.simulate import Design, simulate

SUBSET = ["xz", "yc", "xc", "yx", "zx", "bc"]


@pytest.fixture(scope="module")
def tables(machines):
    flow = machines["flow_xyzcb"]
    sim = simulate(flow, seed=0, design=Design(n_commands=200))
    model = make_model("ap", flow, 5).fit(sim.campaign, NoiseModel.default(flow, "spherical"))
    return from_ap_model(model).discretise(1024)


def flow_profile(flow, modulo=()) -> ControllerProfile:
    axes = {a.name: {"nc_name": a.name + "1", "general_name": f"AX{k + 1}", "number": k + 1,
                     "reference_position": 0.0, "detection_unit": 0.001} for k, a in enumerate(flow.axes)}
    for a in modulo:
        axes[a]["modulo"] = True
    return ControllerProfile.from_dict({"format": "vecpin-controller-profile", "version": 1, "axes": axes})


def write(fmt, tables, machine, prof, out_dir):
    with OutputSet(out_dir) as out:
        job = ExportJob(tables, machine, prof, fmt.limits_for(prof), out)
        names = fmt.write(job)
    return [out_dir / n for n in names], job.notes


def test_registry_has_every_controller_of_the_issue():
    from vecpin.export.names import CONTROLLERS
    assert set(FORMATS) == {"siemens-840d", "siemens-828d", "fanuc-30i", "linuxcnc", "beckhoff", "heidenhain",
                            "iso230", "generic"} == set(CONTROLLERS)          # the CLI's choices are the formats'
    assert list(CONTROLLERS) == list(FORMATS)[:len(CONTROLLERS)]
    for f in FORMATS.values():
        assert f.files and f.sign and f.source and f.to_check
    with pytest.raises(InputError, match="unknown controller"):
        get_format("haas")


def test_siemens_round_trip(flow, tables, tmp_path):
    prof = flow_profile(flow)
    files, notes = write(siemens.FORMAT_840D, tables, flow, prof, tmp_path)
    text = files[0].read_text()
    assert text.startswith("%_N_NC_CEC_INI\nCHANDATA(1)\n") and text.rstrip().endswith("M17")
    for var in ("$AN_CEC[0,0]=", "$AN_CEC_INPUT_AXIS[0]=(AX", "$AN_CEC_OUTPUT_AXIS[0]=(AX1)", "$AN_CEC_STEP[0]=",
                "$AN_CEC_MIN[0]=", "$AN_CEC_MAX[0]=", "$AN_CEC_DIRECTION[0]=0", "$AN_CEC_MULT_BY_TABLE[0]=0",
                "$AN_CEC_IS_MODULO[0]=0"):
        assert var in text
    eec = files[1].read_text()
    assert eec.startswith("%_N_AX_EEC_INI\nCHANDATA(1)") and "$AA_ENC_COMP[0,0,X1]=" in eec
    assert "$AA_ENC_COMP_STEP[0,C1]=" in eec
    readme = files[3].read_text()
    assert "MD18342" in readme and "MD32710" in readme and "SD41300" in readme and "MD38000" in readme
    back = siemens.read(tmp_path, flow, prof)
    assert sorted(back.names()) == sorted(tables.names())
    # the EEC tables are zero at the reference point, MD_REFP.INI's reference point values carry the rest
    back.gauge_offset_change = tables.gauge_offset_change
    q = pseudo_commands(flow, 400, seed=2)
    np.testing.assert_allclose(back.increments(q), tables.increments(q), atol=2e-8)
    # EEC holds measuring-system errors: minus the correction, zero at the reference point
    # (the old writer wrote minus the absolute correction; the manual asks for zero at the reference)
    first = float(eec.split("$AA_ENC_COMP[0,0,X1]=")[1].split()[0])
    xx = tables.table("xx")
    assert first == pytest.approx(-(xx.values[0] - xx(0.0)) * 1e3, abs=1e-6)
    # CEC holds the error of the compensation axis: minus the correction (K3 sag section); the old
    # writer wrote the correction itself, the opposite sign
    cec0 = float(text.split("$AN_CEC[0,0]=")[1].split()[0])
    assert cec0 == pytest.approx(-tables.table("xy").values[0] * 1e3, abs=1e-6)
    assert any("reference point" in n for n in notes)


def test_fanuc_round_trip_within_resolution(flow, tables, tmp_path):
    sub = tables.subset(SUBSET)
    prof = flow_profile(flow)
    files, notes = write(fanuc.FORMAT, sub, flow, prof, tmp_path)
    para = files[0].read_text()
    for p in ("N03620Q1A1P", "N03621Q1", "N03622Q1", "N03623Q1", "N03624Q1", "N03625Q1", "N01240Q1A1P"):
        assert p in para
    assert "N10000Q0P" in files[1].read_text()
    back = fanuc_read.read(tmp_path, flow, prof)
    assert sorted(back.names()) == sorted(sub.names())
    # the pitch tables are zero at the reference position; parameter 1240 (reference position) carries the rest
    const = {g.axis: g.offset for g in fanuc.grids(sub, flow, prof)}
    for g in fanuc.grids(sub, flow, prof):
        assert f"A{g.number}P{g.reference_position - const[g.axis]:.6f}".rstrip("0") in para
    q = pseudo_commands(flow, 400, seed=3)
    # straightness values stand at the moving axis' own pitch points: below its first point (the lowest
    # section of the grid, whose start is the point of no axis) the control holds the first value
    first = {g.axis: g.position(g.first) for g in fanuc.grids(sub, flow, prof)}
    inside = np.all([q[:, flow.axis(a).index] >= flow.axis(a).to_si(x) for a, x in first.items()], axis=0)
    q = q[inside]
    diff = np.abs(flow.to_user(back.increments(q) - sub.increments(q))).max(axis=0)
    assert np.all(diff[:3] < 0.003)       # mm: 128-point grid and 1 um units
    assert np.all(diff[3:] < 0.002)       # deg


def test_fanuc_rotary_turn_sums_to_zero(flow, tmp_path):
    c = np.linspace(0, 2 * math.pi, 1024)
    t = CompensationTable("C", "C", 0.0, c[1], np.radians(0.02 * np.sin(c) + 0.01 * np.cos(2 * c)), modulo=True)
    prof = flow_profile(flow, modulo=["C"])
    write(fanuc.FORMAT, TableSet(flow.axis_names, [t]), flow, prof, tmp_path)
    g = fanuc_read.read_grids(tmp_path, flow, prof)[0]
    assert g.rotary_type and g.values[1:].sum() == 0 and g.values[0] == g.values[-1]


def test_limits_give_clear_errors(flow, tables, tmp_path):
    with pytest.raises(ControllerLimitError, match="allows 6 cross tables"):
        write(fanuc.FORMAT, tables, flow, flow_profile(flow), tmp_path)
    one = TableSet(tables.axis_names, [CompensationTable("X", "Z", 0, 1e-3, np.zeros(300))])
    with pytest.raises(ControllerLimitError, match="at most 200"):
        siemens.LIMITS_828D.check_tables(one)
    with pytest.raises(ControllerLimitError, match="at most 64 cross tables"):
        siemens.LIMITS_840D.constraints(70)
    with pytest.raises(ControllerLimitError, match="100000 points"):
        NO_LIMITS.points(10_000_000)


def test_fanuc_refuses_a_table_that_is_not_modulo_on_a_modulo_axis(flow, tmp_path):
    """C travels 544 deg; declared modulo, its table must cover one turn and repeat."""
    q = np.linspace(flow.axis("C").lower, flow.axis("C").upper, 1024)
    t = CompensationTable("C", "C", q[0], q[1] - q[0], 1e-4 * (q - q[0]))
    prof = flow_profile(flow, modulo=["C"])
    with pytest.raises(VecpinError, match="`modulo_axes` C"):
        write(fanuc.FORMAT, TableSet(flow.axis_names, [t]), flow, prof, tmp_path)


def test_generic_round_trip(flow, tables, tmp_path):
    write(generic.FORMAT, tables, flow, ControllerProfile(), tmp_path)
    back = TableSet.load_json(tmp_path / "tables.json", flow)
    q = pseudo_commands(flow, 200, seed=5)
    np.testing.assert_allclose(back.increments(q), tables.increments(q), atol=1e-12)
    assert back.gauge_offset_change == pytest.approx(tables.gauge_offset_change)
    import csv
    with open(tmp_path / "tables.csv", newline="") as fh:              # a plain CSV reader: every row is data
        rows = list(csv.DictReader(fh))
    assert len(rows) == 25 * 1024 and all(r["table"] and float(r["value"]) == float(r["value"]) for r in rows)


def test_every_reader_fails_with_file_and_line_on_damaged_files(tmp_path):
    """Deleted, cut, duplicated and garbled lines in each documented fixture: the reader
    either reads the file or raises ControllerFileError naming it (never a KeyError)."""
    import random

    from export_helpers import DATA, profile, tiny_machine

    from vecpin.errors import ControllerFileError
    from vecpin.export import beckhoff, heidenhain, iso230, linuxcnc
    m = tiny_machine()
    named = profile(X={"nc_name": "X"}, Y={"nc_name": "Y"}, Z={"nc_name": "Z"}, C={"nc_name": "C"})
    cases = [("siemens", {"AX_EEC.INI": "AX_EEC.INI", "NC_CEC.INI": "NC_CEC.INI"}, lambda d: siemens.read(d, m, profile())),
             ("fanuc", {"CNC-PARA.TXT": "CNC-PARA.TXT", "PITCH.TXT": "PITCH.TXT"}, lambda d: fanuc_read.read(d, m, profile())),
             ("linuxcnc", {"comp_X.txt": "x_comp_type0.txt"}, lambda d: linuxcnc.read(d, m, profile())),
             ("beckhoff", {"achskw_X.lis": "achskw1.lis", "achskw_Y.lis": "achskw2.lis"},
              lambda d: beckhoff.read(d, m, named)),
             ("heidenhain", {"X.COM": "X.COM", "CONFIG.CMA": "CONFIG.CMA"}, lambda d: heidenhain.read(d, m, named)),
             ("iso230", {"ISO230_X.csv": "ISO230_X.csv"}, lambda d: iso230.read_components(d, m))]
    rnd = random.Random(0)
    failures = 0
    for fmt, files, reader in cases:
        original = {f: (DATA / fmt / src).read_text() for f, src in files.items()}
        for trial in range(60):
            d = tmp_path / f"{fmt}{trial}"
            d.mkdir()
            for f, text in original.items():
                (d / f).write_text(text)
            f = rnd.choice(list(files))
            lines = original[f].splitlines()
            k = rnd.randrange(len(lines))
            op = trial % 4
            if op == 0:
                del lines[k]
            elif op == 1:
                lines = lines[:k]
            elif op == 2:
                lines.insert(k, lines[rnd.randrange(len(lines))])
            elif lines[k]:
                i = rnd.randrange(len(lines[k]))
                lines[k] = lines[k][:i] + rnd.choice("x-.,;()[]% 9eE") + lines[k][i + 1:]
            (d / f).write_text("\n".join(lines) + "\n")
            try:
                reader(d)
            except ControllerFileError as exc:
                assert str(exc).startswith(str(d)), exc
                failures += 1
    assert failures > 100       # most damage is noticed
