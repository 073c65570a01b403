"""ISO 230-1 component errors of a model: checked against the model's own kinematics
(Pinocchio chain) and closed forms, the neutral CSV round trip, the hand-made fixture."""
import math

import numpy as np
import pytest
from export_helpers import DATA, E_XX_MM, E_YX_MM, X_MM, tiny_machine

from vecpin.errors import ControllerFileError
from vecpin.export import iso230
from vecpin.models import make_model
from vecpin.units import to_mm


def with_parameters(kind, machine, values: dict, order=2):
    """A 'fitted' model with chosen parameters (the rest zero)."""
    model = make_model(kind, machine, order)
    model.b_ = np.zeros(model.n_parameters)
    for name, v in values.items():
        model.b_[model.parameter_names.index(name)] = v
    model.cov_ = np.eye(6 + model.n_parameters) * 1e-12
    return model


def tip_change(model, q, tool=0.1):
    """Displacement of the tool tip and change of the tool direction caused by the model's errors."""
    out = model.tool_tip(q, tool, model.b_, jacobian=False)
    ref = model.tool_tip(q, tool, np.zeros_like(model.b_), jacobian=False)
    return out.tip - ref.tip, out.tool_dir - ref.tool_dir


def test_6dof_translation_of_a_rotary_axis_is_turned_into_machine_directions():
    """C's frame error dx = 10 um (moving frame): at C = 90 deg it moves the tip along +Y."""
    m = tiny_machine()
    model = with_parameters("6dof", m, {"C.dx.0": 1e-5})
    comp = {c.axis: c for c in iso230.component_errors(model, 5)}["C"]
    k = int(np.argmin(np.abs(comp.positions - math.pi / 2)))
    assert comp.positions[k] == pytest.approx(math.pi / 2)
    assert comp.errors["EXC"][k] == pytest.approx(0.0, abs=1e-15)
    assert comp.errors["EYC"][k] == pytest.approx(1e-5, rel=1e-9)
    q = np.zeros((1, 4))
    q[0, 3] = comp.positions[k]
    d_tip, _ = tip_change(model, q)
    np.testing.assert_allclose(d_tip[0], [comp.errors[f"E{D}C"][k] for D in "XYZ"], atol=1e-12)


def test_6dof_rotation_of_a_linear_axis():
    """X roll of 10 urad (EAX): the tool direction (0, 0, -1) turns by eps x u = (0, +1e-5, 0)."""
    m = tiny_machine()
    model = with_parameters("6dof", m, {"X.ex.0": 1e-5, "X.dy.1": 2e-6})
    comp = {c.axis: c for c in iso230.component_errors(model, 11)}["X"]
    np.testing.assert_allclose(comp.errors["EAX"], 1e-5, rtol=1e-12)
    for k in (0, 5, 10):
        q = np.array([[comp.positions[k], 0.0, 0.0, 0.0]])
        _, d_dir = tip_change(model, q)
        assert d_dir[0, 1] == pytest.approx(comp.errors["EAX"][k], rel=1e-4)
    # EYX is the straightness: 2 um x T1(x), Chebyshev T1 = -1 .. 1 over the travel
    np.testing.assert_allclose(comp.errors["EYX"], 2e-6 * np.linspace(-1, 1, 11), atol=1e-15)


def test_ap_names_what_is_an_iso_component_and_what_is_not():
    m = tiny_machine()
    model = with_parameters("ap", m, {"X->Y.1": 3e-6, "C->X.1": 4e-6, "X->C.1": 5e-6, "C.offset": 1e-4})
    comps = {c.axis: c for c in iso230.component_errors(model, 7)}
    assert {"EXX", "EYX", "EZX", "QCX"} == set(comps["X"].errors)        # C's angle as a function of X: not ISO
    assert {"EXC", "EYC", "EZC", "ECC"} == set(comps["C"].errors)
    q = np.zeros((7, 4))
    q[:, 0] = comps["X"].positions
    np.testing.assert_allclose(comps["X"].errors["EYX"], model.perturbation(q, model.b_)[:, 1], atol=1e-15)
    np.testing.assert_allclose(comps["X"].errors["QCX"], model.perturbation(q, model.b_)[:, 3] - 1e-4, atol=1e-15)
    np.testing.assert_allclose(comps["C"].errors["ECC"], 1e-4)         # C's own offset: angular positioning


def test_neutral_csv_round_trip_and_fixture(tmp_path):
    m = tiny_machine()
    model = with_parameters("6dof", m, {"X.dx.1": 1e-5, "X.ez.2": 3e-6, "C.dy.0": 2e-6})
    for c in iso230.component_errors(model, 21):
        text = iso230.write_neutral(c, m, "test")
        assert text.splitlines()[3].split(",")[:2] == [f"{c.axis}_{m.axis(c.axis).unit}", f"EX{c.axis}_mm"]
        p = tmp_path / iso230.neutral_name(c.axis)
        p.write_text(text)
        back = iso230.read_neutral(p, m)
        np.testing.assert_allclose(back.positions, c.positions, atol=1e-9)
        for name, v in c.errors.items():
            np.testing.assert_allclose(back.errors[name], v, atol=1e-12)
    fix = iso230.read_neutral(DATA / "iso230" / "ISO230_X.csv", m)
    np.testing.assert_allclose(to_mm(fix.positions), X_MM)
    np.testing.assert_allclose(to_mm(fix.errors["EXX"]), E_XX_MM, atol=1e-12)
    np.testing.assert_allclose(to_mm(fix.errors["EYX"]), E_YX_MM, atol=1e-12)


def test_bad_neutral_file(tmp_path):
    p = tmp_path / "ISO230_X.csv"
    p.write_text("X_mm,EXX_um\n0,0\n")
    with pytest.raises(ControllerFileError, match="unit 'um'") as exc:
        iso230.read_neutral(p, tiny_machine())
    assert exc.value.line == 1
    p.write_text("X_mm,EXX_mm\n0,0\n1\n")
    with pytest.raises(ControllerFileError, match="1 fields") as exc:
        iso230.read_neutral(p, tiny_machine())
    assert exc.value.line == 3
