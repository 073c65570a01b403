"""Model files: every number a user reads in mm or degrees, the round trip, and one
station format (``correction_mm_deg``: mm, deg).

Independent truth: the fitted setup in SI converted by hand (1 m = 1000 mm,
1 rad = 180/pi deg), not by vecpin's unit helpers."""
import json
import math

import numpy as np
import pytest

from vecpin.errors import ModelFileError
from vecpin.measurement.noise import NoiseModel
from vecpin.models import ErrorModel, make_model
from vecpin.simulation.simulate import Design, simulate


@pytest.fixture(scope="module")
def fitted(machines):
    """A trunnion machine (workpiece branch) measured from two tracker stations, with
    three table nests, an unknown tool target and a ball bar: every kind of setup unknown."""
    m = machines["trunnion_xyzac"]
    sim = simulate(m, seed=4, design=Design(n_commands=40, n_validation=3, stations=2, ballbar_points=20,
                                            targets_mm=((12.0, -5.0, 3.0),)))
    model = make_model("ap", m, 1).fit(sim.campaign, NoiseModel.default(m, "spherical"))
    assert model.setup_.stations and model.setup_.pivots and model.setup_.nests and model.setup_.targets
    return sim, model


def test_every_setup_number_in_the_file_is_mm_or_deg(fitted, tmp_path):
    sim, model = fitted
    model.save(tmp_path / "m.json")
    d = json.loads((tmp_path / "m.json").read_text())
    tr, s = d["tracker"], model.setup_
    np.testing.assert_allclose(tr["translation_mm"], s.t * 1000.0, rtol=1e-12)
    for sid, (R, t, e) in s.stations.items():
        st = tr["stations"][str(sid)]
        assert set(st) == {"rotation", "translation_mm", "correction_mm_deg"}     # no field in SI any more
        np.testing.assert_allclose(st["translation_mm"], t * 1000.0, rtol=1e-12)
        np.testing.assert_allclose(st["correction_mm_deg"][:3], e[:3] * 1000.0, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(st["correction_mm_deg"][3:], e[3:] * 180.0 / math.pi, rtol=1e-12, atol=1e-15)
        assert max(abs(v) for v in st["correction_mm_deg"][:3]) > 1e-4       # a real correction, not zeros
    for p, c in s.pivots.items():
        np.testing.assert_allclose(tr["pivots_mm"][str(p)], c * 1000.0, rtol=1e-12)
    for kind, store in (("nests", s.nests), ("targets", s.targets)):
        for k, c in store.items():
            np.testing.assert_allclose(tr[f"{kind}_mm"][str(k)], c * 1000.0, rtol=1e-12)
            sd = [s.std[f"{kind[:-1]}{k}.{x}"] * 1000.0 for x in "xyz"]
            np.testing.assert_allclose(tr[f"{kind}_std_mm"][str(k)], sd, rtol=1e-12)
            assert 1e-4 < min(sd) < 1.0      # mm: fitted to micrometres, not metres
    # the target the simulation placed, found by the fit, in mm
    np.testing.assert_allclose(tr["targets_mm"]["T1"], [12.0, -5.0, 3.0], atol=0.5)
    noise = d["noise"]
    assert noise["axis_sigma_unit"].startswith("the axis' unit")
    assert noise["tracker"]["range_ppm"] == pytest.approx(model.noise_.tracker.range_ppm * 1000.0)
    assert "mm per m" in noise["tracker"]["units"]      # 0.5 ppm = 0.0005 mm per m of range


def test_round_trip_keeps_every_station(fitted, tmp_path):
    sim, model = fitted
    model.save(tmp_path / "m.json")
    back = ErrorModel.load(tmp_path / "m.json")
    for sid, (R, t, e) in model.setup_.stations.items():
        R2, t2, e2 = back.setup_.stations[sid]
        np.testing.assert_allclose(R2, R, atol=1e-15)
        np.testing.assert_allclose(t2, t, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(e2, e, rtol=1e-12, atol=1e-18)
    for sid in model.setup_.stations:   # the station's view of the same points
        p = np.array([[0.1, 0.2, 0.3], [-0.4, 0.0, 0.5]])
        np.testing.assert_allclose(back.setup_.to_tracker(p, sid), model.setup_.to_tracker(p, sid), atol=1e-12)
    model.save(tmp_path / "again.json")
    back.save(tmp_path / "back.json")
    again, twice = (json.loads((tmp_path / f).read_text())["tracker"]["stations"] for f in ("again.json", "back.json"))
    for sid, st in again.items():                           # written again, the same numbers (mm -> m -> mm)
        np.testing.assert_allclose(twice[sid]["correction_mm_deg"], st["correction_mm_deg"], rtol=1e-14)


def test_a_station_correction_in_si_is_refused_naming_its_field(fitted, tmp_path):
    """One station format per file version: ``correction_mm_deg`` (mm, deg). A file holding
    the pose correction under another key, or a damaged one, is refused with the field."""
    sim, model = fitted
    model.save(tmp_path / "m.json")
    d = json.loads((tmp_path / "m.json").read_text())
    sid = next(iter(d["tracker"]["stations"]))
    st = d["tracker"]["stations"][sid]
    v = st.pop("correction_mm_deg")
    st["correction"] = [x / 1000.0 for x in v[:3]] + [x * math.pi / 180.0 for x in v[3:]]
    (tmp_path / "old.json").write_text(json.dumps(d, indent=1))
    with pytest.raises(ModelFileError, match="correction_mm_deg"):
        ErrorModel.load(tmp_path / "old.json")
    st.pop("correction")
    st["correction_mm_deg"] = [0.0] * 5
    (tmp_path / "bad.json").write_text(json.dumps(d))
    with pytest.raises(ModelFileError, match=f"tracker.stations.{sid}.correction_mm_deg"):
        ErrorModel.load(tmp_path / "bad.json")
