"""Issue 40: an option that changes nothing is refused, naming the one that would. The
Cartesian tracker sigma weighs Cartesian readings only; given with the spherical (default)
or range noise model it is refused, the library naming the parameters, the command line
its flags."""
import pytest

from vecpin.cli.common import noise
from vecpin.cli.main import build_parser
from vecpin.cli.options import as_flags
from vecpin.errors import InputError
from vecpin.measurement.noise import noise_from_options


@pytest.mark.parametrize("instrument, other", [("spherical", "`tracker_noise`"), ("range", "`tracker_noise`")])
def test_the_cartesian_sigma_without_the_cartesian_model_is_refused(flow, instrument, other):
    with pytest.raises(InputError) as err:
        noise_from_options(flow, instrument, tracker_sigma_mm=0.01)
    text = str(err.value)
    assert "`tracker_sigma_mm` 0.01" in text and "`cartesian`" in text and other in text
    assert noise_from_options(flow, "cartesian", tracker_sigma_mm=0.01).cartesian_sigma == pytest.approx(1e-5)


def test_the_command_line_names_the_flag_that_would_change_it(flow):
    args = build_parser().parse_args(["fit", "flow_xyzcb", "c.csv", "--out", "m.json", "--tracker-sigma-mm", "0.01"])
    with pytest.raises(InputError) as err:
        noise(args, flow)
    text = as_flags(err.value, args.flags)
    assert text.startswith("--tracker-sigma-mm 0.01:") and "--cartesian" in text and "--tracker-noise" in text
    assert "`" not in text
    args = build_parser().parse_args(["fit", "flow_xyzcb", "c.csv", "--out", "m.json", "--cartesian",
                                      "--tracker-sigma-mm", "0.01"])
    assert noise(args, flow).cartesian_sigma == pytest.approx(1e-5)
