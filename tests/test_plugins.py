"""Plug-ins from outside the package: an effect registered by a user's script is
simulated, parsed from the command line, listed, and found by the diagnosis."""
import numpy as np
import pytest

from vecpin.diagnosis.diagnose import diagnose
from vecpin.errors import InputError
from vecpin.models.effects import REGISTRY, Effect, Key, effects_help, parse_effect, register_effect
from vecpin.simulation.simulate import Design, simulate


@pytest.fixture
def z_sag():
    """The toy effect of ARCHITECTURE.md, registered for one test only."""

    @register_effect
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


def test_a_toy_controller_format_is_one_module(flow, tmp_path):
    """A format written outside the package (ARCHITECTURE.md): one CSV per table,
    position and value in mm/deg, registered, then used by the tables workflow; its
    reader gives back what its writer was given."""
    from pathlib import Path

    from vecpin.compensation.limits import NO_LIMITS
    from vecpin.compensation.tables import CompensationTable, TableSet
    from vecpin.errors import ControllerFileError
    from vecpin.export.common import ControllerFormat, no_check, read_lines, to_float
    from vecpin.export.registry import FORMATS, register_format
    from vecpin.models import make_model
    from vecpin.workflows.tables import make_tables

    def write(job):
        names = []
        for t in job.tables.tables:
            ai, ao = job.machine.axis(t.input_axis), job.machine.axis(t.output_axis)
            rows = [f"{p:.6f},{v:.6f}" for p, v in zip(ai.to_user(t.positions), ao.to_user(t.values))]
            job.out.write_text(f"{t.name}.csv", f"# {t.output_axis} from {t.input_axis}\n" + "\n".join(rows) + "\n")
            names.append(f"{t.name}.csv")
        return names

    def read(folder, machine, profile):
        tables = []
        for f in sorted(Path(folder).glob("*.csv")):
            if f.name.startswith("tables"):
                continue
            out, inp = machine.axis(f.stem[0].upper()), machine.axis(f.stem[1].upper())
            rows = [(k + 1, ln.split(",")) for k, ln in enumerate(read_lines(f)) if not ln.startswith("#")]
            pos = np.array([to_float(c[0], f, k, "position") for k, c in rows])
            val = np.array([to_float(c[1], f, k, "value") for k, c in rows])
            tables.append(CompensationTable(inp.name, out.name, float(inp.to_si(pos[0])),
                                            float(inp.to_si(pos[1] - pos[0])), out.to_si(val)))
        return TableSet(machine.axis_names, tables)

    register_format(ControllerFormat("toy-csv", "one CSV per table", NO_LIMITS, write, read, no_check,
                                     files="`<table>.csv`", sign="value = correction", source="this test",
                                     to_check="everything"))
    try:
        from vecpin.simulation.simulate import Design, simulate
        sim = simulate(flow, seed=4, design=Design(n_commands=120))
        model = make_model("ap", flow, 3).fit(sim.campaign)
        run = make_tables(model, tmp_path, "toy-csv", points=64, uncertainty=False)
        back = read(tmp_path, flow, None)
        assert sorted(t.name for t in back.tables) == sorted(run.plan.tables.names())
        for t in back.tables:  # written with 6 decimals in mm or deg
            ao = flow.axis(t.output_axis)
            np.testing.assert_allclose(ao.to_user(t.values), ao.to_user(run.plan.tables.table(t.name).values),
                                       atol=6e-7)
        (tmp_path / "xx.csv").write_text("0,1\nabc,2\n")
        with pytest.raises(ControllerFileError, match="line 2"):
            read(tmp_path, flow, None)
    finally:
        FORMATS.pop("toy-csv", None)
