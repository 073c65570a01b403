"""The diagnosis on simulated data whose effect was withheld from the base model."""
import numpy as np
import pytest

from vecpin.diagnosis.diagnose import diagnose
from vecpin.models import make_model
from vecpin.measurement.noise import NoiseModel
from vecpin.simulation.simulate import Design, simulate
from vecpin.simulation.effects import TrueEffect

pytestmark = pytest.mark.slow   # a long matrix: the edit loop (-m 'not slow') leaves it to CI

DESIGN = Design(n_validation=300)

EFFECTS = {
    "gantry_skew": (TrueEffect("gantry_skew", ("Y",), 0.05, {"about": "x", "depends": "X"}, seed=1), "gantry_skew[Y/x]"),
    "coupled_axes": (TrueEffect("coupled_axes", ("X", "Y"), 0.05, seed=4), "coupled_axes[X,Y]"),
    "thermal": (TrueEffect("thermal", (), 0.04, seed=3), "thermal[X,Y,Z]"),
    "backlash": (TrueEffect("backlash", ("X",), 0.03, seed=2), "backlash[X]"),
    "rotary_periodic": (None, None),  # the rotary axis differs per machine
    "instrument_shift": (TrueEffect("instrument_shift", (), 0.05, {"at": 0.6}, seed=5), "instrument_shift"),
}


def _validation_mean(model, sim):
    return np.linalg.norm(model.residuals(sim.validation_truth), axis=1).mean()


class _Floors(dict):
    """Noise-free validation error of the base model on each machine's clean campaign,
    and the diagnosis of that clean campaign (computed once per machine)."""

    def __init__(self, machines):
        super().__init__()
        self.machines = machines

    def __missing__(self, name):
        m = self.machines[name]
        sim = simulate(m, seed=10, design=DESIGN)
        model = make_model("6dof", m, 6).fit(sim.campaign, NoiseModel.default(m, "spherical"))
        self[name] = (sim, _validation_mean(model, sim), diagnose(m, sim.campaign))
        return self[name]


@pytest.fixture(scope="module")
def floors(machines):
    return _Floors(machines)


@pytest.mark.parametrize("machine", ["flow_xyzcb", "snk_120v"])
def test_nothing_is_significant_on_clean_data(floors, machine):
    _, _, d = floors[machine]
    assert not d.accepted and not d.outlier_rows
    assert all(not e.significant for e in d.effects)


CASES = [("flow_xyzcb", e) for e in EFFECTS] + [("snk_120v", e) for e in ("gantry_skew", "coupled_axes", "backlash")] + \
    [("ingersoll_xyzca", "rotary_periodic")]  # higher harmonics need an axis that turns: C travels 800 deg


@pytest.mark.parametrize("machine, effect", CASES)
def test_withheld_effect_is_found_and_recovers_the_gap(machines, floors, machine, effect):
    m = machines[machine]
    spec, label = EFFECTS[effect]
    if effect == "rotary_periodic":
        rot = [a.name for a in m.axes if a.kind == "rotary"][0]
        spec, label = TrueEffect("rotary_periodic", (rot,), 0.04, seed=7), f"rotary_periodic[{rot}]"
    sim = simulate(m, seed=10, design=DESIGN, effects=[spec])
    d = diagnose(m, sim.campaign)
    top = d.effects[0]
    assert top.significant
    assert top.label.startswith(label), [e.label for e in d.effects[:3]]
    # its size (how much it moves the model's prediction, RMS over the rows) is at most the
    # simulated strength (RMS tool-tip displacement over the campaign) and most of it where
    # the base model takes up little (measured: 0.036 for 0.04 of thermal, 0.042 for 0.05 of
    # coupled X-Y on flow_xyzcb; 0.011 for 0.05 of skew on snk_120v, whose base takes up most)
    assert 0.15 * spec.strength_mm < top.size_mm < 1.1 * spec.strength_mm, (top.size_mm, spec.strength_mm)
    # noise-free validation: the gap between the base model and the clean floor mostly closes
    floor = floors[machine][1]
    before = _validation_mean(d.base_model, sim)
    after = _validation_mean(d.best_model, sim)
    assert (before - after) > 0.5 * (before - floor), (before, after, floor)


def test_outliers_are_flagged(machines):
    m = machines["flow_xyzcb"]
    spec = TrueEffect("outliers", (), 0.5, {"fraction": 0.01}, seed=6)
    sim = simulate(m, seed=10, design=DESIGN, effects=[spec])
    d = diagnose(m, sim.campaign)
    simulated = sim.truth.effects[0]  # the effect instance the specification built
    assert d.outlier_rows == sorted(int(r) for r in simulated.outlier_rows)
    assert d.effects[0].name == "outliers" and d.effects[0].significant
    assert not [e for e in d.accepted if e.name != "outliers"]


def test_two_effects_are_both_found(machines):
    m = machines["flow_xyzcb"]
    effects = [EFFECTS["gantry_skew"][0], EFFECTS["backlash"][0]]
    sim = simulate(m, seed=11, design=DESIGN, effects=effects)
    d = diagnose(m, sim.campaign)
    labels = [e.label for e in d.accepted]
    assert "gantry_skew[Y/x]" in labels and "backlash[X]" in labels
    assert len(d.best_model.effects) >= 2


def test_diagnosis_files_and_localisation(machines, tmp_path):
    import json
    m = machines["flow_xyzcb"]
    sim = simulate(m, seed=12, design=Design(n_commands=200), effects=[EFFECTS["backlash"][0]])
    d = diagnose(m, sim.campaign)
    from vecpin.viz.diagnosis import draw_diagnosis
    paths = d.write(tmp_path, draw=draw_diagnosis)
    j = json.loads(paths["diagnosis"].read_text())
    assert set(j) >= {"base", "effects", "outlier_rows", "localization"}
    assert set(j["base"]) >= {"model", "heldout_mean_mm", "heldout_max_mm"}
    for e in j["effects"]:
        assert set(e) >= {"name", "axes", "significant", "heldout_mean_mm_before", "heldout_mean_mm_after",
                          "shrink_pct", "evidence"}
    assert j["effects"][0]["name"] == "backlash" and j["effects"][0]["axes"] == ["X"]
    assert j["effects"][0]["evidence"]
    # backlash shows as structure against the approach direction of X, not as noise
    assert j["localization"]["breakdowns"]["direction:X"]["structured"]
    assert j["localization"]["most_structured"][0] == "direction:X"
    assert (tmp_path / "figures" / "breakdowns.png").stat().st_size > 10_000
    assert "| rank | effect |" in paths["report"].read_text()
    from vecpin.models import ErrorModel
    best = ErrorModel.load(paths["model_best"])
    assert [e.label for e in best.effects] == ["backlash[X]"]
    np.testing.assert_allclose(best.residuals(sim.campaign), d.best_model.residuals(sim.campaign), atol=1e-12)
