"""The controller files end to end (as tests/test_controller_files_e2e.py says) on production_xyzbaw's
East and West zones and the Master Mill's twin-drive X, whose true gantry turns when its drives
move apart. A module of its own so that the two test processes share the cases."""
import pytest
from controller_cases import CONTROLLERS, prepared_case, run_case

CASES = ("production_xyzbaw east", "production_xyzbaw west", "master_mill twin")  # trunnion, production: test_controller_files_e2e.py
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module", params=CASES)
def case(request, tmp_path_factory):
    return prepared_case(request.param, tmp_path_factory)


@pytest.mark.parametrize("controller", CONTROLLERS)
def test_the_files_as_written_give_the_machine_what_vecpin_predicts(case, controller, tmp_path):
    run_case(case, controller, tmp_path)
