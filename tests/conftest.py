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
