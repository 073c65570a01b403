"""An export that holds far fewer points than the plan (cut short, or one of several
files) is imported with a warning that counts them; two lost sights are no warning."""
import warnings

import pytest
from test_importer import export

from vecpin.errors import VecpinWarning
from vecpin.measurement.importer import import_export
from vecpin.planning.plan import PlanSettings, make_plan
from vecpin.simulation.simulate import simulate


def test_an_export_missing_most_points_is_warned_of(flow, tmp_path):
    plan = make_plan(flow, PlanSettings(n_commands=20, order=1, candidates=200, sight=False, validation_points=20))
    (tmp_path / "plan.csv").write_text(plan.template.to_csv(flow))
    c = simulate(flow, 4, plan=(plan.template.q, plan.template.tool)).campaign
    n = len(c)
    short = export(tmp_path / "short.csv", c, plan.template, rows=range(n // 2))
    with pytest.warns(VecpinWarning, match=rf"short.csv: {n - n // 2} of the {n} points of the plan .*not in the export"):
        res = import_export(short, flow, tmp_path / "plan.csv")
    assert len(res.campaign) == n // 2
    nearly = export(tmp_path / "nearly.csv", c, plan.template, rows=[i for i in range(n) if i not in (3, 4)])
    with warnings.catch_warnings():
        warnings.simplefilter("error", VecpinWarning)
        assert len(import_export(nearly, flow, tmp_path / "plan.csv").campaign) == n - 2
