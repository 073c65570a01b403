import os

# the tests run small matrices one after another: one BLAS thread is faster, and much
# faster on a loaded machine, than threads contending for the cores (set before numpy loads)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
if os.environ.get("PYTEST_XDIST_WORKER"):   # the test workers share the cores out already
    os.environ.setdefault("VECPIN_WORKERS", "1")

import numpy as np
import pytest

import vecpin
from vecpin.kinematics.machine import bundled_machines


@pytest.fixture(scope="session")
def machines():
    return {name: vecpin.Machine.load(name) for name in bundled_machines()}


@pytest.fixture(scope="session")
def flow(machines):
    return machines["flow_xyzcb"]


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def pytest_terminal_summary(terminalreporter):
    """One line on the real-controller tests (tests/test_linuxcnc_real.py): ran or skipped, and why."""
    seen = {}
    for outcome in ("passed", "failed", "skipped", "error"):
        for rep in terminalreporter.stats.get(outcome, []):
            if "test_linuxcnc_real.py" in getattr(rep, "nodeid", "") and rep.when in ("call", "setup"):
                seen.setdefault(outcome, set()).add(rep.nodeid)
    if seen:
        counts = ", ".join(f"{len(v)} {k}" for k, v in seen.items())
        why = ""
        if "skipped" in seen:
            rep = next(r for r in terminalreporter.stats["skipped"] if "test_linuxcnc_real.py" in r.nodeid)
            why = f" ({rep.longrepr[2] if isinstance(rep.longrepr, tuple) else rep.longrepr})"
        terminalreporter.write_line(f"real LinuxCNC controller tests: {counts}{why}")
