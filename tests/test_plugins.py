"""Plug-ins from outside the package: an effect registered by a user's script is
simulated, parsed from the command line, listed, and found by the diagnosis."""
import numpy as np
import pytest

from vecpin.diagnosis.diagnose import diagnose
from vecpin.errors import InputError
from vecpin.models.effects import REGISTRY, Effect, Key, effects_help, parse_effect, register
from vecpin.simulation.simulate import Design, simulate


@pytest.fixture
def z_sag():
    """The toy effect of ARCHITECTURE.md, registered for one test only."""

    @register
    class ZSag(Effect):
        """Z droops with X squared times Y (a ram sagging as it reaches out)."""
        name = "z_sag"
        summary = "Z droop growing with X^2 Y"
        kinds = ("command",)
        geometric = True
        keys = (Key("power", 2.0, "", "exponent of the simulated droop"),)

        def parameters(self):
            return [self._p("droop", "length", 1e-3)]

        def command(self, q, feats):
            x, y = self.machine.axis("X"), self.machine.axis("Y")
            u, v = (q[:, x.index] - x.lower) / x.travel, (q[:, y.index] - y.lower) / y.travel
            S = np.zeros((len(q), self.machine.n_axes, 1))
            S[:, self.machine.axis("Z").index, 0] = u**2 * v
            return S

        @classmethod
        def candidates(cls, machine, feats):
            return [cls(machine)]

        def simulate_command(self, q, feats):
            x, y = self.machine.axis("X"), self.machine.axis("Y")
            u, v = (q[:, x.index] - x.lower) / x.travel, (q[:, y.index] - y.lower) / y.travel
            dq = np.zeros_like(q)
            dq[:, self.machine.axis("Z").index] = -1e-3 * u ** self.options.get("power", 2.0) * v
            return dq * self.scale

    yield ZSag
    REGISTRY.pop("z_sag", None)


def test_a_toy_effect_goes_through_simulate_and_diagnose(flow, z_sag):
    assert "z_sag: Z droop growing with X^2" in effects_help() and "power=2.0" in effects_help()
    with pytest.raises(InputError, match="unknown key 'bogus'"):
        parse_effect("z_sag:bogus=1", flow)
    effect = parse_effect("z_sag:strength=0.06,power=2.5,seed=3", flow)
    assert isinstance(effect, z_sag) and effect.options["power"] == 2.5 and effect.strength_mm == 0.06
    sim = simulate(flow, seed=5, design=Design(n_commands=220), effects=[effect])
    d = diagnose(flow, sim.campaign, effects=["z_sag", "backlash", "thermal"])
    assert [e.label for e in d.accepted] == ["z_sag"]
    assert d.accepted[0].shrink_pct > 5 and d.accepted[0].p_value < 1e-10
