import os

# the tests run small matrices one after another: one BLAS thread is faster, and much
# faster on a loaded machine, than threads contending for the cores (set before numpy loads)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

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
