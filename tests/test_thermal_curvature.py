"""The curvature per term the thermal prediction draws (vecpin.compensation.thermalheld):
a hierarchy of a curvature common to the terms and each term's deviation from it. Judged
by what a normal posterior must do in its limits, not by vecpin's own figures: a term the
campaign resolves (its standard deviation a twentieth of its estimate) is drawn as its
estimate +- that deviation; one it does not resolve is shrunk towards none; terms it does
not resolve beside one it does are drawn towards that one (the structure's common
curvature), not around their own estimates. And thermal.json's curvature record (per term,
or an older file's one for all terms) is checked field by field."""
import json

import numpy as np
import pytest

import vecpin
from vecpin.compensation.thermal import ThermalTerms, remaining_mm
from vecpin.compensation.thermalheld import curvature_draws
from vecpin.errors import InputError

N = 4000


def test_a_resolved_curvature_is_drawn_around_its_estimate():
    d = curvature_draws([0.02], [[0.001 ** 2]], np.random.default_rng(1), N)[:, 0]
    assert d.mean() == pytest.approx(0.02, rel=0.02) and d.std() == pytest.approx(0.001, rel=0.1)


def test_an_unresolved_curvature_is_shrunk_towards_none():
    d = curvature_draws([0.003], [[0.01 ** 2]], np.random.default_rng(2), N)[:, 0]
    assert abs(d.mean()) < 0.003 and np.median(np.abs(d)) < 0.01     # drawn around 0.003 +- 0.01: 0.0067


def test_unresolved_terms_are_drawn_towards_the_common_curvature():
    d = curvature_draws([0.010, 0.0, 0.0], np.diag([0.001, 0.05, 0.05]) ** 2, np.random.default_rng(3), N)
    assert d[:, 0].mean() == pytest.approx(0.010, rel=0.05)
    assert np.all((0.002 < d[:, 1:].mean(axis=0)) & (d[:, 1:].mean(axis=0) < 0.010))   # not 0, their estimate
    assert np.all(d[:, 1:].std(axis=0) < 0.05)                                           # nor their spread


def terms(curvature: dict) -> dict:
    zero = {"X": 0.0, "Y": 0.0, "Z": 0.0}
    t = ThermalTerms("flow_xyzcb", ["X", "Y", "Z"], 20.0, 1.0, dict(zero), {"X": 6.0, "Y": 0.0, "Z": 0.0},
                     dict(zero), None, t_range_c=(17.0, 23.0))
    cov = np.zeros((6, 6))
    cov[0, 0] = 0.1 ** 2                       # (um/K)^2: 1 um at 10 K
    t.held_out = {"names": [f"{a}.{k}_per_K" for a in "XYZ" for k in ("offset", "slope")], "cov": cov.tolist(),
                  "floor_um": 2.0, "blocks": 5, "lag_std_h": 0.0}
    t.curvature = curvature
    return t.to_dict()


@pytest.mark.parametrize("curvature, words", [
    ({"names": ["X", "Q"], "per_k": [0, 0], "cov_per_k": [[1, 0], [0, 1]], "alpha": [1, 0]},
     ["'curvature.names'", "tool_growth"]),
    ({"names": ["X"], "per_k": [0.01], "cov_per_k": [[1, 0]], "alpha": [1, 0]}, ["'curvature.cov_per_k'", "1 x 1"]),
    ({"names": ["X"], "per_k": ["a"], "cov_per_k": [[1]], "alpha": [1, 0]}, ["'curvature.per_k'", "one per name"]),
    ({"per_k": 0.01, "alpha": [1, 0]}, ["'curvature'", "std_per_k"]),
    ({"names": ["X", "tool_growth"], "per_k": [0, 0], "cov_per_k": [[1, 0], [0, 1]], "alpha": [1, 0],
      "growth_axis": "W"}, ["'curvature.growth_axis'", "'W'"]),
], ids=["name", "cov-shape", "per-k", "old-without-std", "growth-axis"])
def test_a_curvature_record_edited_by_hand_is_refused(tmp_path, curvature, words):
    (tmp_path / "thermal.json").write_text(json.dumps(terms(curvature)))
    with pytest.raises(InputError) as e:
        ThermalTerms.load(tmp_path / "thermal.json")
    assert all(w in str(e.value) for w in words) and "thermal.json" in str(e.value)


def test_an_older_file_with_one_curvature_still_predicts(tmp_path):
    m = vecpin.Machine.load("flow_xyzcb")
    old, new = tmp_path / "old.json", tmp_path / "new.json"
    old.write_text(json.dumps(terms({"per_k": 0.01, "std_per_k": 0.002, "alpha": [3.0, 0.0]})))
    new.write_text(json.dumps(terms({"names": ["X", "Y", "Z"], "per_k": [0.01, 0.0, 0.0],
                                     "cov_per_k": (np.diag([0.002, 0.05, 0.05]) ** 2).tolist(), "alpha": [3.0, 0.0]})))
    q = np.zeros((5, len(m.axes)))
    tool = np.full(5, 0.1)
    a, b = (remaining_mm(ThermalTerms.load(p), m, q, tool, 30.0) for p in (old, new))
    # only X has a thermal error, 6 um/K: its curvature 1 %/K (resolved in both: +-0.2 %/K) bends it by
    # 0.01 x (10^2 - 3) K = 0.97 K, 5.8 um; the straight terms' own error (0.1 um/K x 10 K) beside it
    for r in (a, b):
        assert r.low < r.point < r.high and r.point == pytest.approx(6.0 * 0.97 * 1e-3, rel=0.15)


def test_the_growth_and_the_axis_carrying_it_bend_apart():
    """A tool that keeps its direction along Z: its growth is Z's offset. A machine whose
    growth bends by +3 %/K and Z's expansion by -1 %/K (X, Y straight; Z's own offset 0;
    Z expanding about its mid-travel, the terms' P0; no noise; exact lag): the fit gives
    the offset (the growth) and the slope (Z's expansion) their own curvatures, each the
    truth's relative to the gain at T0:
    k / (1 + 2 k (T0 - 20)), the truth's curvature being about 20 degC (one shared
    curvature could follow neither)."""
    from thermal_truth import Truth, hall_day

    from vecpin.compensation.thermal import fit_thermal
    from vecpin.measurement.campaign import Campaign
    from vecpin.measurement.noise import NoiseModel
    from vecpin.models import make_model
    m = vecpin.Machine.load("trunnion_xyzac")
    rng = np.random.default_rng(11)
    mid = 0.5 * (m.axis("Z").lower + m.axis("Z").upper)
    truth = Truth(lag_s=3600.0, nonlinear={"X": 0.0, "Y": 0.0, "Z": -0.01}, offset={"X": 5e-6, "Y": -3e-6, "Z": 0.0},
                  centre={"X": 0.1, "Y": -0.05, "Z": mid}, growth=8e-6, growth_nonlinear=0.03)
    q, tool, tip, t, air = hall_day(m, truth, rng, 6)
    camp = Campaign(m.axis_names, q, tool, tip, extra={"time": t, "temperature": air})
    geo = make_model("6dof", m, 2).fit(camp, NoiseModel.default(m, "spherical"))
    terms, _ = fit_thermal(geo, camp, lags=(1.0,))
    c = terms.curvature
    per_k = dict(zip(c["names"], c["per_k"]))
    assert c["growth_axis"] == "Z" and terms.growth_um_per_k is None
    for name, k in (("tool_growth", 0.03), ("Z", -0.01)):
        assert per_k[name] == pytest.approx(k / (1 + 2 * k * (terms.t0_c - 20.0)), rel=0.1)
