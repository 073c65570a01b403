"""The diagnosis names what is there and nothing else, says why, and turns the fitted
numbers into advice that matches the simulated truth."""
import numpy as np
import pytest

from vecpin.cli import main
from vecpin.compensation.plan import plan_tables
from vecpin.diagnosis.diagnose import diagnose
from vecpin.measurement.noise import NoiseModel
from vecpin.models.effects import REGISTRY, effects_help, parse_effect
from vecpin.simulation.effects import EffectSpec
from vecpin.simulation.floor import true_compensated_error
from vecpin.simulation.independent import IndependentMachine, layout
from vecpin.simulation.judge import validation_commands
from vecpin.simulation.simulate import Design, simulate

pytestmark = pytest.mark.slow   # a long matrix: the edit loop (-m 'not slow') leaves it to CI

DESIGN = Design(n_validation=10)


def truth_lines(truth, m) -> set[str]:
    """``rotary_periodic[A]`` for every rotary axis A travelling more than a turn on which a term of the
    independent ``truth`` has a harmonic of a whole number of cycles per turn, 3 or more: a periodic error the
    truth itself holds, which the diagnosis names rightly as carried by the base model."""
    return {f"rotary_periodic[{m.axes[sh.axis].name}]" for term in truth.terms for sh in term.shapes
            if m.axes[sh.axis].kind == "rotary" and m.axes[sh.axis].upper - m.axes[sh.axis].lower > 2 * np.pi
            and any(w >= 3 and float(w).is_integer() and (ca or sb) for w, ca, sb in sh.harmonics)}


def added_or_false(d, truth, m) -> list[str]:
    """The diagnosis' accepted names less the periodic errors the truth holds that the base model carries."""
    lines = truth_lines(truth, m)
    return [e.label for e in d.accepted if not (e.in_base and e.label in lines)]


@pytest.mark.parametrize("name, family", [("portal_xyzcb_c720", "windup"), ("gantry_xyzca", "periodic_drift")])
def test_clean_multi_turn_machines_name_nothing(name, family):
    """Machines vecpin never saw, C travelling 2-4 turns, errors outside vecpin's
    families, no effect: the chosen base model leaves nothing for an effect to explain (a periodic
    error of 3 or more cycles per turn the truth itself holds may be named as carried by the base model)."""
    m = layout(name)
    truth = IndependentMachine.random(m, family, seed=3)
    sim = simulate(m, seed=4, truth=truth, design=DESIGN)
    d = diagnose(m, sim.campaign, noise=NoiseModel.default(m, "spherical", tracker=truth.tracker.noise))
    assert not added_or_false(d, truth, m), d.summary()


def test_a_gantry_skew_is_found_alone_and_its_tables_help():
    """Ingersoll-type gantry skew on an independent XYZCA gantry (C over +-400 deg): found
    alone; the best model predicts the true machine far better than the base; its tables
    (the skew projected onto separable tables) leave the true machine no worse than
    the base model's. (The skew's product of X and the ram extension is
    not separable: tables carry only its projection.)"""
    m = layout("gantry_xyzca")
    truth = IndependentMachine.random(m, "periodic_drift", seed=5)
    spec = EffectSpec("gantry_skew", ("Y",), 0.06, {"about": "x", "depends": "X"}, seed=2)
    sim = simulate(m, seed=6, truth=truth, design=DESIGN, effects=[spec])
    noise = NoiseModel.default(m, "spherical", tracker=truth.tracker.noise)
    d = diagnose(m, sim.campaign, noise=noise)
    labels = added_or_false(d, truth, m)   # a periodic error the truth holds, carried by the base: not counted
    assert len(labels) == 1 and labels[0].startswith("gantry_skew[") and labels[0].endswith("/x]"), d.summary()
    q, tool = validation_commands(m, 300, seed=8)
    exact = truth.measure(q, tool, None, features=None)      # geometric truth incl. the skew (no features needed)
    from vecpin.units import norm_mm
    err = {k: norm_mm(mod.predict_tip(q, tool) - exact).mean() for k, mod in (("base", d.base_model), ("best", d.best_model))}
    assert err["best"] < 0.7 * err["base"], err
    base = true_compensated_error(truth, plan_tables(d.base_model, uncertainty=False).tables, q, tool, "reference")[0]
    best = true_compensated_error(truth, plan_tables(d.best_model, uncertainty=False).tables, q, tool, "reference")[0]
    assert best < 1.02 * base, (base, best)  # no worse; a twin-drive differential table carries the rest
    assert "gantry_skew" in d.headline()[1] and "What to do:" in d.headline()[2]


def _advice_numbers(d, label):
    e = next(e for e in d.accepted if e.label == label)
    sl = next(sl for eff, sl in d.best_model.effect_slices() if eff.label == label)
    return d.best_model.b_[sl], d.best_model.std_[sl], e.advice


