"""An axis whose name is no NC address in a dialect asked for is refused before the
planning runs (it used to be refused after it, when the programs were written: a
minute lost per axis on a large plan), naming the axis and the option."""
import pytest
from hostile_helpers import refused

import vecpin.workflows.planning as planning_workflow


@pytest.mark.parametrize("dialect, address", [("fanuc", "Q"), ("gcode", "Q"), ("siemens-840d", "b_axis")])
def test_a_bad_nc_address_is_refused_before_planning(tmp_path, capsys, monkeypatch, dialect, address):
    def planned(*args, **kwargs):
        raise AssertionError("the plan was computed before the NC addresses were checked")
    monkeypatch.setattr(planning_workflow, "make_plan", planned)
    refused(["plan", "flow_xyzcb", "--points", "50", "--dialect", dialect, "--axis-map", f"B={address}",
             "--out", tmp_path / "p", "--quiet"], capsys, "axis 'B'", f"'{address}'", "--axis-map")
    assert not (tmp_path / "p").exists()
