"""One model specification (``ModelSpec``) feeds the constructor, ``with_effects``, the
model choice's candidates and the model file: each way gives the same model.

Independent check: the parameters' names and priors and the tool tips the models
compute at the same parameters, compared between models built the different ways;
knot positions written in mm compared with the SI knots divided by 1e-3 by hand."""
import json

import numpy as np
import pytest

from vecpin.errors import ModelFileError
from vecpin.measurement.noise import NoiseModel
from vecpin.models import APModel, ErrorModel, ModelSpec, SixDofModel, make_model
from vecpin.models.basis import AxisBasis
from vecpin.models.effects.coupled_axes import CoupledAxes
from vecpin.simulation.simulate import Design, simulate


def custom_bases(m):
    """A Chebyshev order 3 on X, a cubic spline with 4 knots on Y, order 1 elsewhere; a
    Fourier series with a trend on a rotary axis travelling more than a turn."""
    out = []
    for a in m.axes:
        if a.name == "Y":
            out.append(AxisBasis(a.lower, a.upper, 3, "bspline", knots=tuple(np.linspace(a.lower, a.upper, 6)[1:-1])))
        elif a.multiturn:
            out.append(AxisBasis(a.lower, a.upper, 2, "fourier_trend", rotary=True, trend=1))
        else:
            out.append(AxisBasis(a.lower, a.upper, 3 if a.name == "X" else 1, "chebyshev", rotary=a.kind == "rotary"))
    return out


def same_model(a: ErrorModel, b: ErrorModel, rng) -> None:
    assert a.spec == b.spec and type(a) is type(b)
    assert a.parameter_names == b.parameter_names
    np.testing.assert_array_equal(a.priors, b.priors)
    q = np.array([[rng.uniform(x.lower, x.upper) for x in a.machine.axes] for _ in range(5)])
    beta = rng.normal(0, 1e-5, a.n_parameters)
    np.testing.assert_array_equal(a.tool_tip(q, 0.2, beta).J_b, b.tool_tip(q, 0.2, beta).J_b)


@pytest.mark.parametrize("kind", ["6dof", "ap"])
def test_constructor_make_model_from_spec_and_with_effects_give_one_model(flow, rng, kind):
    cls = SixDofModel if kind == "6dof" else APModel
    opts = dict(tool_lengths=[0.2, 0.3], prior_scale=2.0, bases=custom_bases(flow))
    eff = [CoupledAxes(flow, ("X", "Y"))]
    built = cls(flow, 3, effects=eff, **opts)
    assert built.spec.kind == kind and built.spec.basis == "custom" and built.spec.orders[0] == 3
    same_model(built, make_model(kind, flow, 3, effects=eff, **opts), rng)
    same_model(built, ErrorModel.from_spec(flow, built.spec), rng)
    plain = cls(flow, 3, **opts)
    extended = plain.with_effects(eff)
    assert plain.effects == [] and extended.spec == plain.spec.with_effects(eff)
    same_model(built, extended, rng)
    assert extended.with_effects([]).spec == plain.spec


def test_a_rule_spec_rebuilds_its_bases_from_the_order(flow):
    spec = SixDofModel(flow, 4, basis="chebyshev").spec
    assert spec.basis == "chebyshev" and spec.orders == (4,) * flow.n_axes
    assert all(B.kind == "chebyshev" for B in spec.bases)
    auto = APModel(flow, 4).spec
    assert [B.kind for B in auto.bases] == ["fourier" if a.multiturn else "chebyshev" for a in flow.axes]
    assert ModelSpec.from_dict(auto.to_dict(flow), flow) == auto


@pytest.fixture(scope="module")
def fitted(flow):
    """A custom-basis AP model with a coupled-axes effect and a length correction per tool, fitted."""
    sim = simulate(flow, seed=3, design=Design(n_commands=50, n_validation=3))
    model = APModel(flow, 3, tool_lengths=list(sim.campaign.tool_lengths()), prior_scale=1.5,
                    bases=custom_bases(flow), effects=[CoupledAxes(flow, ("X", "Y"))])
    return sim, model.fit(sim.campaign, NoiseModel.default(flow))


def test_the_model_file_stores_the_spec_and_reads_it_back(fitted, flow, tmp_path, rng):
    sim, model = fitted
    model.save(tmp_path / "m.json")
    d = json.loads((tmp_path / "m.json").read_text())
    section = d["model"]
    assert section == json.loads(json.dumps(model.spec.to_dict(flow)))
    y = flow.axis("Y")
    np.testing.assert_allclose(section["axis_bases"][y.index]["knots"], np.array(model.bases[y.index].knots) / 1e-3,
                               rtol=1e-15)
    assert section["tool_lengths_mm"] == pytest.approx([t * 1000.0 for t in model.tool_lengths], rel=1e-15)
    back = ErrorModel.load(tmp_path / "m.json")
    same_model(model, back, rng)
    np.testing.assert_allclose(back.b_, model.b_, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(back.residuals(sim.campaign), model.residuals(sim.campaign), atol=1e-12)
    back.save(tmp_path / "again.json")
    assert json.loads((tmp_path / "again.json").read_text())["model"] == section


@pytest.mark.parametrize("field,value,match", [("basis", "auto", "model.basis 'auto'"),
                                               ("order", -1, "`order` -1"),
                                               ("axis_bases", [], "model.axis_bases")])
def test_a_damaged_model_section_is_refused_naming_it(fitted, tmp_path, field, value, match):
    sim, model = fitted
    model.save(tmp_path / "m.json")
    d = json.loads((tmp_path / "m.json").read_text())
    d["model"][field] = value
    (tmp_path / "bad.json").write_text(json.dumps(d))
    with pytest.raises(ModelFileError, match=match) as err:
        ErrorModel.load(tmp_path / "bad.json")
    assert "field 'model'" in str(err.value)
