"""The table face's readings checked before any fit (review of the indicator's sweeps, issue 39).

A sweep along one axis reads the face's slope along that axis only: without the nests' heights the fit
(and the diagnosis) refuse it before fitting, naming the option, rather than fit, save the model and fail
when the face is wanted; a setting that is no dict is refused, not a traceback. A model file whose sweep
has no standard deviation is refused naming the field, not read as an exact reading.
"""
from __future__ import annotations

import numpy as np
import pytest

from vecpin.errors import InputError, ModelFileError
from vecpin.fitting.problem import FitProblem
from vecpin.measurement.setup import Setup
from vecpin.models.modelfile import _table_face_from
from vecpin.simulation.simulate import Design, simulate
from vecpin.workflows.diagnosing import diagnose_to_dir


def test_one_sweep_without_heights_and_a_setting_no_dict_are_refused_before_the_fit(machines, tmp_path):
    m = machines["trunnion_xyzac"]
    c = simulate(m, seed=1, design=Design(n_commands=12, n_validation=2)).campaign
    with pytest.raises(InputError, match=r"`table_face` X: a sweep along X alone .* `nest_heights`"):
        FitProblem.build(m, c, table_face={"X": (300, 3.0)})
    with pytest.raises(InputError, match=r"`table_face` Y: a sweep along Y alone"):
        diagnose_to_dir(m, c, tmp_path / "d", table_face={"Y": (200, -1.0, 2.0)})
    assert not (tmp_path / "d").exists() or not any((tmp_path / "d").iterdir())
    with pytest.raises(InputError, match=r"`table_face`: give \{axis"):
        FitProblem.build(m, c, table_face=[("X", (300, 3.0))])
    both = FitProblem.build(m, c, table_face={"X": (300, 3.0), "Y": (250, -1.0)})
    assert both.table_face == {"X": (300, 3.0), "Y": (250, -1.0)}


def test_a_model_files_sweep_without_its_sd_is_refused(machines, tmp_path):
    m = machines["trunnion_xyzac"]
    tr = {"table_face": {"X": {"distance_mm": 300.0, "change_um": 3.0}}}
    with pytest.raises(ModelFileError, match=r"m.json.*tracker.table_face.*X: no sd_um"):
        _table_face_from(tmp_path / "m.json", tr, Setup(np.eye(3), np.zeros(3)), m)
    tr["table_face"]["X"]["sd_um"] = 2.0
    back = Setup(np.eye(3), np.zeros(3))
    _table_face_from(tmp_path / "m.json", tr, back, m)
    assert back.face_sweep["X"] == pytest.approx((0.3, 3e-6, 2e-6))
