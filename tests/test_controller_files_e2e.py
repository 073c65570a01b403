"""What the machine gets is what vecpin predicts: the files vecpin writes for Siemens,
Fanuc, Heidenhain and LinuxCNC, read back by vecpin's readers *and* applied by
controllers simulated from the vendors' documentation or source (tests/controller_appliers.py:
own parsers, documented rules, nothing of vecpin's readers), on the true simulated machine
(tests/controller_cases.py): a trunnion whose X/Y/Z constants are tool-to-rotary-centre
offsets, production_xyzbaw whose W follows the rotaries, the same in its East and West
zones, and the Master Mill's twin-drive X whose true gantry turns when its drives move
apart. The true error equals that of the table set vecpin planned (within 2 %), is far
below the uncompensated one (below it at all where the controller's limits cost), and where it is more than 2 % above the full tables the
printout's and the README's first line say so; without the reference point data it is
worse. The real LinuxCNC runs the same files in tests/test_linuxcnc_real.py."""
import pytest
from controller_cases import e2e_tests

CASES = ("trunnion_xyzac", "production_xyzbaw")  # the zones and the twin drive: test_controller_files_zones.py
pytestmark = pytest.mark.slow


case, test_the_files_as_written_give_the_machine_what_vecpin_predicts = e2e_tests(CASES)