def test_backlash_advice_matches_the_simulated_reversal(flow):
    sim = simulate(flow, seed=11, design=Design(n_commands=250), effects=[EffectSpec("backlash", ("X",), 0.04, seed=2)])
    d = diagnose(flow, sim.campaign, effects=["backlash", "thermal", "gantry_skew"])
    beta, sd, advice = _advice_numbers(d, "backlash[X]")
    sim_effect = sim.truth.effects[0]
    true_half = 0.5 * 1e-3 * sim_effect.scale        # the simulation's lag against the last move [m]
    assert abs(-beta[0] - true_half) < 3 * sd[0] + 0.02 * true_half
    rev = float(advice[0].split("reversal error ")[1].split(" ")[0])  # mm, as printed
    assert abs(rev - 2 * true_half * 1e3) < 3 * 2 * sd[0] * 1e3 + 0.002
    assert "MD32450" in advice[0] and "1851" in advice[0]


def test_thermal_advice_matches_the_simulated_expansion(flow):
    sim = simulate(flow, seed=12, design=Design(n_commands=250), effects=[EffectSpec("thermal", (), 0.04, seed=3)])
    d = diagnose(flow, sim.campaign, effects=["backlash", "thermal"])
    theta, sd, advice = _advice_numbers(d, "thermal[X,Y,Z]")
    scale = sim.truth.effects[0].scale
    truth_ppm = 11.5e-6 * scale                       # per K, every linear axis
    for k in range(3):
        assert abs(theta[k] - truth_ppm) < 3 * sd[k] + 0.05 * truth_ppm, (theta[k], truth_ppm, sd[k])
    printed = float(advice[0].split("scale ")[1].split(" ")[0])    # ppm/K as printed
    assert abs(printed - theta[0] * 1e6) < 0.05 + 1e-6
    assert "temperature compensation" in " ".join(advice)


def test_effect_specifications_refuse_what_they_do_not_know(flow):
    for text, msg in [("backlash", "needs axes="), ("gantry_skew:strength=0.05", "needs axes="),
                      ("thermal:foo=1", "unknown key 'foo'"), ("backlash:axes=X,strength=abc", "not a float"),
                      ("backlash:axes=Q", "no axis 'Q'"), ("nothing", "unknown effect"),
                      ("gantry_skew:axes=Y,about=w", "one of x, y, z"), ("thermal:strength=-1", "outside")]:
        with pytest.raises(Exception, match=msg):
            parse_effect(text, flow)
    text = effects_help()
    for name, cls in REGISTRY.items():
        assert name in text and all(f"{k.name}=" in text for k in cls.keys)
    assert "strength=MM" in text and "[fraction]" in text and "[degC]" in text


def test_simulate_help_effects_and_bad_effects_on_the_command_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(["simulate", "--help-effects"])
    assert e.value.code == 0 and "instrument_shift" in capsys.readouterr().out
    assert main(["simulate", "flow_xyzcb", "--out", str(tmp_path), "--effect", "backlash"]) == 2
    err = capsys.readouterr().err
    assert "needs axes=" in err and "Traceback" not in err


def test_report_opens_with_three_plain_sentences(flow, tmp_path):
    sim = simulate(flow, seed=13, design=Design(n_commands=200), effects=[EffectSpec("backlash", ("Y",), 0.04, seed=1)])
    d = diagnose(flow, sim.campaign, effects=["backlash", "gantry_skew"])
    paths = d.write(tmp_path)
    text = paths["report"].read_text().splitlines()
    assert text[2].startswith("Where:") and text[3].startswith("Which:") and text[4].startswith("What to do:")
    assert "backlash[Y]" in text[3] and "reversal error" in text[4]
    import json
    j = json.loads(paths["diagnosis"].read_text())
    means = [b["mean_mm"] for v in j["localization"]["breakdowns"].values() for b in v["bins"]]
    assert 0.005 < np.median(means) < 1.0          # millimetres, not metres
    assert j["effects"][0]["accepted"] and j["effects"][0]["explains"]


def test_model_best_goes_into_tables_view_and_report(flow, tmp_path, capsys):
    """A best model with a geometric effect (skew: into the tables) and a row-dependent one
    (thermal: advice instead) is accepted by tables, view and report."""
    sim = simulate(flow, seed=14, design=DESIGN,
                   effects=[EffectSpec("thermal", (), 0.08, seed=3),
                            EffectSpec("gantry_skew", ("Y",), 0.05, {"about": "x", "depends": "X"}, seed=1)])
    d = diagnose(flow, sim.campaign, effects=["thermal", "gantry_skew", "backlash"])
    assert {e.name for e in d.accepted} == {"thermal", "gantry_skew"}
    paths = d.write(tmp_path / "diag")
    from vecpin.measurement.campaign import write_campaign
    write_campaign(tmp_path / "c.csv", sim.campaign, flow)
    best = str(paths["model_best"])
    assert main(["tables", best, "--out", str(tmp_path / "t"), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "thermal[X,Y,Z] is not in the tables" in out and "ppm/K" in out
    assert main(["view", best, str(tmp_path / "c.csv"), "--html", str(tmp_path / "s.html")]) == 0
    assert main(["report", best, str(tmp_path / "c.csv"), "--out", str(tmp_path / "r"), "--quiet"]) == 0
