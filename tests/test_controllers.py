"""Controller files: written, parsed back, same compensation; limits enforced."""
import math

import numpy as np
import pytest

from vecpin.compensation.functions import from_ap_model, pseudo_commands
from vecpin.export.controllers import (CONTROLLERS, check_limits, fanuc_offsets, read_fanuc, read_siemens, write_fanuc,
                                write_generic, write_siemens)
from vecpin.errors import VecpinError
from vecpin.models import make_model
from vecpin.measurement.noise import NoiseModel
from vecpin.simulation.simulate import Design, simulate
from vecpin.compensation.tables import CompensationTable, TableSet

SUBSET = ["xz", "yc", "xc", "yx", "zx", "bc"]


@pytest.fixture(scope="module")
def tables(machines):
    flow = machines["flow_xyzcb"]
    sim = simulate(flow, seed=0, design=Design(n_commands=200))
    model = make_model("ap", flow, 5).fit(sim.campaign, NoiseModel.default(flow, "spherical"))
    return from_ap_model(model).discretise(1024)


def test_siemens_round_trip(flow, tables, tmp_path):
    files = write_siemens(tables, flow, tmp_path, axis_map={"X": "X1", "C": "C1"})
    text = files[0].read_text()
    assert text.startswith("%_N_NC_CEC_INI") and text.rstrip().endswith("M17")
    for var in ("$AN_CEC[0,0]=", "$AN_CEC_INPUT_AXIS[0]=", "$AN_CEC_OUTPUT_AXIS[0]=X1", "$AN_CEC_STEP[0]=",
                "$AN_CEC_MIN[0]=", "$AN_CEC_MAX[0]=", "$AN_CEC_DIRECTION[0]=0", "$AN_CEC_MULT_BY_TABLE[0]=0",
                "$AN_CEC_IS_MODULO[0]=0"):
        assert var in text
    eec = files[1].read_text()
    assert eec.startswith("%_N_AX_EEC_INI") and "$AA_ENC_COMP[0,0,X1]=" in eec and "$AA_ENC_COMP_STEP[0,C1]=" in eec
    readme = files[2].read_text()
    assert "MD18342" in readme and "MD32710" in readme and "SD41300" in readme and "MD38000" in readme
    back = read_siemens(tmp_path, flow, axis_map={"X": "X1", "C": "C1"}, gauge_offset_change=tables.gauge_offset_change)
    assert sorted(back.names()) == sorted(tables.names())
    q = pseudo_commands(flow, 400, seed=2)
    np.testing.assert_allclose(back.increments(q), tables.increments(q), atol=2e-8)
    # EEC holds measuring-system errors: the negated increments
    first = float(eec.split("$AA_ENC_COMP[0,0,X1]=")[1].split()[0])
    assert first == pytest.approx(-tables.table("xx").values[0] * 1e3, abs=1e-6)


def test_fanuc_round_trip_within_resolution(flow, tables, tmp_path):
    sub = tables.subset(SUBSET)
    files = write_fanuc(sub, flow, tmp_path)
    pitch = files[0].read_text()
    for p in ("N3620", "N3621", "N3622", "N3623", "N3624", "N3625", "N10000P"):
        assert p in pitch
    back = read_fanuc(tmp_path, flow, offsets=fanuc_offsets(sub, flow), gauge_offset_change=sub.gauge_offset_change)
    assert sorted(back.names()) == sorted(sub.names())
    q = pseudo_commands(flow, 400, seed=3)
    diff = np.abs(flow.to_user(back.increments(q) - sub.increments(q))).max(axis=0)
    assert np.all(diff[:3] < 0.003)       # mm: 128-point grid and 1 µm units
    assert np.all(diff[3:] < 0.002)       # deg
    # rotary table over a turn: increments sum to zero
    c = [ln for ln in pitch.splitlines() if ln.startswith("N3621")][0]
    first_c = int(c.split("A4P")[1].split("A")[0])
    last_c = int([ln for ln in pitch.splitlines() if ln.startswith("N3622")][0].split("A4P")[1].split("A")[0])
    vals = [int(ln.split("P")[1]) for ln in pitch.splitlines() if ln.startswith("N1") and len(ln) > 6
            and first_c <= int(ln[1:].split("P")[0]) - 10000 <= last_c]
    assert sum(vals) == 0


def test_limits_give_clear_errors(flow, tables, tmp_path):
    with pytest.raises(VecpinError, match="allows 6 straightness tables"):
        write_fanuc(tables, flow, tmp_path)
    with pytest.raises(VecpinError, match="at most 2000"):
        check_limits(tables.subset(SUBSET).__class__(tables.axis_names, [CompensationTable("X", "Z", 0, 1e-3, np.zeros(3000))]),
                     CONTROLLERS["siemens-840d"])
    with pytest.raises(VecpinError, match="at most 62 cross tables"):
        CONTROLLERS["siemens-840d"].constraints(70)


def test_fanuc_refuses_a_non_periodic_rotary_table(flow, tmp_path):
    """C travels 544 deg: a table that differs one turn apart cannot be a Fanuc rotary table."""
    q = np.linspace(flow.axis("C").lower, flow.axis("C").upper, 1024)
    t = CompensationTable("C", "C", q[0], q[1] - q[0], 1e-4 * (q - q[0]))
    with pytest.raises(VecpinError, match="repeats every turn"):
        write_fanuc(TableSet(flow.axis_names, [t]), flow, tmp_path)


def test_generic_round_trip(flow, tables, tmp_path):
    write_generic(tables, flow, tmp_path)
    back = TableSet.load_json(tmp_path / "tables.json", flow)
    q = pseudo_commands(flow, 200, seed=5)
    np.testing.assert_allclose(back.increments(q), tables.increments(q), atol=1e-12)
    assert back.gauge_offset_change == pytest.approx(tables.gauge_offset_change)
    rows = (tmp_path / "tables.csv").read_text().splitlines()
    assert rows[0].startswith("table,input_axis") and len(rows) == 1 + 25 * 1024 + 1
    assert math.isclose(float(rows[-1].split(",")[1]), tables.gauge_offset_change * 1e3, abs_tol=1e-6)
