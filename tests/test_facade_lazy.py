"""A facade name imports its own library module only (vecpin.workflows.facade.facade): a script's first
``vecpin.read_campaign`` no longer imports the diagnosis, the simulator and the table planning (3.7 s of CPU
against 0.74 s on the loaded 2-core development machine). Its text and signature stay the library function's.
Marked slow (a fresh Python, about 0.3 s on a quiet machine): the fast tier has no room left."""
import json
import subprocess
import sys

import pytest

CODE = """
import inspect, json, sys
import vecpin
f = vecpin.read_campaign
print(json.dumps({"modules": sorted(m for m in sys.modules if m.startswith("vecpin.")),
                  "parameters": list(inspect.signature(f).parameters), "doc": f.__doc__.split(";")[0]}))
"""


@pytest.mark.slow
def test_a_facade_name_imports_its_own_module_only():
    out = json.loads(subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True,
                                    check=True).stdout)
    assert "vecpin.measurement.campaign" in out["modules"]
    others = ("vecpin.diagnosis.diagnose", "vecpin.simulation.simulate", "vecpin.compensation.plan",
              "vecpin.workflows.tables")
    assert not [m for m in others if m in out["modules"]]
    assert out["parameters"] == ["path", "machine"] and out["doc"].startswith("Read and validate a campaign CSV")
