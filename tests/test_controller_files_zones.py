"""The controller files end to end (as tests/test_controller_files_e2e.py says) on production_xyzbaw's
East and West zones and the Master Mill's twin-drive X, whose true gantry turns when its drives
move apart. A module of its own so that the two test processes share the cases."""
import pytest
from controller_cases import e2e_tests

CASES = ("production_xyzbaw east", "production_xyzbaw west", "master_mill twin")  # trunnion, production: test_controller_files_e2e.py
pytestmark = pytest.mark.slow


case, test_the_files_as_written_give_the_machine_what_vecpin_predicts = e2e_tests(CASES)
