"""Effect terms: Jacobians through the whole tracker-frame prediction against finite
differences, and the effect registry."""
import numpy as np
import pytest

from vecpin.models.effects import (REGISTRY, Backlash, CoupledAxes, Effect, GantrySkew, InstrumentShift, RotaryPeriodic, Thermal,
                            effect_from_dict, register_effect)
from vecpin.measurement.features import Features
from vecpin.identification.likelihood import predict_tracker
from vecpin.measurement.setup import Setup
from vecpin.models import make_model
from vecpin.measurement.registration import rigid_registration
from vecpin.simulation.simulate import Design, simulate


@pytest.fixture(scope="module")
def small(machines):
    m = machines["flow_xyzcb"]
    sim = simulate(m, seed=3, design=Design(n_commands=12, n_validation=2))
    return m, sim.campaign, Features.from_campaign(sim.campaign)


def _effects(m, c):
    return [GantrySkew(m, ("Y",), about="x"), CoupledAxes(m, ("X", "C")), Thermal(m), Backlash(m, ("Z",)),
            RotaryPeriodic(m, ("C",)), InstrumentShift(m, t0=float(c.time[10]))]


@pytest.mark.parametrize("kind", ["6dof", "ap"])
@pytest.mark.parametrize("k", range(6))
def test_effect_jacobians_match_finite_differences(small, kind, k):
    m, c, f = small
    eff = _effects(m, c)[k]
    eff.prepare(c, f)
    model = make_model(kind, m, 2, effects=[eff])
    setup = Setup(*rigid_registration(m.tool_tip(c.q, c.tool), c.xyz))
    theta = np.random.default_rng(1).normal(size=model.n_parameters + 6) * 1e-5
    _, dy, _ = predict_tracker(model, c.q, c.tool, theta, setup, f)
    h = 1e-7
    for j in range(theta.size):
        e = np.zeros_like(theta)
        e[j] = h
        fd = (predict_tracker(model, c.q, c.tool, theta + e, setup, f, False)[0]
              - predict_tracker(model, c.q, c.tool, theta - e, setup, f, False)[0]) / (2 * h)
        np.testing.assert_allclose(dy[:, :, j], fd, atol=1e-6)


def test_effects_round_trip_and_registry(small):
    m, c, _ = small
    for e in _effects(m, c):
        assert effect_from_dict(e.to_dict(), m).label == e.label
    assert set(REGISTRY) >= {"gantry_skew", "coupled_axes", "thermal", "backlash", "rotary_periodic", "instrument_shift"}


def test_user_effect_can_be_registered(small):
    m, c, f = small

    @register_effect
    class ZDroop(Effect):
        """Z sags in proportion to the X position squared (a user's own effect)."""
        name = "z_droop_test"
        kinds = ("command",)

        def parameters(self):
            return [self._p("k", "length", 1e-3)]

        def command(self, q, feats):
            S = np.zeros((len(q), m.n_axes, 1))
            S[:, m.axis("Z").index, 0] = (q[:, m.axis("X").index] / 6.0) ** 2
            return S

    try:
        model = make_model("ap", m, 2, effects=[ZDroop(m)]).fit(c)
        assert model.parameter_names[-1] == "z_droop_test.k"
        assert effect_from_dict({"name": "z_droop_test"}, m).n_parameters == 1
    finally:
        REGISTRY.pop("z_droop_test")


def test_skew_advice_numbers_agree_with_each_other(flow):
    """The skew's range over an axis, its end-to-end change and its slope are one curve's
    numbers: slope x travel = end to end, and a curved skew says the rest is curvature."""
    import re
    e = GantrySkew(flow, ("Y",), about="x", orders={"X": 2, "Z": 0, "C": 0, "B": 0})
    line = next(s for s in e.advice(np.array([40e-6, 100e-6]), None) if "over X" in s)
    vals = [float(v) for v in re.findall(r"[-+]?\d+\.\d+", line)]
    ptp, travel, ends, slope = vals[0], vals[1], vals[2], vals[3]
    assert travel == pytest.approx(flow.axis("X").travel, abs=0.01)
    assert slope * travel == pytest.approx(ends, rel=0.01)
    assert ptp > ends and "curvature" in line      # a quadratic term: the range exceeds the end-to-end change
