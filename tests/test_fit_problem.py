"""The fit's shape: one table of settings (vecpin.fitting.settings.DEFAULTS) read by the
problem, the estimator and the command line; a frozen Setup the likelihood never changes;
``cv=`` taking one fold label per row, the choice then made on exactly those folds."""
import dataclasses

import numpy as np
import pytest

from vecpin.cli.main import build_parser
from vecpin.errors import InputError
from vecpin.fitting.estimator import ErrorModelCV
from vecpin.fitting.problem import FitProblem
from vecpin.fitting.settings import DEFAULTS
from vecpin.identification.folds import command_folds
from vecpin.identification.likelihood import Likelihood
from vecpin.measurement.campaignrows import Campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.setup import Setup
from vecpin.models import make_model
from vecpin.selection.choice import choose_or_fix
from vecpin.simulation.simulate import Design, simulate


@pytest.fixture(scope="module")
def sim(flow):
    return simulate(flow, seed=4, design=Design(n_commands=40, n_validation=2))


def test_one_table_of_defaults(flow):
    """The estimator's constructor, the problem's fields and the fit command's options default
    as the table says; an unknown setting is refused by name."""
    est = ErrorModelCV(flow).get_params()
    assert {k: est[k] for k in DEFAULTS} == {k: v for k, (v, _) in DEFAULTS.items()}
    fields = {f.name: f.default for f in dataclasses.fields(FitProblem) if f.name in DEFAULTS}
    assert fields == {k: v for k, (v, _) in DEFAULTS.items()} | {"noise_from_data": True}   # None resolved by build
    args = build_parser().parse_args(["fit", "flow_xyzcb", "c.csv", "--out", "m.json"])
    assert (args.folds, args.prior_scale, args.model, args.basis, args.order) == tuple(
        DEFAULTS[k][0] for k in ("cv", "prior_scale", "kind", "basis", "order"))
    with pytest.raises(InputError, match="no setting folds"):
        FitProblem.build(flow, Campaign(flow.axis_names, np.zeros((0, flow.n_axes)), np.zeros(0), np.zeros((0, 3))),
                         folds=3)


def test_the_likelihood_leaves_a_given_setup_as_it_was(flow):
    """Rows of a second tracker station: the likelihood places that station in its own copy;
    the setup handed to it keeps no station, and a frozen setup takes no new attribute."""
    rng = np.random.default_rng(0)
    q = flow.lower + rng.random((20, flow.n_axes)) * (flow.upper - flow.lower)
    tips = flow.tool_tip(q, 0.2)
    c = Campaign(flow.axis_names, q, np.full(20, 0.2), tips, station=(np.arange(20) >= 10).astype(int))
    given = Setup(np.eye(3), np.zeros(3))
    lik = Likelihood(make_model("6dof", flow, 0, basis="chebyshev"), c, NoiseModel.default(flow), setup=given)
    assert 1 in lik.setup.stations and given.stations == {}
    with pytest.raises(dataclasses.FrozenInstanceError):
        given.e0 = np.ones(6)


def test_fold_labels_give_the_choice_of_those_folds(flow, sim):
    """The folds a number gives, passed as labels (here as text): the same candidates with the
    same held-out means; the choice says what the folds group. Labels of another length
    are refused naming ``cv``."""
    c, noise = sim.campaign, NoiseModel.default(flow)
    fold = command_folds(c, 3, np.random.default_rng(0))
    settings = dict(kind="6dof", basis="chebyshev", order="auto")
    _, by_number = choose_or_fix(flow, c, noise, **settings, folds=3)
    labels = np.array([f"block {f}" for f in fold], dtype=object)
    _, by_label = choose_or_fix(flow, c, noise, **settings, folds=FitProblem.build(flow, c, noise, cv=labels).cv)
    assert not by_number.ends   # interleaved folds only: the same folds either way
    assert [cand.mean for cand in by_label.candidates] == pytest.approx([cand.mean for cand in by_number.candidates])
    assert by_label.chosen.label() == by_number.chosen.label()
    assert "grouped by the given fold labels" in by_label.to_dict()["method"]
    assert "grouped by pose" in by_number.to_dict()["method"]
    with pytest.raises(InputError, match="`cv`"):
        FitProblem.build(flow, c, noise, cv=labels[:-1])


def test_the_api_page_tables_the_settings_as_defined():
    """docs/api.md's settings table: every setting of DEFAULTS once, with its default."""
    from pathlib import Path
    text = (Path(__file__).resolve().parents[1] / "docs" / "api.md").read_text(encoding="utf-8")
    rows = {}
    for line in text[text.index("| setting | default | meaning |"):].splitlines()[2:]:
        if not line.startswith("|"):
            break
        name, value = (cell.strip() for cell in line.split("|")[1:3])
        rows[name] = value.strip("`")
    assert rows == {k: repr(v).replace("'", '"') for k, (v, _) in DEFAULTS.items()}
