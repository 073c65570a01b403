"""What `vecpin fit` imports (issue 43): scipy.linalg and Pinocchio, not scipy.optimize (and with it
scipy.sparse, scipy.special, scipy.fft, scipy.spatial), which only the smooth prior's L-BFGS needs and which
cost 0.25 s of CPU in every fit's process (0.75 times a whole plain reference fit). Marked slow (a fresh
Python, about 0.6 s of CPU): the fast tier has no room left."""
import json
import subprocess
import sys

import pytest

CODE = """
import json, sys
import vecpin.cli.main, vecpin.cli.fitting, vecpin.workflows.fitting
print(json.dumps(sorted(m for m in sys.modules if m.startswith(("scipy.", "vecpin.")))))
"""


@pytest.mark.slow
def test_the_fit_command_imports_no_scipy_optimize():
    loaded = json.loads(subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True,
                                       check=True).stdout)
    assert "scipy.linalg" in loaded and "vecpin.fitting.smoothprior" in loaded
    heavy = ("scipy.optimize", "scipy.stats", "scipy.sparse", "scipy.special", "scipy.fft", "scipy.spatial")
    assert [m for m in heavy if m in loaded] == []
