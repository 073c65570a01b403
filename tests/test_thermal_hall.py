"""The simulated hall (``vecpin simulate --temperature-profile``): the campaign and the
validation run read the profile (closed forms: a ramp, a sine), the validation run starts
when asked, and the controller's thermal terms act in the run through the tables as the
controllers' error line says (the correction worked out here by hand from the terms);
bad profiles are refused naming the field, the row and the column."""
import numpy as np
import pytest

import vecpin
from vecpin.compensation.thermal import ThermalTerms
from vecpin.errors import InputError
from vecpin.simulation.design import Design
from vecpin.simulation.simulate import simulate
from vecpin.simulation.temperature import Hall, parse_profile


def test_campaign_and_validation_follow_the_profile():
    m = vecpin.Machine.load("trunnion_xyzac")
    hall = Hall(parse_profile("warmup:18:28:3"), validation_after_s=4 * 3600.0)
    sim = simulate(m, seed=1, design=Design(n_commands=20, n_validation=6, nests=0), hall=hall)
    c, v = sim.campaign, sim.validation
    ramp = 18 + 10 * np.clip(c.time / 3600 / 3, 0, 1)               # the profile's own closed form
    assert np.abs(c.temperature - ramp).max() < 0.1                 # 0.02 degC sensor noise, 5 sigma
    assert v.time.min() >= c.time.max() + 4 * 3600 - 1e-6
    assert np.abs(v.temperature - 28).max() < 0.1
    cyc = parse_profile("cycle:20:2:6")
    assert cyc.at(np.array([1.5 * 3600]))[0] == pytest.approx(22.0)


def test_controller_corrects_by_the_error_line():
    m = vecpin.Machine.load("trunnion_xyzac")
    terms = ThermalTerms(m.name, ["X", "Y", "Z"], 20.0, 0.0, {"X": 0.0, "Y": 0.0, "Z": -225.0},
                         {"X": 6.0, "Y": -4.0, "Z": 9.0}, {"X": 11.5, "Y": 0.0, "Z": 0.0}, 5.0)
    hall = Hall(parse_profile("warmup:30:30:1"), thermal=terms)
    q = np.zeros((2, m.n_axes))
    q[:, m.axis("X").index] = [0.1, -0.2]                              # m
    qc, tool = hall.controller(m, q, np.full(2, 0.1), np.array([7200.0, 7300.0]), np.full(2, 30.0))
    dT = 10.0
    x_err_um = 6.0 * dT + 11.5 * dT * np.array([0.1, -0.2])          # a dT + b dT (p - P0), p in m
    assert qc[:, m.axis("X").index] - q[:, m.axis("X").index] == pytest.approx(-x_err_um * 1e-6, abs=1e-12)
    assert qc[:, m.axis("Z").index] == pytest.approx(-9.0 * dT * 1e-6, abs=1e-12)
    assert tool == pytest.approx(0.1 - 5.0 * dT * 1e-6, abs=1e-12)   # the grown tool taken back


def test_bad_profiles_are_refused_by_name(tmp_path):
    with pytest.raises(InputError, match="END 'x' is not a number"):
        parse_profile("warmup:18:x:3")
    with pytest.raises(InputError, match="PERIOD_H"):
        parse_profile("cycle:20:2:0")
    with pytest.raises(InputError, match="not a profile"):
        parse_profile("ramp:1:2")
    f = tmp_path / "hall.csv"
    f.write_text("time,temperature\n0,20\n3600,warm\n")
    with pytest.raises(InputError, match="row 3, column temperature"):
        parse_profile(str(f))
    f.write_text("time,temperature\n0,20\n0,21\n")
    with pytest.raises(InputError, match="row 3, column time"):
        parse_profile(str(f))
