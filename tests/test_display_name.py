"""The printed name of a model kind comes from one place, ``ErrorModel.display_name``:
a third registered kind is named by its own attribute in every table, figure and
report (no hard-coded {"6dof": "6-DoF", "ap": "AP"} that raises KeyError on it)."""
import re
from pathlib import Path

import numpy as np
import pytest

from vecpin.kinematics.machine import Machine
from vecpin.models import MODELS, make_model, register_model
from vecpin.models.ap import APModel
from vecpin.models.sixdof import SixDofModel
from vecpin.selection.choice import AxisChoice, Candidate
from vecpin.selection.orders import OrderRow, OrderSweep
from vecpin.viz import figures
from vecpin.viz.report import model_label

PACKAGE = Path(__file__).resolve().parents[1] / "vecpin"


@pytest.fixture
def third_kinds():
    """Two kinds registered for the test (and removed after it): one with a display name
    of its own, one without (shown by its kind)."""
    @register_model
    class NamedKind(APModel):
        kind = "ap_named_test"
        display_name = "AP (named test kind)"

    @register_model
    class PlainKind(APModel):
        kind = "ap_plain_test"
    yield NamedKind, PlainKind
    for k in (NamedKind.kind, PlainKind.kind):
        MODELS.pop(k, None)


def test_the_seeds_names():
    # Paper I writes the two models "6-DoF" and "AP"
    assert SixDofModel.display_name == "6-DoF" and APModel.display_name == "AP"
    assert MODELS["6dof"].display_name == "6-DoF" and MODELS["ap"].display_name == "AP"


def _sweep(kind):
    rows = [OrderRow(o, 10 + o, 0.1, 0.05 / (o + 1), 0.1, 0.06 / (o + 1), 0.12, 1.0) for o in (1, 2, 3)]
    return OrderSweep(kind, "chebyshev", "k-fold CV", (0.5, 1.0), (0.5, 1.0), rows)


def test_a_third_kind_is_named_everywhere(third_kinds, tmp_path):
    named, plain = third_kinds
    m = Machine.load("flow_xyzcb")
    for cls, shown in ((named, "AP (named test kind)"), (plain, "ap_plain_test")):
        model = make_model(cls.kind, m, 2)
        assert model.display_name == shown
        assert model.label().startswith(shown + " ")                       # models/base.py
        assert model_label(model) == f"{shown} order 2"                     # viz/report.py
        cand = Candidate(cls.kind, tuple(AxisChoice("chebyshev", 2) for _ in m.axes), 40, np.array([0.01, 0.02]))
        assert cand.label() == f"{shown} cheb2"                             # selection/choice.py
        table = _sweep(cls.kind).table()                                     # selection/orders.py
        assert re.search(rf"^{re.escape(shown)}\s+1\s", table, re.M)
        path = figures.order_sweep_figure([_sweep("ap"), _sweep(cls.kind)], tmp_path / f"{cls.kind}.png")  # viz/figures.py
        assert path.is_file() and path.stat().st_size > 1000


def test_no_hard_coded_kind_names_left():
    """The names live on the classes: no module maps kinds to names by itself."""
    pattern = re.compile(r"""["']6-DoF["']\s+if\s|\{\s*["']6dof["']\s*:\s*["']6-DoF["']""")
    found = [f"{p.relative_to(PACKAGE)}:{i}" for p in PACKAGE.rglob("*.py")
             for i, line in enumerate(p.read_text().splitlines(), 1) if pattern.search(line)]
    assert not found, found


def test_the_report_names_each_axis_basis_when_they_differ(flow):
    """A model whose axes carry different series (the data's choice) is not called
    "order N" in the report: its label lists each axis' basis, as the fit's choice table."""
    from vecpin.models.basis import AxisBasis
    orders = [4, 2, 3, 2, 5]
    bases = [AxisBasis(a.lower, a.upper, o, "chebyshev", rotary=a.kind == "rotary") for a, o in zip(flow.axes, orders)]
    mixed = make_model("6dof", flow, max(orders), bases=bases)
    assert model_label(mixed) == "6-DoF cheb4/cheb2/cheb3/cheb2/cheb5"
    assert model_label(make_model("6dof", flow, 3)) == "6-DoF order 3"     # one series order on every axis
