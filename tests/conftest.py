import os

# the tests run small matrices one after another: one BLAS thread is faster, and much
# faster on a loaded machine, than threads contending for the cores (set before numpy loads)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
if os.environ.get("PYTEST_XDIST_WORKER"):   # the test workers share the cores out already
    os.environ.setdefault("VECPIN_WORKERS", "1")

import time

import numpy as np
import pytest

import vecpin
from vecpin.kinematics.axes import bundled_machines


@pytest.fixture(scope="session")
def machines():
    return {name: vecpin.Machine.load(name) for name in bundled_machines()}


@pytest.fixture(scope="session")
def flow(machines):
    return machines["flow_xyzcb"]


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def _linuxcnc_line(terminalreporter):
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


_BUDGET = "VECPIN_TIER_BUDGET_S"   # set by .ci/run for the fast tier: the run fails when it takes longer
_started = time.monotonic()


def _controller() -> bool:
    return not os.environ.get("PYTEST_XDIST_WORKER")


def _fast_tier_budget(config) -> float | None:
    """The fast tier's budget [s] (``VECPIN_TIER_BUDGET_S``) when this run is the fast tier
    (``-m "not slow"``), else None."""
    budget = os.environ.get(_BUDGET)
    fast = (config.getoption("markexpr") or "").replace("'", "").replace('"', "").strip() == "not slow"
    return float(budget) if budget and fast and _controller() else None


def pytest_sessionfinish(session, exitstatus):
    """The fast tier's wall time against its budget: over it, the run fails."""
    budget = _fast_tier_budget(session.config)
    if budget is not None and exitstatus == 0 and time.monotonic() - _started > budget:
        session.exitstatus = 1


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    """The real-controller line, and the fast tier's wall time beside its budget when one is set."""
    _linuxcnc_line(terminalreporter)
    budget = _fast_tier_budget(config)
    if budget is not None:
        took = time.monotonic() - _started
        verdict = "within" if took <= budget else "OVER"
        terminalreporter.write_line(f"fast tier wall time: {took:.0f} s, {verdict} its {budget:.0f} s budget")
